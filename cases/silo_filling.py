# Silo filling: "Granular MPM" §4.3, Table 4, Figs. 14-16.
# A flat-bottom silo (after Wójcik et al., the paper's ref. [25]) is filled from the top: every
# 0.17 s three points, each with the mass and spacing of a 0.15 m square, appear in the middle of
# the three central cells of the top row of a 0.3 m grid and fall in. They first fall freely
# (disconnected), then land on the pile, interact and stop, and the pile below is compacted by the
# weight above: the three stages of granular flow in one run. The paper contrasts the deposit of
# stress-free MPM (loose, irregular, points still moving at 4-6 m/s) with Granular MPM's (tight,
# regular, 0-1 m/s) and has Granular MPM fill only about half the silo with all 504 points.
#
# Choices, and differences from the paper's set-up:
# - The silo walls. The paper makes them of a linear elastic body (Table 4: E = 1 GPa, ρ = 2250,
#   stiffer and thicker than the real silo "for numerical reasons") fixed at the sides. Here the
#   side walls are the domain's own "fixed" (no-slip) walls: an elastic wall meshed in the same
#   grid shares nodes with the fill, which makes it a no-slip contact too, and a wall fixed at its
#   outer side that is as stiff as the fill and several cells thick barely moves under a few
#   metres of fill, so the rigid wall is what the elastic one approximates, at no cost.
# - The floor is a fixed obstacle (Scene.add_obstacle) under the silo instead of the domain's
#   bottom wall: it acts the same (its nodes are fixed), and the solver measures the force on
#   obstacles, so the floor becomes a load cell. With no-slip side walls part of the weight hangs
#   on the walls (Janssen), so floor load / deposited weight < 1 is expected once points settle.
# - Releases at t = 0, 0.17, 0.34 ... s: 168 of them for 504 points, the last at 28.39 s, and the
#   paper's t_total = 28.56 s = 168 × 0.17 s, so the last few points are still falling at the end
#   of the full run (the summary counts only points that had time to land, see DEPOSIT_DELAY).
# - Release positions: the centres of the three cells, each shifted in x by a seeded uniform random
#   offset of at most ±3 cm (--jitter; 0 gives the exact centres). Without it every point of a
#   column lands exactly on the axis of the one below, the grid velocities of a column one point
#   wide are symmetric about that axis, and nothing can push a point sideways: each column stays a
#   stack of points flattened by their impacts (ψ = 0 makes the plastic flow isochoric, so a point
#   squashed vertically widens). Seen with every shape tried (linear, bspline2, cpgimp, cpdi1); in
#   full runs with cpgimp and cpdi1 the three stacks grew up the silo until, at t ≈ 17 s, 16
#   flattened points sat in one cell and the run stopped (the interaction-search bins overflowed).
#   Real grains never land dead-centre; a few cm of scatter (a fifth of a point) is enough for the
#   columns to topple and the pile to spread over the whole floor.
# - Original MPM (the linear shape, the paper's "Granular original MPM" of Fig. 15, whose deposit
#   the text describes) with the MUSL update and the APIC transfer (DEFAULTS). With USL, a lone
#   point landing on the pile at 6-7 m/s with E = 1 GPa can take a huge strain increment from a
#   nearly massless node as it crosses a cell; MUSL re-maps the velocities from the updated points
#   first. cpdi1 (the paper's Granular CPDI of Fig. 16) also runs cleanly (--shape cpdi1 --update
#   USL). Other transfers, tried on 150 points: PIC gathered 42 points into one cell by t = 5.4 s
#   (the run stopped); pure FLIP kept points moving at 1.3 m/s in the deposit and made the floor
#   load noisy (even negative at the last frame).
#
# What it gives (full run, 504 points, CPU, ≈ 4 min): the mass is exact at every frame, the deposit
# is at rest (0-0.2 m/s, the paper's Granular range being 0-1 m/s) and every point sits at or just
# above the critical density, but the pile is loose: the points form an open network with voids
# (packing ≈ 0.55 of the section) that reaches ≈ 95 % of the silo's height, where the paper's
# Granular original MPM fills about half of it. cpdi1 ends the same (98 %) and --jitter 0.07 too
# (96 %). With one point per 0.3 m cell, points that share nodes move as one continuum, so chains
# of points lock into arches around voids that the grid never sees. The paper's figures are not
# reproduced quantitatively.
"""Silo filling (Granular MPM §4.3): points fed in from the top, deposit height, packing and speed."""

