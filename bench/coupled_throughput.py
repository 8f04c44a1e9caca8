"""Coupled MPM–DEM throughput: granular points with many free pentagons mixed in, step time split by stage.

Scene (``pentagon-mix``): a box of sand (Mohr–Coulomb, 2 × 2 points per cell) with B free rounded
pentagons (regular core of circumradius 1.4h dilated by a = 0.35h: outer diameter 3.5h, a = 0.1 of
it; ρ = 2500 kg/m³, μ = 0.5) scattered through it on a jittered square lattice (random angles,
jitter ±¼ of the gap between neighbours, so no two bodies overlap). The lattice pitch is chosen so
that about N points are left: every sub-cell point whose distance to a pentagon's core is below
a + r_p (r_p = h/√2, ``Scene.add_points``' default contact radius) is removed, so no point starts
in contact with a body; the points are then given one by one (``Scene.add_points``). The box is
the MPM grid's walls (a fixed floor, slip sides and top) and the sand fills it from wall to wall:
the grid walls hold the points, the points hold the bodies. That is what a user would write here;
``--walls`` adds what a user who also wants the bodies kept in the box would add: fixed wall bodies
on the left, right and bottom (``Scene.add_walls``, thickness 3.5h), with the sand then kept one
cell off them. It is off by default: a wall's bounding circle spans the box, so in each point–body
list rebuild its 32 lanes scan every grid cell (see docs/bench-history.md). Gravity (0, −9.81) m/s².

For each (size N, bodies B) two runs: "plain" (the same points, material, config and fixed dt, no
rigid body at all) and "coupled". Both use the same fixed dt, a quarter of the smallest of the
Courant bound of the points, the contact bound of a point of the smallest mass
(``contact_time_step_bound``) and the DEM bound of the pentagons (``dem_time_step_bound``), so they
take equal steps. Each run first settles, untimed (``--settle`` × sqrt(h/g), the time to fall half
a cell: the nearest points start up to half a cell from a body, so the bodies sink onto the sand
and the sand presses on them; 0 skips it), is warmed up (compilation, CUDA-graph capture, a few
steps), then:

1. ``--steps`` steps as ``Simulation.advance`` runs them (one CUDA graph per step on GPUs) between
   two device synchronisations: ``seconds_per_step`` and ``particle_updates_per_second``;
2. the stage split: ``--split-steps`` more steps that call the stages of ``sim.stage`` one by one
   in the order of ``CoupledStage.step``, without the graph, with ``wp.synchronize_device`` after
   each stage and ``time.perf_counter`` around it: ``dem`` (``DEMSolver.contact_stage``: body–body
   lists and forces), ``imp`` (``CoupledStage.contact_forces``: point–body lists and forces), ``mpm``
   (``run_sequence``: P2G, grid, G2P, and ``end_step``: t += dt and the next, capped dt), ``rigid``
   (``DEMSolver.body_update``). The plain run's split has ``mpm`` only. Taken without the graph and
   with a synchronisation after every stage, the split's sum exceeds the graph step (launch and
   sync latency); read its fractions, not its sum.

The coupled line carries ``ratio_to_plain`` = plain seconds per step / coupled seconds per step (the
coupled step's point-updates per second over the pure-MPM step's, on the same points in the same
run), the issue's ``target`` (≥ 0.5 at 1M points with 10k bodies, on the GPU), the point–body pairs
listed and in contact after the timed steps (``imp_pairs``, ``imp_contacts``), the points the IMP
force search visited in the last step (``imp_searched``: those the sift kept in large scenes, else
the listed ones), the list rebuilds
during the timed steps (point–body ``imp_rebuilds``, body–body ``dem_rebuilds``) and during the
split (``split_imp_rebuilds``, ``split_dem_rebuilds``). ``--granular`` runs both with
``SolverConfig(granular=True)`` (``mpm_variant`` "granular", else "standard"). One JSON line per
(size, bodies, mode) on stdout (``--out FILE`` appends them), a summary of the ratios on stderr.
Nothing about time is asserted.

    python bench/coupled_throughput.py --device cpu --steps 5
    python bench/coupled_throughput.py --device cuda --out bench/results/coupled_throughput/h100.jsonl
    python bench/coupled_throughput.py --device cuda --granular --out bench/results/coupled_throughput/h100.jsonl
"""

