"""column-collapse --sand dem: the column as DEM grains settled behind a gate (cases/column_collapse.py's
header says what and why); the scene, the settling and the summary read from the grains."""

from __future__ import annotations

import math
import sys

import numpy as np

from mpmdem import ContactLaw, InputError, Scene, rounded_rectangle, sphero_disk
from mpmdem.sim import gated_grains
from mpmdem.study.case import CaseSetup
from mpmdem.study.grain_deposit import connected_front, flank_angle, surface_profile

KN = 1.0e6  # N/m per m, the silo's grains (cases/silo_discharge.py)
KT = KN / 20.0  # the silo's k_t / k_n (MPM-SDEM Table 3's ratio)
#: the loose lattice the grains are placed on, in units of the column's height a L0, per grain shape:
#: tall enough to hold the grains of the settled column (φ 0.82 against the disks' lattice's ~0.65;
#: a pentagon's lattice cell is its bounding circle's, ~1.4 × its area), trimmed to them
LATTICE = {"disk": 1.5, "polygon": 2.2}
#: the box's length beyond the column, in units of Lube's larger runout fit (the MPM box's 1.5, doubled: disks
#: run out farther than sand, and farther with L0 / d)
BOX_RUNOUT = 3.0
#: --floor ledge: the box's length (to the pit's far wall), in L0
PIT_LENGTH = 2.5
#: --floor ledge: the run is this many times the collapse's (the heap left on the ledge creeps to rest in
#: ~20 sqrt(a L0 / g): disks roll without resistance)
HEAP_RUN = 5.0
#: wall plates' thickness, in L0
WALL = 0.1
#: profile.png draws at most this many grains as disks (more as pixels)
DRAWN_AS_DISKS = 50_000
#: --sand dem: the solver's choices (no grid). f64: a resting grain's overlap under its own weight, ρ_s g π r² / k_n
#: (1.5e-8 m at r = 0.5 mm), is below f32's spacing of positions a metre from the origin (1.2e-7 m at 1 m;
#: the tall columns run out to 2-5 m), so in f32 a surface grain's contact force could only jump by many
#: times its weight, and a grain slower than ulp/(2 dt) (a few mm/s there) would not move at all.
DEFAULTS_DEM = {"precision": "f64"}


def check(args) -> None:
    """InputError for a grain radius the column cannot hold or a floor grains cannot have."""
    r = args.grain_radius
    if not (math.isfinite(r) and 1e-5 <= r <= 0.05 * args.width and r <= 0.1 * args.aspect_ratio * args.width):
        raise InputError("--grain-radius", r, f"a grain radius in [1e-05 m, L0/20 = {0.05 * args.width:.4g} m] "
                         "and at most a tenth of the column's height")
    if args.floor == "fixed":
        raise InputError("--floor", "fixed", "rough (glued grains) or friction (a flat plate) with --sand dem: "
                         "fixed is the continuum's no-slip floor")


def _box(args) -> tuple[float, float]:
    """(length, height) [m] of the grains' domain above the floor: the column's reach (the pit's far
    wall with --floor ledge), and the lattice's height."""
    a, w = args.aspect_ratio, args.width
    reach = PIT_LENGTH * w if args.floor == "ledge" else (1.0 + BOX_RUNOUT * max(1.2 * a, 1.9 * a ** (2.0 / 3.0))) * w
    return reach, LATTICE[args.grain_shape] * a * w + 4.0 * args.grain_radius


def pit_depth(args) -> float:
    """Depth [m] of the pit beyond the ledge (--floor ledge; 0 otherwise): twice the column's height, at
    least 0.3 L0; the grains that fall in (at most the column's area) pile up lower than the ledge."""
    return max(2.0 * args.aspect_ratio, 0.3) * args.width if args.floor == "ledge" else 0.0