import math
import sys

import numpy as np

from mpmdem import MohrCoulomb, Scene, rectangle
from mpmdem.study.case import CaseSetup
from mpmdem.study.flag_types import count_at_least, given, non_negative
from mpmdem.study.validation import Check
from mpmdem.study.variants import Variant

NAME = "silo-filling"
DESCRIPTION = "a flat-bottom silo filled from the top, 3 points every 0.17 s (stress-free vs Granular MPM)"
DEFAULTS = {"granular": True, "shape": "linear", "transfer": "APIC", "update": "MUSL", "precision": "f64",
            "dt": 5.0e-5}

VALIDATION = [
    Check("fill_fraction", 0.5, "Granular MPM §4.3 (Fig. 15, 27.79 s): all 504 points fill about half the silo",
          0.1, "'about half' read from the figure to a tenth of the height; 504 points of 0.15 m without voids "
          "fill 0.56 of it, so the paper's deposit is void-free", relative=False,
          known_gap="the pile is an open network with voids: with one point per cell, points that share nodes lock "
                    "into arches (see the header); the quick run feeds only the first few points",
          gap_bounds=(0.35, 0.50), gap_source="the full run (504 points): 0.90 on the H100 (validation table), 0.95 on "
          "a CPU, 0.98 with cpdi1, 0.96 with --jitter 0.07 (the header), rounded outward to 0.05; quick (30 points, "
          "3.7 s): 0.12 on a CPU, rounded outward to 0.05",
          quick_gap_bounds=(-0.40, -0.35)),
]

GRAVITY = 9.81  # m/s²
# "Granular MPM" Table 4
H = 0.30  # m, grid spacing
DT = 5.0e-5  # s
T_TOTAL = 28.56  # s (= 168 releases × 0.17 s)
WIDTH, HEIGHT = 2.7, 7.5  # m, the silo (9 × 25 cells)
E, NU, RHO, RHO_CR = 1.0e9, 0.3, 2250.0, 2235.0  # Pa, -, kg/m³, kg/m³ (fill; the silo body: same E, ν, ρ)
PHI, PSI, ETA = 30.0, 0.0, 0.15  # deg, deg, Pa s²
# §4.3 text
POINT_SIZE = 0.15  # m, edge of the square each point stands for (mass ρ × 0.15²)
INTERVAL = 0.17  # s between releases
PER_RELEASE = 3
PAPER_POINTS = 504
FLOOR_ROWS = 2  # cells of obstacle (the floor load cell) below y = 0, inside the domain
# where the points appear: the centres of the three middle cells of the top row
RELEASE_X = WIDTH / 2 + H * np.array([-1.0, 0.0, 1.0])  # m
RELEASE_Y = HEIGHT - 0.5 * H  # m
# A point counts as deposited once it has had the time to fall the whole silo onto the bare floor
# and half a second more to come to rest on the pile.
DEPOSIT_DELAY = math.sqrt(2.0 * RELEASE_Y / GRAVITY) + 0.5  # s (1.72 s)
JITTER = 0.03  # m, largest random x offset of a release position (see the header)
SLOW = 1.0  # m/s, the top of the paper's 0-1 m/s range of Granular MPM's deposit


