"""Granular MPM overhead: step time of granular mode against plain MPM on the same scene.

Granular mode (``SolverConfig(granular=True)``, "Granular MPM" §3.3–3.4) adds to every step the
domains of interaction, the cell-binned interaction search, the union–find components and the
per-node grid layers that keep components apart. This script measures what that costs: for each
scene and size it times the same scene, the same SolverConfig and the same fixed dt twice, once
with ``granular=False`` ("plain") and once with ``granular=True`` ("granular"), and reports
``overhead`` = granular seconds per step / plain seconds per step.

Material (both scenes): the "Granular MPM" paper's sand with a softer E so steps are not tiny,
MohrCoulomb(E = 1e7 Pa, ν = 0.3, ρ = 2250 kg/m³, φ = 30°, ψ = 0°, η = 0.15 Pa s², ρ_cr = 2235 kg/m³).
Its critical density is used in both modes (density control "revert" runs in plain mode too), so
the difference is the granular machinery alone.

Scenes:

- ``dense-column``: a column of aspect ratio 2 (width W, height 2W) resting on the floor of a box
  3W wide and 2.5W high, 2 × 2 points per cell, gravity (0, −9.81) m/s², a fixed floor and slip
  side and top walls. The points touch, so it is (almost) one component: the best case of
  granular mode, where every node uses its first grid layer.
- ``flowing-column``: the same column once it has collapsed for ``FLOW_TIME`` (0.03 s: its foot
  runs out along the floor and grains leave its front). Both modes take the same warm-up steps
  (``warmup_steps`` in its lines), so they time the same window of the flow. Its points sit near
  the critical density, so nearly every pair of neighbours is near flipping and the interaction
  graph changes at every step: what granular mode costs in a dense flow (the column at rest above
  is its best case, and the issue's target names no phase of it).
- ``dispersed-cloud``: points placed one by one (``Scene.add_points``) on a jittered square lattice
  of spacing 0.65 h (about 2.4 points per cell), each a square domain of edge h/2, so the spacing
  is 1.3 × the edge and the domains of interaction (scaled to the critical volume, edge × 1.003)
  do not overlap: nearly every point is a component of its own, and a node holds up to 16 of them.
  Random velocities of 0.5–1.5 m/s in random directions (``--cloud-speed`` scales them), no
  gravity, slip walls of a box 1.5 × the cloud's side. The worst case: many layers in use per
  node. The gaps are 0.15 h and in 200 steps a point at 1 m/s moves about 0.6 h, so points collide
  and merge during the timed steps: ``components_start`` (after the warm-up) and ``components`` (after the
  timed steps) show how dispersed the cloud stayed.

Both modes use the same fixed dt, a quarter of the initial Courant bound h / max(c + |v|), so they
take the same steps. Each run is warmed up (kernel compilation, CUDA-graph capture and
``WARMUP_STEPS`` steps excluded; on CUDA one step is a captured graph, as in mpm_throughput.py),
then ``--steps`` steps run between two device synchronisations. Nothing about time is asserted.

Issue targets (on the GPU, 262k and 1M points): granular ≤ 1.5 × plain on the dense column and ≤ 3 ×
plain on the dispersed cloud. The GPU figures go to ``bench/results/granular_overhead/h100.jsonl``.

One JSON line per (scene, size, mode) on stdout (``--out FILE`` appends them to FILE), plain
first; the granular line carries ``components`` (``components_start`` before the timed steps),
``layers`` (the most grid layers in use at one node, after the timed steps; ``grid_layers`` is how
many there are) and ``overhead``. A summary of the ratios against the targets goes to
stderr at the end.

    python bench/granular_overhead.py --device cpu --sizes 4096 --steps 5
    python bench/granular_overhead.py --device cpu --check
    python bench/granular_overhead.py --device cuda --out bench/results/granular_overhead/h100.jsonl
"""

from __future__ import annotations

import argparse
import ast
import gc
import json
import math
import re
import sys
import time
from pathlib import Path

import numpy as np
import warp as wp
from small_scenes import commit  # (bench/ is on the path of a bench script)

from mpmdem import MohrCoulomb, Scene, Simulation, SolverConfig, rectangle
from mpmdem.kernels import granular as kgran
from mpmdem.sim.mpm import initial_dt_bound
from mpmdem.sim.tuning import Tuning