from __future__ import annotations

import argparse
import gc
import json
import math
import sys
import time
from pathlib import Path

import numpy as np
import warp as wp

from mpmdem import ContactLaw, MohrCoulomb, Scene, Simulation, SolverConfig, regular_polygon
from mpmdem.sim.coupling import contact_time_step_bound
from mpmdem.sim.dem import dem_time_step_bound
from mpmdem.sim.mpm import initial_dt_bound

MATERIAL = MohrCoulomb(1.0e7, 0.3, 2000.0, 30.0, 0.0)
LAW = ContactLaw(1.0e7, restitution=0.3)
BODY_DENSITY = 2500.0  # kg/m³
FRICTION = 0.5
GRAVITY = 9.81  # m/s²
WIDTH = 1.0  # m, width of the sand in the box
SIZE = 3.5  # outer diameter of a pentagon [cells]
SPHERO = 0.1  # sphero radius / outer diameter
JITTER = 0.25  # lattice jitter, ± this fraction of the gap between neighbouring bodies
HEADROOM = 2  # cells of empty box above the sand
POINTS_PER_CELL = 2
WARMUP_STEPS = 5
SETTLE = 1.0  # untimed settling [sqrt(h/g)]: bodies fall onto the sand (it starts a fraction of a cell away)
SPLIT_WARMUP = 2  # untimed steps of the split loop
DT_FACTOR = 0.25
TARGET = 0.5  # issue: coupled / pure-MPM point-updates per second, at 1M points with 10k bodies
GPU_SIZES = (262144, 1048576)
GPU_BODIES = (1000, 10000)
CPU_SIZES = (4096,)
CPU_BODIES = (16, 64)
STAGES = ("dem", "imp", "mpm", "rigid")
SEED = 0