def add_arguments(parser):
    parser.add_argument("--points", type=count_at_least(3), default=None,
                        help=f"points released in all, a multiple of 3 (default {PAPER_POINTS}; 30 with --quick)")
    parser.add_argument("--settle", type=non_negative("s"), default=None,
                        help="time run after the paper's t_total-equivalent (points/3 × 0.17 s) [s] "
                             "(default 0, the paper's length; 2 with --quick, so the last points land and rest)")
    parser.add_argument("--jitter", type=non_negative("m"), default=JITTER,
                        help=f"release positions are shifted by a uniform random ±jitter in x [m] (default {JITTER})")
    parser.add_argument("--compare", action="store_true",
                        help="also run stress-free MPM (one grid, no density control) for the summary; slow: "
                             "its points lose density, which shrinks the CFL step (quick: ≈ 100 s instead of 10)")


def _check(args):
    from mpmdem import InputError

    n = _points(args)
    if not (n >= PER_RELEASE and n % PER_RELEASE == 0):
        raise InputError("--points", n, "a positive multiple of 3")
    s = _settle(args)
    if not (math.isfinite(s) and s >= 0.0):
        raise InputError("--settle", s, "a time >= 0 [s]")
    if not (math.isfinite(args.jitter) and 0.0 <= args.jitter <= 0.5 * (H - POINT_SIZE)):
        raise InputError("--jitter", args.jitter,
                         f"an offset in [0, {0.5 * (H - POINT_SIZE)}] m (the point stays inside its cell)")


def _points(args) -> int:
    return given(args.points, 30 if args.quick else PAPER_POINTS)


def _settle(args) -> float:
    return given(args.settle, 2.0 if args.quick else 0.0)


def material() -> MohrCoulomb:
    return MohrCoulomb(E, NU, RHO, PHI, PSI, bagnold=ETA, critical_density=RHO_CR)