def _scene(args, gate: bool) -> Scene:
    """The box for grains: a frictionless wall at x = 0 (the symmetry plane, as the MPM case's slip
    wall), a frictionless lid and far wall, and the floor: a row of fixed disks of the mean grain
    radius, touching, centred on y = 0 (rough), or a flat plate with μ = tan φ (friction), or the rough
    floor ending at x = L0 over a pit (ledge); ``gate``: a frictionless plate at x = L0 holds the column."""
    from mpmdem.cases.column_collapse import GRAVITY, friction_angle

    length, height = _box(args)
    w, r = args.width, args.grain_radius
    t = WALL * w
    contact = ContactLaw(KN, KT, restitution=gated_grains.RESTITUTION)
    # (the domain reaches a grain radius past the walls: a grain pressed on a wall overlaps it a little)
    pit = pit_depth(args)
    scene = Scene(domain=((-r, -r - pit), (length + r, height + r)), gravity=(0.0, -GRAVITY), contact=contact)
    plates = [("left", t, height + 2 * t, (-0.5 * t, 0.5 * height), 0.0),
              ("right", t, height + pit + 2 * t, (length + 0.5 * t, 0.5 * (height - pit)), 0.0),
              ("lid", length + 2 * t, t, (0.5 * length, height + 0.5 * t), 0.0)]
    if args.floor == "ledge":  # the ledge's face under the last glued disk, and the pit's floor
        plates += [("ledge", t, pit - r, (w - 0.5 * t, -0.5 * (pit + r)), 0.0),
                   ("pit", length - w + 2 * t, t, (0.5 * (w + length), -pit - 0.5 * t), gated_grains.GRAIN_FRICTION)]
    if args.floor == "friction":
        mu = math.tan(math.radians(friction_angle(args)))
        plates.append(("floor", length + 2 * t, t, (0.5 * length, -0.5 * t), mu))
    else:
        disk = sphero_disk(r)
        end = w - r if args.floor == "ledge" else length
        for k in range(int(math.floor(end / (2.0 * r) + 1e-9)) + 1):
            scene.add_rigid_body(disk, density=1000.0, position=(2.0 * r * k, 0.0), motion="fixed",
                                 friction=gated_grains.GRAIN_FRICTION, name=f"floor{k}")
    if gate:
        plates.append(("gate", t, height + 2 * t, (w + 0.5 * t, 0.5 * height), 0.0))
    for name, pw, ph, centre, mu in plates:
        scene.add_rigid_body(rounded_rectangle(pw, ph), density=1000.0, position=centre, motion="fixed",
                             friction=mu, name=name)
    return scene


def floor_top(args) -> float:
    """y [m] of the floor's top: the glued disks' top r (rough, ledge), 0 (friction)."""
    return 0.0 if args.floor == "friction" else args.grain_radius


def build(args) -> CaseSetup:
    """Grains on a loose lattice over the column's place, trimmed to those that settle to a L0,
    settled behind the gate, then moved into the box without it (mpmdem.sim.gated_grains)."""
    from mpmdem.cases.column_collapse import DENSITY, GRAVITY, collapse_time
    from mpmdem.model.grains import place_grains
    from mpmdem.sim.simulation import default_device

    check(args)
    a, w = args.aspect_ratio, args.width
    y0 = floor_top(args)
    _, height = _box(args)
    closed = _scene(args, gate=True)
    region = [(0.0, y0), (w, y0), (w, height), (0.0, height)]
    placed = place_grains(region, radius=args.grain_radius, shape=args.grain_shape,
                          density=gated_grains.grain_density(DENSITY), friction=gated_grains.GRAIN_FRICTION,
                          seed=args.seed, name="sand")
    closed.add_grain_set(gated_grains.lowest_grains(placed, gated_grains.PACKING_FRACTION * a * w * w))
    device = args.device or default_device()
    precision = getattr(args, "precision", None) or DEFAULTS_DEM["precision"]
    packing, seconds = gated_grains.settle_behind_gate(closed, precision=precision, device=device,
                                                       height=height - y0, gravity=GRAVITY,
                                                       settle_max=args.settle_max)
    scene = _scene(args, gate=False)
    grains = scene.add_grain_set(packing.grains[0])
    scene.add_mass_probe("all")
    scene.add_mass_probe("beyond_gate", lo=(w, -math.inf))
    settled = gated_grains.settled_record(packing, seconds)
    top = _column_top(grains.position, grains.bounding_radius, w, 4.0 * args.grain_radius)
    settled.update(height_m=top, aspect_ratio=(top - y0) / w)
    args.settled = settled  # (for the summary: the case's functions share only the flags)
    if not getattr(args, "quiet", False):
        print(f"column-collapse: {len(grains)} grains settled in {packing.time:.3g} s ({seconds:.3g} s wall): "
              f"packing fraction {packing.packing_fraction:.3f}, bulk density {packing.bulk_density:.0f} kg/m^3, "
              f"height {top - y0:.4g} m (a = {(top - y0) / w:.3g})", file=sys.stderr)
    tau = collapse_time(args)
    end = (6.0 if args.quick else 7.0) * tau * (HEAP_RUN if args.floor == "ledge" else 1.0)
    return CaseSetup(scene, end_time=end, frames=60 if args.quick else 70, config=dict(DEFAULTS_DEM))