# -- scene ----------------------------------------------------------------------------------------
def _core_distance(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Distance of points q (B, K, 2) to convex counter-clockwise cores v (B, V, 2); 0 inside."""
    e = np.roll(v, -1, axis=1) - v  # (B, V, 2)
    d = q[:, :, None, :] - v[:, None, :, :]  # (B, K, V, 2)
    length2 = np.einsum("bvi,bvi->bv", e, e)[:, None, :]
    s = np.clip(np.einsum("bkvi,bvi->bkv", d, e) / length2, 0.0, 1.0)
    dist = np.linalg.norm(d - s[..., None] * e[:, None, :, :], axis=-1).min(axis=2)
    inside = (e[:, None, :, 0] * d[..., 1] - e[:, None, :, 1] * d[..., 0] >= 0.0).all(axis=2)
    return np.where(inside, 0.0, dist)


def build(particles: int, bodies: int, walls: bool = False, seed: int = SEED) -> dict:
    """The points and pentagons of one (size, bodies) case; plain and coupled scenes come from it.
    With ``walls`` the sand is kept one cell from the sides and the floor (off the wall bodies)."""
    r_p = math.sqrt(1.0 / POINTS_PER_CELL)  # [cells] add_points' default contact radius sqrt(h/n · h)
    a = SPHERO * SIZE
    r_core = 0.5 * SIZE - a
    core = regular_polygon(5, r_core, a)  # in cells, for the geometry only
    d = a + r_p
    excluded = _dilated_area(core.vertices, d)  # [cells²] no point's centre in it
    pitch = math.sqrt(particles / POINTS_PER_CELL**2 / bodies + excluded)  # [cells]
    nx = math.ceil(math.sqrt(bodies))
    ny = math.ceil(bodies / nx)
    cols, rows = math.ceil(nx * pitch), math.ceil(ny * pitch)  # the sand, in cells
    h = WIDTH / cols
    rng = np.random.default_rng(seed)
    ii, jj = np.divmod(np.arange(bodies), nx)
    centres = np.column_stack([(jj + 0.5) * pitch + 0.5 * (cols - nx * pitch),
                               (ii + 0.5) * pitch + 0.5 * (rows - ny * pitch)])
    gap = pitch - SIZE
    centres += rng.uniform(-JITTER * gap, JITTER * gap, centres.shape)
    angles = rng.uniform(0.0, 2.0 * math.pi, bodies)
    c, s = np.cos(angles)[:, None], np.sin(angles)[:, None]
    v = core.vertices
    world = np.stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1]], axis=-1) + centres[:, None, :]
    # sub-cell points of the sand, in cells from its lower-left corner; drop those within a + r_p of a core
    n = POINTS_PER_CELL
    sub = 1.0 / n
    keep = np.ones((rows * n, cols * n), bool)
    reach = r_core + d
    w = math.ceil(2.0 * reach / sub) + 2
    lo = np.floor((centres - reach) / sub - 0.5).astype(int)  # first sub-cell index (x, y) of each window
    kx = lo[:, 0, None] + np.arange(w)[None, :]
    ky = lo[:, 1, None] + np.arange(w)[None, :]
    gx = np.broadcast_to(kx[:, None, :], (bodies, w, w)).reshape(bodies, -1)
    gy = np.broadcast_to(ky[:, :, None], (bodies, w, w)).reshape(bodies, -1)
    q = np.stack([(gx + 0.5) * sub, (gy + 0.5) * sub], axis=-1)
    near = _core_distance(q, world) < d
    near &= (gx >= 0) & (gx < cols * n) & (gy >= 0) & (gy < rows * n)
    keep[gy[near], gx[near]] = False
    iy, ix = np.nonzero(keep)
    inset = 1 if walls else 0  # cells between the sand and the sides and floor
    points = ((np.column_stack([ix, iy]) + 0.5) * sub + inset) * h
    domain = ((0.0, 0.0), ((cols + 2 * inset) * h, (rows + inset + HEADROOM) * h))
    return dict(points=points, h=h, domain=domain, centres=(centres + inset) * h, angles=angles,
                shape=regular_polygon(5, r_core * h, a * h), r_p=r_p * h, pitch=pitch, lattice=(nx, ny))


def _dilated_area(v: np.ndarray, d: float) -> float:
    """Area of a convex polygon dilated by d: A + P d + π d²."""
    x, y = v[:, 0], v[:, 1]
    area = 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))
    return area + _perimeter(v) * d + math.pi * d * d


def _perimeter(v: np.ndarray) -> float:
    return float(np.linalg.norm(np.roll(v, -1, axis=0) - v, axis=1).sum())


def make_scene(case: dict, coupled: bool, walls: bool) -> Scene:
    """The plain scene (the points alone) or the coupled one (with the pentagons, and walls if asked)."""
    h = case["h"]
    scene = Scene(domain=case["domain"], cell_size=h, gravity=(0.0, -GRAVITY), contact=LAW if coupled else None,
                  boundaries={"bottom": "fixed", "left": "slip", "right": "slip", "top": "slip"})
    body = scene.add_points(case["points"], MATERIAL, size=h / POINTS_PER_CELL, name="sand")
    if not math.isclose(body.contact_radius, case["r_p"], rel_tol=1e-9):
        raise RuntimeError(f"contact radius {body.contact_radius} is not the {case['r_p']} the points were cut with")
    if coupled:
        for k, (x, a) in enumerate(zip(case["centres"], case["angles"], strict=True)):
            scene.add_rigid_body(case["shape"], density=BODY_DENSITY, position=tuple(x), angle=float(a),
                                 friction=FRICTION, name=f"pentagon{k}")
        if walls:
            scene.add_walls(("left", "right", "bottom"), thickness=SIZE * h, friction=FRICTION)
    return scene


# -- timing ---------------------------------------------------------------------------------------
def _timed(acc: dict, name: str, device, fn, *args) -> None:
    start = time.perf_counter()
    fn(*args)
    wp.synchronize_device(device)
    acc[name] += time.perf_counter() - start


def split_step(sim: Simulation, acc: dict) -> None:
    """One step, stage by stage, in the order of CoupledStage.step (MPMSolver.step for the plain run)."""
    device = sim.device
    mpm = sim.mpm
    if sim.coupling is None:
        _timed(acc, "mpm", device, mpm.step)
        return
    stage, dem = sim.coupling, sim.dem

    _timed(acc, "dem", device, dem.contact_stage)
    _timed(acc, "imp", device, stage.contact_forces if stage.liu is None else stage._liu_carriers)
    _timed(acc, "mpm", device, mpm.run_sequence)
    _timed(acc, "rigid", device, dem.body_update)
    _timed(acc, "mpm", device, mpm.end_step)


def _check(sim: Simulation, before: int, steps: int) -> None:
    t, dt, bound, after, status = sim.stage.read_clock()
    if after - before != steps:
        raise RuntimeError(f"took {after - before} of {steps} steps")
    sim.stage.check_status(t, dt, bound, status)


def _rebuilds(sim: Simulation) -> tuple[float, float]:
    if not sim.coupling:
        return 0.0, 0.0
    d = sim.diagnostics()
    return d["imp_rebuilds"], d["list_rebuilds"]


def time_run(scene: Scene, config: SolverConfig, steps: int, split_steps: int, device: str, settle: float) -> dict:
    sim = Simulation(scene, config, device=device)
    sim.advance_to(max(settle, 1.0e-12))  # modules, CUDA graph, the settling steps (at least one)
    settle_steps = sim.stage.read_clock()[3]
    sim.stage.set_stop_time(1.0e9)
    sim.advance(WARMUP_STEPS)
    wp.synchronize_device(device)
    before = sim.stage.read_clock()[3]
    imp0, dem0 = _rebuilds(sim)
    start = time.perf_counter()
    sim.advance(steps)
    wp.synchronize_device(device)
    seconds = time.perf_counter() - start
    _check(sim, before, steps)
    out = dict(seconds=seconds, seconds_per_step=seconds / steps, particles=sim.particle_count,
               bodies=sim.body_count, cuda_graph=sim._graph is not None, settle_steps=settle_steps)
    if sim.coupling:
        d = sim.diagnostics()
        imp1, dem1 = _rebuilds(sim)
        L = sim.coupling.L
        searched = (L.near_count if sim.coupling.sifted else L.listed_count).numpy()[0]
        out.update(imp_pairs=d["imp_pairs"], imp_contacts=d["imp_contacts"], imp_searched=int(searched),
                   imp_rebuilds=imp1 - imp0, dem_rebuilds=dem1 - dem0)
    # the stage split: no graph, a synchronisation after every stage
    stages = STAGES if sim.coupling else ("mpm",)
    acc = dict.fromkeys(stages, 0.0)
    for _ in range(SPLIT_WARMUP):
        split_step(sim, dict(acc))
    before = sim.stage.read_clock()[3]
    imp0, dem0 = _rebuilds(sim)
    for _ in range(split_steps):
        split_step(sim, acc)
    _check(sim, before, split_steps)
    total = sum(acc.values())
    out.update(split_steps=split_steps, split_seconds_per_step=total / split_steps,
               stage_seconds_per_step={k: v / split_steps for k, v in acc.items()},
               stage_fractions={k: v / total for k, v in acc.items()})
    if sim.coupling:
        imp1, dem1 = _rebuilds(sim)
        out.update(split_imp_rebuilds=imp1 - imp0, split_dem_rebuilds=dem1 - dem0)
    del sim
    gc.collect()
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--device", default=None)
    p.add_argument("--sizes", type=int, nargs="*", default=None, help="material points (about)")
    p.add_argument("--bodies", type=int, nargs="*", default=None, help="pentagons")
    p.add_argument("--steps", type=int, default=200)
    p.add_argument("--split-steps", type=int, default=None, help="steps of the stage split (default --steps)")
    p.add_argument("--granular", action="store_true", help="SolverConfig(granular=True) in both runs")
    p.add_argument("--walls", action="store_true", help="also fixed wall bodies (Scene.add_walls) for the bodies")
    p.add_argument("--settle", type=float, default=SETTLE,
                   help="untimed settling before the warm-up, in sqrt(h/g) (the time to fall half a cell); 0: none")
    p.add_argument("--out", default=None)
    args = p.parse_args(argv)
    wp.init()
    device = args.device or ("cuda" if wp.get_cuda_device_count() else "cpu")
    cuda = device.startswith("cuda")
    sizes = args.sizes or (GPU_SIZES if cuda else CPU_SIZES)
    counts = args.bodies or (GPU_BODIES if cuda else CPU_BODIES)
    split_steps = args.split_steps or args.steps
    variant = "granular" if args.granular else "standard"
    lines = []
    for size in sizes:
        for bodies in counts:
            case = build(size, bodies, args.walls)
            plain_scene = make_scene(case, False, args.walls)
            coupled_scene = make_scene(case, True, args.walls)
            mass = float(np.min(coupled_scene.particles()["mass"]))
            bounds = dict(courant=initial_dt_bound(plain_scene), contact=contact_time_step_bound(coupled_scene, mass),
                          dem=dem_time_step_bound(coupled_scene))
            dt = DT_FACTOR * min(bounds.values())
            settle = args.settle * math.sqrt(case["h"] / GRAVITY)
            config = SolverConfig(transfer="PIC", shape="bspline2", dt=dt, granular=args.granular)
            runs = {}
            for mode, scene in (("plain", plain_scene), ("coupled", coupled_scene)):
                r = time_run(scene, config, args.steps, split_steps, device, settle)
                runs[mode] = r
                line = dict(case="coupled-throughput", mode=mode, mpm_variant=variant, granular=args.granular,
                            device=str(wp.get_device(device)), size=size, pentagons=bodies, walls=args.walls,
                            steps=args.steps, dt=dt, dt_bounds=bounds, settle_time=settle,
                            particle_updates_per_second=r["particles"] * args.steps / r["seconds"], **r)
                if mode == "coupled":
                    line["ratio_to_plain"] = runs["plain"]["seconds_per_step"] / r["seconds_per_step"]
                    line["target"] = TARGET
                line.update(cell_size=case["h"], pitch_cells=case["pitch"], lattice=list(case["lattice"]),
                            shape=config.shape, transfer=config.transfer, update=config.update,
                            precision=config.precision, warmup_steps=WARMUP_STEPS, seed=SEED, warp=wp.__version__)
                lines.append(line)
                print(json.dumps(line), flush=True)
            del plain_scene, coupled_scene, case
            gc.collect()
    if args.out:
        with Path(args.out).open("a") as f:
            for line in lines:
                f.write(json.dumps(line) + "\n")
    for line in lines:
        if line["mode"] == "coupled":
            frac = " ".join(f"{k} {v:.0%}" for k, v in line["stage_fractions"].items())
            print(f"{line['particles']:>9} points, {line['pentagons']:>6} pentagons ({line['mpm_variant']} MPM): "
                  f"coupled/plain point-updates/s = {line['ratio_to_plain']:.2f} (target >= {TARGET:g} at 1M points, "
                  f"10k bodies); split: {frac}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