def release_times(n: int) -> np.ndarray:
    """Release time [s] of each of the n points, three at a time every INTERVAL."""
    return INTERVAL * (np.arange(n) // PER_RELEASE)


def end_time(args) -> float:
    return INTERVAL * _points(args) / PER_RELEASE + _settle(args)


def release_positions(n: int, jitter: float) -> np.ndarray:
    """Where the n points appear [m]: the three cell centres, shifted in x by a seeded uniform
    random offset in [−jitter, jitter] (the same for every run)."""
    x = np.tile(RELEASE_X, n // PER_RELEASE) + np.random.default_rng(0).uniform(-jitter, jitter, n)
    return np.column_stack([x, np.full(n, RELEASE_Y)])


def scene(n: int, jitter: float = JITTER) -> Scene:
    sc = Scene(domain=((0.0, -FLOOR_ROWS * H), (WIDTH, HEIGHT)), cell_size=H, gravity=(0.0, -GRAVITY),
               boundaries={side: "fixed" for side in ("left", "right", "bottom", "top")})
    sc.add_obstacle(rectangle(-H, -(FLOOR_ROWS + 1) * H, WIDTH + H, 0.0))  # the floor, top at y = 0
    pos = release_positions(n, jitter)
    sc.add_points(pos, material(), size=POINT_SIZE, release_time=release_times(n), name="fill")
    return sc


#: --compare: the same filling with stress-free MPM, a run of its own (mpmdem.study.variants), one frame
#: every 0.5 s
VARIANTS = [Variant("stress_free", config={"granular": False, "density_control": "none"}, args={"frame_interval": 0.5},
                    flag="compare")]


def build(args) -> CaseSetup:
    _check(args)
    end = end_time(args)
    if getattr(args, "frame_interval", None):  # a variant's frames (see VARIANTS)
        frames = max(10, round(end / args.frame_interval))
    else:
        frames = max(10, round(end / 0.1)) if args.quick else max(20, round(end / 0.17))
    # --quick takes the CFL step (0.4 × the bound, 1.55e-4 s) instead of Table 4's 5e-5 s, a third
    # of the steps; --dt still overrides either
    return CaseSetup(scene(_points(args), args.jitter), end_time=end, frames=frames,
                     config={"dt": None} if args.quick else {})


def deposit_stats(x, v, mass, vol, F, release, t_end) -> dict:
    """Deposit measures of one frame: which points are deposited (released ≥ DEPOSIT_DELAY before
    t_end), the top of the deposit (the highest top corner of a deposited point's domain, its
    0.15 m square carried by F), the mean density Σm/ΣV of the deposited points and their speeds."""
    dep = (release <= t_end - DEPOSIT_DELAY) & np.isfinite(x[:, 0])
    out = {"deposited_points": int(dep.sum())}
    if not dep.any():
        return out | {"fill_height_m": 0.0, "deposit_density": None, "deposit_max_speed": None}
    speed = np.hypot(v[dep, 0], v[dep, 1])
    top = x[dep, 1] + 0.5 * POINT_SIZE * (np.abs(F[dep, 1, 0]) + np.abs(F[dep, 1, 1]))
    out.update(
        fill_height_m=float(top.max()),
        fill_fraction=float(top.max() / HEIGHT),
        # the same from the centres (highest deposited centre + half a 0.15 m point): meaningful also
        # when points have lost their density and F (stress-free MPM) stretched their domains
        fill_height_centres_m=float(x[dep, 1].max() + 0.5 * POINT_SIZE),
        deposit_density=float(mass[dep].sum() / vol[dep].sum()),
        # the points' own areas over the silo section below the top of the deposit: the packing of
        # the pile as drawn (voids between points included), not the points' density
        deposit_packing_fraction=float(vol[dep].sum() / (WIDTH * top.max())),
        deposit_min_density=float((mass[dep] / vol[dep]).min()),
        deposit_max_speed=float(speed.max()),
        deposit_mean_speed=float(speed.mean()),
        deposit_fraction_slow=float(np.mean(speed < SLOW)),
        deposit_inside_silo=bool(((x[dep, 0] > 0.0) & (x[dep, 0] < WIDTH) & (x[dep, 1] > 0.0)
                                  & (x[dep, 1] < HEIGHT)).all()),
    )
    # lower half of the deposit: the part the paper's 0-1 m/s vs 4-6 m/s contrast is about
    low = x[dep, 1] < 0.5 * top.max()
    out["deposit_lower_half_max_speed"] = float(speed[low].max()) if low.any() else None
    return out


def _mass_history(times, mass_diag, point_mass, release) -> tuple[np.ndarray, float]:
    """Expected mass per frame (points with release ≤ t, the solver's own test) and the largest
    relative error of the diagnostics' mass against it."""
    expected = np.array([point_mass[release <= t].sum() for t in times])
    err = np.abs(mass_diag - expected) / np.maximum(expected, 1e-300)
    return expected, float(err.max())


def summarize(sim, result, args) -> dict:
    n = _points(args)
    release = release_times(n)
    t = result.times
    d = result.diagnostics
    f = sim.fields()
    point_mass = f["mass"]
    expected, mass_err = _mass_history(t, d["mass"], point_mass, release)
    t_end = float(t[-1])
    released = int((release <= t_end).sum())
    out = {
        "paper": "Granular MPM §4.3, Table 4",
        "points": n,
        "end_time_s": t_end,
        "released_points": released,
        "point_mass_kg_per_m": float(point_mass[0]),
        "expected_mass_kg_per_m": float(point_mass[release <= t_end].sum()),
        "final_mass_kg_per_m": float(d["mass"][-1]),
        "max_relative_mass_error": mass_err,
        "deposit_delay_s": DEPOSIT_DELAY,
    }
    out.update(deposit_stats(f["x"], f["v"], f["mass"], f["volume"], f["F"], release, t_end))
    # floor load cell against the weight of the deposited points (Janssen: walls carry the rest)
    dep = (release <= t_end - DEPOSIT_DELAY)
    weight = float(point_mass[dep].sum() * GRAVITY)
    floor = -float(d["force_obstacles_y"][-1])  # [N/m], the material pushes the floor down
    out.update(floor_load_N_per_m=floor, deposited_weight_N_per_m=weight,
               floor_load_over_weight=floor / weight if weight > 0 else None)
    out["paper_fill_fraction_granular"] = "about half of the 7.5 m (Fig. 15 at 27.79 s, all 504 points)"
    out["paper_deposit_speed_m_s"] = {"granular": [0.0, 1.0], "stress_free": [4.0, 6.0]}
    if "components" in d:
        out["components_final"] = int(d["components"][-1])
        out["layers_final"] = int(d["layers"][-1])
        out["layers_max"] = int(np.max(d["layers"]))
    out["work_plastic_J_per_m"] = float(d["work_plastic"][-1])
    out["work_inflow_J_per_m"] = float(d["work_inflow"][-1])
    out["work_numerical_J_per_m"] = float(d["work_numerical"][-1])
    return out


def _last_frame(path) -> tuple[dict, np.ndarray, np.ndarray]:
    """The particle fields of the last frame of a run file, its frame times and its mass diagnostic."""
    from mpmdem.io import RunFile

    with RunFile(path) as rf:
        return {k: rf.field(k, -1) for k in ("x", "v", "F", "mass", "volume")}, rf.times, rf.diagnostics["mass"]


def compare(main, runs, args) -> dict:
    """--compare: the deposit of stress-free MPM (one grid, no density control, "Granular MPM" §4.3),
    a run of its own; the plot of the deposits."""
    release = release_times(_points(args))
    clouds, out = {}, {}
    if main.path is not None:
        f, t, _ = _last_frame(main.path)
        clouds["granular" if main.summary["config"]["granular"] else "run"] = (f["x"], f["v"], f["F"])
    run = runs.get("stress_free")
    if run is not None and run.summary["status"] == "blown-up":
        out["stress_free"] = {"status": "blown-up", "message": run.summary["message"]}
    elif run is not None:
        g, times, mass = _last_frame(run.path)
        clouds["stress-free"] = (g["x"], g["v"], g["F"])
        _, mass_err = _mass_history(times, mass, g["mass"], release)
        out["stress_free"] = {"status": run.summary["status"], "max_relative_mass_error": mass_err,
                              **deposit_stats(g["x"], g["v"], g["mass"], g["volume"], g["F"], release,
                                              float(times[-1]))}
    if main.path is not None:
        _plot(clouds, main.path.parent / "silo_filling.png", float(t[-1]))
    return out


def _plot(clouds: dict, path, t_end: float) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import PolyCollection

    fig, axes = plt.subplots(1, len(clouds), figsize=(3.2 * len(clouds) + 0.8, 6.5), squeeze=False)
    vmax = 6.0
    corners = 0.5 * POINT_SIZE * np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], float)
    for ax, (name, (x, v, F)) in zip(axes[0], clouds.items(), strict=True):
        ok = np.isfinite(x[:, 0])
        # each point's domain: its initial square carried by F (the parallelogram CPDI tracks)
        polys = x[ok, None, :] + np.einsum("pij,kj->pki", F[ok], corners)
        coll = PolyCollection(polys, cmap="viridis", edgecolor="k", linewidth=0.2)
        coll.set_array(np.hypot(v[ok, 0], v[ok, 1]))
        coll.set_clim(0.0, vmax)
        ax.add_collection(coll)
        ax.plot([0, 0, WIDTH, WIDTH], [HEIGHT, 0, 0, HEIGHT], "k-", lw=2)
        for gx in np.arange(0.0, WIDTH + 1e-9, H):
            ax.axvline(gx, color="0.9", lw=0.4, zorder=0)
        for gy in np.arange(0.0, HEIGHT + 1e-9, H):
            ax.axhline(gy, color="0.9", lw=0.4, zorder=0)
        ax.set_xlim(-0.2, WIDTH + 0.2)
        ax.set_ylim(-0.2, HEIGHT + 0.2)
        ax.set_aspect("equal")
        ax.set_title(f"{name}, t = {t_end:.2f} s", fontsize=9)
        ax.set_xlabel("x [m]")
    axes[0, 0].set_ylabel("y [m]")
    fig.colorbar(coll, ax=axes[0].tolist(), label="speed [m/s]", shrink=0.8)
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    from mpmdem.study.runner import run_case

    sys.exit(run_case(sys.modules[__name__], prog="python cases/silo_filling.py"))
