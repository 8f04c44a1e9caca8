"""sand-blocks --sand dem: the sand column as DEM grains settled behind a gate (cases/sand_blocks.py's header
says what and why); the scene, the settling and the summary read from the grains."""

from __future__ import annotations

import math
import sys

import numpy as np

from mpmdem import ContactLaw, InputError, Scene, rounded_rectangle
from mpmdem.sim import gated_grains
from mpmdem.study.case import CaseSetup

#: the loose lattice the grains are placed on, in units of the column's height (cases/_column_grains.py)
LATTICE = {"disk": 1.5, "polygon": 2.2}
#: --sand dem: the solver's choices (no grid). f64: a resting 1 mm grain's overlap under its weight (5.7e-8 m)
#: is about f32's spacing of positions half a metre from the origin (6e-8 m), where the flume ends
#: (cases/_column_grains.py says more)
DEFAULTS_DEM = {"precision": "f64"}


def _height(args) -> float:
    """Height [m] of the grains' domain: the flume's walls, or the lattice if taller."""
    from mpmdem.cases.sand_blocks import COLUMN, FLUME

    return max(FLUME[1], LATTICE[args.grain_shape] * COLUMN[1] + 4.0 * args.grain_radius)


def _scene(args, *, gate: bool, blocks: bool) -> Scene:
    """The flume for grains: the floor slab and the right wall as in the MPM run (--friction's μ), a
    frictionless left wall and lid; ``gate``: a frictionless plate at the column's right side;
    ``blocks``: the three blocks (cases/sand_blocks.py)."""
    from mpmdem.cases import sand_blocks as sb

    r, top = args.grain_radius, _height(args)
    mu = sb.FRICTION_SETS[args.friction]
    kn = args.normal_stiffness
    contact = ContactLaw(kn, kn * sb.KT / sb.KN, restitution=gated_grains.RESTITUTION)
    length = sb.FLUME[0]
    scene = Scene(domain=((-r, -r), (length + r, top + r)), gravity=(0.0, -sb.GRAVITY), contact=contact)
    rr = min(args.sphero_radius, 0.4 * sb.SLAB)
    t = sb.SLAB
    plates = [("floor", length + 2 * t, t, (0.5 * length, -0.5 * t), mu["floor"]),
              ("wall_right", t, top + 2 * t, (length + 0.5 * t, 0.5 * top), mu["floor"]),
              ("wall_left", t, top + 2 * t, (-0.5 * t, 0.5 * top), 0.0),
              ("lid", length + 2 * t, t, (0.5 * length, top + 0.5 * t), 0.0)]
    if gate:
        plates.append(("gate", t, top + 2 * t, (sb.COLUMN[0] + 0.5 * t, 0.5 * top), 0.0))
    for name, w, h, centre, friction in plates:
        scene.add_rigid_body(rounded_rectangle(w, h, rr), density=sb.WOOD_DENSITY, position=centre, motion="fixed",
                             friction=friction, name=name)
    if blocks:
        for name, pos in sb.block_positions(args.ensemble_seed).items():
            scene.add_rigid_body(rounded_rectangle(*sb.BLOCK, args.sphero_radius), density=sb.WOOD_DENSITY,
                                 position=pos, motion="fixed" if name == "block3" else "free", friction=mu["block"],
                                 name=name)
    return scene


def build(args) -> CaseSetup:
    """Grains over the column, trimmed to those that settle to its height, settled behind the gate,
    then moved into the flume with the blocks (mpmdem.sim.gated_grains)."""
    from mpmdem.cases import sand_blocks as sb
    from mpmdem.model.grains import place_grains
    from mpmdem.sim.simulation import default_device
    from mpmdem.study.references.table3 import DENSITY

    r = args.grain_radius
    if not (math.isfinite(r) and 2e-4 <= r <= 0.005):
        raise InputError("--grain-radius", r, "a grain radius in [0.0002, 0.005] m (the column is 0.1 m wide; "
                         "the blocks 18 mm tall)")
    w, h = sb.COLUMN
    closed = _scene(args, gate=True, blocks=False)
    region = [(0.0, 0.0), (w, 0.0), (w, _height(args)), (0.0, _height(args))]
    placed = place_grains(region, radius=r, shape=args.grain_shape, density=gated_grains.grain_density(DENSITY),
                          friction=gated_grains.GRAIN_FRICTION, seed=args.seed, name="sand")
    closed.add_grain_set(gated_grains.lowest_grains(placed, gated_grains.PACKING_FRACTION * w * h))
    device = args.device or default_device()
    precision = getattr(args, "precision", None) or DEFAULTS_DEM["precision"]
    packing, seconds = gated_grains.settle_behind_gate(closed, precision=precision, device=device,
                                                       height=_height(args), gravity=sb.GRAVITY,
                                                       settle_max=args.settle_max)
    scene = _scene(args, gate=False, blocks=True)
    grains = scene.add_grain_set(packing.grains[0])
    scene.add_mass_probe("all")
    settled = gated_grains.settled_record(packing, seconds)
    args.settled = settled  # (for the summary: the case's functions share only the flags)
    if not getattr(args, "quiet", False):
        print(f"sand-blocks: {len(grains)} grains settled in {packing.time:.3g} s ({seconds:.3g} s wall): packing "
              f"fraction {packing.packing_fraction:.3f}, bulk density {packing.bulk_density:.0f} kg/m^3",
              file=sys.stderr)
    end = sb.END_QUICK if args.quick else sb.END_FULL
    return CaseSetup(scene, end_time=end, frames=round(end / 0.01), config=dict(DEFAULTS_DEM))