#: "Granular MPM" sand, E lowered from 1 GPa to 10 MPa (a 10× larger stable step).
MATERIAL = MohrCoulomb(1.0e7, 0.3, 2250.0, 30.0, 0.0, bagnold=0.15, critical_density=2235.0)
GRAVITY = (0.0, -9.81)
SCENES = ("dense-column", "flowing-column", "dispersed-cloud")
#: Targets of the issue: granular seconds per step / plain seconds per step.
TARGETS = {"dense-column": 1.5, "flowing-column": 1.5, "dispersed-cloud": 3.0}
COLUMN_WIDTH = 1.0  # m
POINTS_PER_CELL = 2  # per direction, dense column
CLOUD_SPACING = 0.65  # lattice spacing of the cloud [cells]
CLOUD_EDGE = 0.5  # edge of each cloud point's domain [cells]
CLOUD_JITTER = 0.05  # ± jitter of the cloud lattice [cells]; keeps the domains apart
CLOUD_CELL_SIZE = 0.01  # m
CLOUD_SPEED = 1.0  # m/s, mean speed of the cloud's points (uniform in [0.5, 1.5] × this)
DT_FACTOR = 0.25  # fixed dt / initial Courant bound
WARMUP_STEPS = 5
FLOW_TIME = 0.03  # s of collapse before the flowing column's timed steps
GPU_SIZES = (262144, 1048576)
CPU_SIZES = (4096,)
CHECK_SIZE, CHECK_STEPS = 2000, 5
SEED = 0


# -- scenes ---------------------------------------------------------------------------------------
def dense_column(particles: int, material=MATERIAL) -> Scene:
    """Column W × 2W on the floor of a 3W × 2.5W box, 2 × 2 points per cell, about ``particles`` points."""
    cells = max(2, round(math.sqrt(particles / (2 * POINTS_PER_CELL**2))))  # W in cells
    h = COLUMN_WIDTH / cells
    width, height = 3 * cells * h, math.ceil(2.5 * cells) * h
    x0 = cells * h  # the column sits in the middle third, on cell lines
    scene = Scene(domain=((0.0, 0.0), (width, height)), cell_size=h, gravity=GRAVITY,
                  boundaries={"bottom": "fixed", "left": "slip", "right": "slip", "top": "slip"})
    scene.add_mpm_body(rectangle(x0, 0.0, x0 + cells * h, 2 * cells * h), material, points_per_cell=POINTS_PER_CELL)
    return scene


def dispersed_cloud(particles: int, seed: int = SEED, speed: float = CLOUD_SPEED) -> Scene:
    """``particles`` separate points on a jittered lattice (spacing 1.3 × their edge), random velocities."""
    rng = np.random.default_rng(seed)
    h = CLOUD_CELL_SIZE
    side = math.ceil(math.sqrt(particles))  # lattice columns
    rows = math.ceil(particles / side)
    spacing = CLOUD_SPACING * h
    cloud_w, cloud_h = side * spacing, rows * spacing
    box = 1.5 * max(cloud_w, cloud_h)
    box = math.ceil(box / h) * h
    ii, jj = np.divmod(np.arange(particles), side)
    x = np.column_stack([(jj + 0.5) * spacing, (ii + 0.5) * spacing])
    x += rng.uniform(-CLOUD_JITTER * h, CLOUD_JITTER * h, x.shape)
    x += np.array([0.5 * (box - cloud_w), 0.5 * (box - cloud_h)])
    v = speed * rng.uniform(0.5, 1.5, particles)
    angle = rng.uniform(0.0, 2.0 * np.pi, particles)
    v = np.column_stack([v * np.cos(angle), v * np.sin(angle)])
    scene = Scene(domain=((0.0, 0.0), (box, box)), cell_size=h, gravity=(0.0, 0.0),
                  boundaries={s: "slip" for s in ("left", "right", "bottom", "top")})
    scene.add_points(x, MATERIAL, size=CLOUD_EDGE * h, velocity=v)
    return scene


BUILDERS = {"dense-column": dense_column, "flowing-column": dense_column, "dispersed-cloud": dispersed_cloud}


# -- timing ---------------------------------------------------------------------------------------
def _rebuilds(mpm) -> tuple[int, int]:
    """Interaction-graph rebuilds and relabels without a rebuild so far (granular mode;
    kernels/granular.py reuses the labels, or relabels over its pair lists)."""
    if not mpm.config.granular:
        return 0, 0
    flags = mpm.interaction.flags.numpy()
    return int(flags[kgran.FLAG_COUNT]), int(flags[kgran.FLAG_RELABELS])