def _column_top(x: np.ndarray, r: np.ndarray, width: float, strip: float) -> float:
    """y [m] of a settled column's top: the mean over strips of ``strip`` [m] across its width of
    the highest grain top (y + r) in each."""
    _, top = surface_profile(x, r, 0.0, strip, end=width)
    return float(np.nanmean(top))


def summarize(sim, result, args) -> dict:
    """The MPM summary's fields, read from the grains (see the case's header), with the settled
    column, the connected front and the deposit's flank angle."""
    from mpmdem.cases import column_collapse as cc
    from mpmdem.io import RunFile

    a, w = args.aspect_ratio, args.width
    grains = sim.scene.grains[0]
    k0 = len(sim.scene.rigid_bodies)
    mass = grains.mass
    r = grains.bounding_radius
    d = 2.0 * float(np.mean(np.sqrt(grains.area / math.pi)))  # mean equivalent diameter
    with RunFile(result.path) as rf:
        times = rf.times
        diag = rf.diagnostics
        positions = [np.asarray(rf.body_field("x", k), dtype=float)[k0:] for k in range(rf.frame_count)]
    x0, x1 = positions[0], positions[-1]
    y0 = floor_top(args)
    # --floor ledge: the heap is what stays on the ledge (the grains in the pit lie below y = 0)
    kept = x1[:, 1] > 0.0 if args.floor == "ledge" else np.ones(len(x1), bool)
    xk, mk, rk = x1[kept], mass[kept], r[kept]
    # the front as the MPM summary reads it (cc.deposit_front), on bins of two grain diameters
    length = cc.deposit_front(xk, mk, cc.DENSITY, 2.0 * d, 0.0, cc.FRONT_THICKNESS * w)
    connected = connected_front(xk, rk, 0.0, 2.0 * d)
    farthest = float((xk[:, 0] + rk).max())
    near_wall = xk[:, 0] < 2.0 * d
    height = float((xk[near_wall, 1] + rk[near_wall]).max()) - y0 if near_wall.any() else 0.0
    kinetic = cc.motion_energy(times, positions, mass)
    # the flow has stopped when the deposit (the grains inside its connected front) is at rest: a
    # thrown disk rolls on along the floor (no rolling resistance) long after
    deposit = kept & (x1[:, 0] - r <= connected)
    stop = cc.stop_time(times, cc.motion_energy(times, [p[deposit] for p in positions], mass[deposit]))
    stop_all = cc.stop_time(times, kinetic)
    tau = cc.collapse_time(args)
    centres, top = surface_profile(xk, rk, 0.0, 2.0 * d, end=min(connected, w) if args.floor == "ledge" else connected)
    flank = flank_angle(centres, top, floor=y0)
    # the steepest secant from the surface to the connected front: the deposit lies under the line of
    # this slope that ends at the front (the bound of tests/cases/test_column_dem.py's area argument)
    ahead = [(t - y0) / (connected - c) for c, t in zip(centres, top, strict=True) if c < connected - d]
    secant = math.degrees(math.atan(max(ahead))) if ahead else None
    pred_runout, pred_height = cc.lube_runout(a), cc.lube_height(a)
    runout = (length - w) / w
    total = np.asarray(diag["mass_all"])
    settled = dict(getattr(args, "settled", {}))
    out = {
        "sand": "dem", "aspect_ratio": a, "initial_width_m": w, "initial_height_m": a * w, "floor": args.floor,
        "grain_radius_m": args.grain_radius, "grain_diameter_mean_m": d, "grain_shape": args.grain_shape,
        "grain_density": grains.density, "grain_friction": grains.friction, "normal_stiffness": KN,
        "tangential_stiffness": KT, "restitution": gated_grains.RESTITUTION, "seed": args.seed,
        "grains": len(grains), "width_in_diameters": w / d,
        "settled": settled, "settled_aspect_ratio": settled.get("aspect_ratio"),
        "runout_m": length - w, "normalized_runout": runout,
        "runout_connected_m": connected - w, "normalized_runout_connected": (connected - w) / w,
        "runout_farthest_point_m": farthest - w, "normalized_runout_farthest_point": (farthest - w) / w,
        "front_thickness_m": cc.FRONT_THICKNESS * w, "front_bin_m": 2.0 * d,
        "final_height_m": height, "normalized_final_height": height / w,
        "final_height_max_m": float((x1[:, 1] + r).max()) - y0,
        "flank_angle_deg": flank["angle_deg"], "flank_angle_stderr_deg": flank["angle_stderr_deg"],
        "surface_secant_angle_deg": secant, "flank_bins": flank["bins"], "flank_x_range_m": flank["x_range_m"],
        "heap_mass_fraction": float(mk.sum() / mass.sum()),
        "stop_time_s": stop, "stop_time_normalized": stop / tau if stop is not None else None,
        "stop_time_all_grains_s": stop_all, "grains_beyond_front": int(np.count_nonzero(~deposit)),
        "collapse_time_scale_s": tau, "kinetic_energy_peak": float(kinetic.max()),
        "mass_initial": float(total[0]), "mass_final": float(total[-1]),
        "mass_change_relative": float(abs(total[-1] - total[0]) / total[0]),
        "reached_far_wall": bool(farthest >= _box(args)[0] - d),
        "scaling": cc.SCALING, "predicted_normalized_runout": pred_runout,
        "predicted_normalized_final_height": pred_height, "runout_ratio_to_prediction": runout / pred_runout,
        "reference_runout_band": list(cc.runout_band(a)), "height_ratio_to_prediction": (height / w) / pred_height,
        "dt": float(np.asarray(diag["dt"])[-1]),
    }
    _plot(x0, x1, r, w, a, y0, result.path.parent / "profile.png", heap=args.floor == "ledge")
    return out