def summarize(sim, result, args) -> dict:
    """The MPM summary's event fields (cases/sand_blocks.py), read from the grains and the blocks."""
    from mpmdem.cases import sand_blocks as sb
    from mpmdem.io import RunFile

    grains = sim.scene.grains[0]
    k0 = len(sim.scene.rigid_bodies)
    with RunFile(result.path) as rf:
        times = rf.times
        names = [str(n) for n in rf.body_geometry()["name"][:k0]]
        frames = [np.asarray(rf.body_field("x", k), dtype=float) for k in range(rf.frame_count)]
        ang = np.array([np.asarray(rf.body_field("angle", k), dtype=float)[:k0] for k in range(rf.frame_count)])
        diag = rf.diagnostics
    bx = np.array([f[:k0] for f in frames])
    gx = [f[k0:] for f in frames]
    radius = grains.bounding_radius
    idx = {n: names.index(n) for n in ("floor", *sb.BLOCK_NAMES)}
    r = args.sphero_radius
    pile_left = sb.BLOCK_X - 0.5 * sb.BLOCK[0]
    front = np.array([float(np.max(x[:, 0] + radius)) for x in gx])
    # the flow reaches the blocks when a grain's edge touches block 3's left face
    reach = sb.first_time(times, front >= pile_left)
    d = 2.0 * float(np.mean(np.sqrt(grains.area / math.pi)))
    out = {
        "sand": "dem", "gravity": sb.GRAVITY, "paper_times_printed_s": sb.T_PAPER_PRINTED,
        "paper_times_s": sb.T_PAPER, "grains": len(grains), "grain_radius_m": args.grain_radius,
        "grain_diameter_mean_m": d, "grain_shape": args.grain_shape, "grain_density": grains.density,
        "grain_friction": grains.friction, "seed": args.seed, "settled": dict(getattr(args, "settled", {})),
        "friction_set": args.friction, "sphero_radius": r, "normal_stiffness": float(args.normal_stiffness),
        "ensemble_seed": args.ensemble_seed,
        "block_start_x_m": {n: p[0] for n, p in sb.block_positions(args.ensemble_seed).items()},
        "times": times.tolist(), "flow_front_x": front.tolist(), "reach_time": reach,
    }
    out.update(sb.block_tracks(times, bx, ang, idx, r))
    # no grain centre may end a frame inside a block
    deepest = 0.0
    for k, x in enumerate(gx):
        for n in sb.BLOCK_NAMES:
            i = idx[n]
            deepest = max(deepest, sb.block_penetration(x, bx[k, i], ang[k, i] - ang[0, i], r))
    out["deepest_penetration_m"] = deepest
    out["event_times_s"] = {"reach": reach, "block2_touch": out["block2_touch_time"],
                            "block1_touch": out["block1_touch_time"], "block2_rest": out["block2_rest_time"],
                            "block1_rest": out["block1_rest_time"]}
    out["event_errors_s"] = {k: (out["event_times_s"][k] - t) if out["event_times_s"][k] is not None else None
                             for k, t in sb.T_PAPER.items()}
    known = [abs(v) for v in out["event_errors_s"].values() if v is not None]
    out["event_error_max_s"] = max(known) if len(known) == 3 else None
    mass = np.asarray(diag["mass_all"])
    out["mass_initial"] = float(mass[0])
    out["mass_max_relative_change"] = float(np.abs(mass / mass[0] - 1.0).max())
    out["energy_kinetic_final"] = float(diag["energy_kinetic"][-1])
    out["dt"] = float(np.asarray(diag["dt"])[-1])
    return out