def kernel_split(mpm, steps: int) -> dict[str, float]:
    """Device time per step [µs] of each kernel, over ``steps`` steps launched one by one (no CUDA
    graph, CUDA activity timing): where a step's time goes. Names are Warp's kernel keys."""
    totals: dict[str, float] = {}
    with wp.ScopedTimer("kernels", print=False, synchronize=True, cuda_filter=wp.TIMING_KERNEL) as timer:
        for _ in range(steps):
            mpm.step()
    for r in timer.timing_results:
        name = re.sub(r"(_[0-9a-f]{7,})+$", "", r.name.split("__locals__")[-1])  # drop Warp's hashes
        totals[name] = totals.get(name, 0.0) + r.elapsed * 1.0e3 / steps  # ms -> µs per step
    return dict(sorted(totals.items(), key=lambda kv: -kv[1]))


def time_mode(scene: Scene, config: SolverConfig, steps: int, device, kernel_steps: int = 0,
              warmup: int = WARMUP_STEPS, tuning: Tuning | None = None) -> dict:
    """Warm up, then time ``steps`` steps of one Simulation (``tuning``: its performance knobs, None
    the defaults); the fields of its JSON line."""
    sim = Simulation(scene, config, device=str(device), tuning=tuning)
    mpm = sim.mpm
    sim.advance_to(1.0e-12)  # loads the modules, records the CUDA graph, takes one step
    t, dt, *_ = mpm.read_clock()
    # the warm-up steps as a run takes them (checks after each batch; Granular MPM lays its blocks
    # in line or in conditional nodes by how often they ran, mpmdem.sim.block_layout)
    sim.advance_to(t + (warmup - 0.5) * dt)
    mpm.set_stop_time(1.0e9)
    wp.synchronize_device(device)
    components_start = mpm.granular_statistics()[0] if config.granular else None
    rebuilds_before = _rebuilds(mpm)
    steps_before = mpm.read_clock()[3]
    start = time.perf_counter()
    sim.advance(steps)
    wp.synchronize_device(device)
    seconds = time.perf_counter() - start
    t, dt, bound, steps_after, status = mpm.read_clock()
    taken = steps_after - steps_before
    if taken != steps:
        raise RuntimeError(f"mpmdem took {taken} of {steps} timed steps (stop time reached?)")
    mpm.check_status(t, dt, bound, status)  # NaN, escaped points, layer overflow: BlowUpError
    out = dict(seconds=seconds, seconds_per_step=seconds / steps, finite=bool(np.isfinite(mpm.P.x.numpy()).all()),
               cuda_graph=sim._graph is not None, sim_time=t, grid_layers=mpm.granular_layers,
               block_layouts=["inline" if b.inline else "conditional" for b in getattr(sim, "block_layouts", [])])
    if config.granular:
        out["components"], out["layers"] = mpm.granular_statistics()
        out["components_start"] = components_start
        after = _rebuilds(mpm)
        out["rebuilds"] = after[0] - rebuilds_before[0]
        out["relabels"] = after[1] - rebuilds_before[1]
    if kernel_steps and str(device).startswith("cuda"):
        out["kernels_us_per_step"] = kernel_split(mpm, kernel_steps)
    del sim, mpm
    gc.collect()
    return out


def measure(case: str, particles: int, config: SolverConfig, steps: int, device,
            cloud_speed: float = CLOUD_SPEED, kernel_steps: int = 0, warmup_steps: int = WARMUP_STEPS,
            knobs: dict | None = None) -> list[dict]:
    """Plain, then granular, on one scene, both with ``Tuning(**knobs)``; their two rows (the
    granular one with ``overhead``)."""
    scene = dispersed_cloud(particles, speed=cloud_speed) if case == "dispersed-cloud" else dense_column(particles)
    count = len(scene.particles()["mass"])
    dt = DT_FACTOR * initial_dt_bound(scene)
    nx, ny = scene.cell_counts
    warmup = warmup_steps + (math.ceil(FLOW_TIME / dt) if case == "flowing-column" else 0)
    rows = []
    for granular in (False, True):
        cfg = config.replace(granular=granular, dt=dt)
        r = time_mode(scene, cfg, steps, device, kernel_steps, warmup, Tuning(**(knobs or {})))
        row = dict(case=case, mode="granular" if granular else "plain", device=str(device),
                   device_name=wp.get_device(device).name, particles=count, requested=particles, steps=steps,
                   seconds=r["seconds"], seconds_per_step=r["seconds_per_step"], pups=count * steps / r["seconds"])
        if granular:
            row.update(components=r["components"], components_start=r["components_start"], layers=r["layers"],
                       overhead=r["seconds_per_step"] / rows[0]["seconds_per_step"],
                       target=TARGETS[case], grid_layers=r["grid_layers"],
                       rebuilds=r["rebuilds"], relabels=r["relabels"])
        if "kernels_us_per_step" in r:
            row["kernels_us_per_step"] = r["kernels_us_per_step"]
        row.update(shape=cfg.shape, transfer=cfg.transfer, update=cfg.update, precision=cfg.precision,
                   density_control=cfg.density_control, dt=dt, cell_size=scene.cell_size, grid=[nx, ny],
                   cuda_graph=r["cuda_graph"], finite=r["finite"], warmup_steps=warmup, seed=SEED,
                   block_layouts=r["block_layouts"],
                   warp=wp.__version__, tuning=dict(knobs or {}), commit=commit())
        if case == "dispersed-cloud":
            row["cloud_speed"] = cloud_speed
        rows.append(row)
    return rows