def _plot(x0, x1, r, w, a, y0, path, heap: bool = False) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import EllipseCollection

    from mpmdem.cases.column_collapse import lube_height, lube_runout

    fig, ax = plt.subplots(figsize=(8, 3.5))
    for x, colour in ((x0, "0.8"), (x1, "C0")):
        if len(x) > DRAWN_AS_DISKS:  # (hundreds of thousands of disks: pixels, not ellipses)
            ax.scatter(x[:, 0] / w, (x[:, 1] - y0) / w, s=0.05, marker="s", color=colour, lw=0, rasterized=True)
            continue
        ax.add_collection(EllipseCollection(2 * r / w, 2 * r / w, 0.0, units="xy", offsets=(x - [0.0, y0]) / w,
                                            offset_transform=ax.transData, facecolor=colour, edgecolor="none",
                                            alpha=0.6 if colour == "C0" else 1.0))
    for colour, label in (("0.8", "settled"), ("C0", "final")):
        ax.plot([], [], "o", color=colour, label=label)
    xr = 1.0 + lube_runout(a)
    if not heap:  # (a heap on a ledge is no collapse on a floor)
        ax.axvline(xr, color="C3", ls="--", lw=1, label="Lube et al. 2005 (set A): $L_f$")
        ax.axhline(lube_height(a), color="C3", ls=":", lw=1, label="$H_f$")
    name = "heap on a ledge" if heap else "column collapse"
    ax.set(xlabel="x / L0", ylabel="y / L0", aspect="equal", xlim=(0.0, max(float(x1[:, 0].max()) / w, xr) + 0.05),
           ylim=(0.0, 1.05 * max(a, float(x0[:, 1].max()) / w)), title=f"{name}, grains, a = {a:g}")
    ax.legend(fontsize=7, loc="center right")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