def main(argv=None) -> int:
    """Parse the flags; time every scene × size × mode; print (and append) one JSON line per run."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--device", default=None, help="cpu, cuda or cuda:N (default: cuda if present)")
    parser.add_argument("--sizes", default=None,
                        help=f"comma-separated point counts (default {','.join(map(str, GPU_SIZES))} on cuda, "
                             f"{','.join(map(str, CPU_SIZES))} on cpu)")
    parser.add_argument("--steps", type=int, default=None, help="timed steps (default 200 on cuda, 20 on cpu)")
    parser.add_argument("--scenes", default=",".join(SCENES), help=f"comma-separated, among {', '.join(SCENES)}")
    parser.add_argument("--shape", default="linear")
    parser.add_argument("--transfer", default="PIC", help="any non-XPIC scheme (granular mode needs USL)")
    parser.add_argument("--precision", default="f32", choices=("f32", "f64"))
    parser.add_argument("--cloud-speed", type=float, default=CLOUD_SPEED,
                        help="mean speed of the cloud's points [m/s] (faster: more of them collide and merge)")
    parser.add_argument("--check", action="store_true",
                        help=f"smoke test: {CHECK_SIZE} points, {CHECK_STEPS} steps (overrides --sizes, --steps)")
    parser.add_argument("--out", type=Path, default=None, help="also append the JSON lines to this .jsonl file")
    parser.add_argument("--warmup", type=int, default=WARMUP_STEPS,
                        help="steps before timing, through advance_to as a run takes them (the Granular MPM "
                             "blocks' layout is chosen after 100 of them, mpmdem.sim.block_layout)")
    parser.add_argument("--kernel-steps", type=int, default=0,
                        help="on cuda, also time each kernel over this many steps launched without the graph")
    parser.add_argument("--tuning", action="append", default=[], metavar="KNOB=VALUE",
                        help="a Tuning knob of both modes (Python literal), e.g. tiled_p2g_granular=False")
    args = parser.parse_args(argv)
    knobs = {k: ast.literal_eval(v) for k, v in (item.split("=", 1) for item in args.tuning)}

    wp.init()
    device = wp.get_device(args.device or ("cuda" if wp.get_cuda_device_count() > 0 else "cpu"))
    cuda = device.is_cuda
    if args.check:
        sizes, steps = [CHECK_SIZE], CHECK_STEPS
    else:
        sizes = [int(s) for s in args.sizes.split(",")] if args.sizes else list(GPU_SIZES if cuda else CPU_SIZES)
        steps = args.steps or (200 if cuda else 20)
    scenes = [s.strip() for s in args.scenes.split(",") if s.strip()]
    unknown = [s for s in scenes if s not in BUILDERS]
    if unknown:
        parser.error(f"unknown scene(s) {unknown}; choose among {', '.join(SCENES)}")
    config = SolverConfig(shape=args.shape, transfer=args.transfer, update="USL", precision=args.precision)
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
    summary = []
    with wp.ScopedDevice(device):
        for case in scenes:
            for particles in sizes:
                for row in measure(case, particles, config, steps, device, args.cloud_speed, args.kernel_steps,
                                   args.warmup, knobs):
                    line = json.dumps(row)
                    print(line, flush=True)
                    if args.out is not None:
                        with args.out.open("a") as f:
                            f.write(line + "\n")
                    if row["mode"] == "granular":
                        summary.append(row)
    for row in summary:
        print(f"{row['case']:>16} {row['particles']:>9} points: granular/plain = {row['overhead']:.2f} "
              f"(target <= {row['target']:g}), {row['components']} components, {row['layers']} layers",
              file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
