"""Cost against size: µs per step of plain MPM, Granular MPM, DEM grains and the coupled step from 1e3
to 1e7 points (or grains), with each family's launch floor and a memory roofline (issue 46, item 4).

Families (the scenes of the other benches, so the rows can be read beside theirs):

- ``mpm``: ``granular_overhead.dense_column`` (a sand column, 2 × 2 points per cell, on a floor),
  plain MPM (APIC, quadratic B-spline, f32), fixed dt = ¼ of the initial Courant bound;
- ``granular``: the same scene and dt with ``SolverConfig(granular=True)``;
- ``dem-grains``: ``grain_throughput.lattice_pack`` (disks at rest on a floor, the probe's jitter,
  k_n and dt), the disk–disk pass;
- ``coupled``: ``coupled_throughput``'s sand with free pentagons mixed in, one pentagon for every
  POINTS_PER_BODY points (at most --max-bodies), PIC, dt = ¼ of the smallest bound.

Each (family, size) is warmed up (compilation, CUDA-graph capture, ``--warmup`` steps), then
``--steps`` steps run between two device synchronisations. Its line holds ``us_per_step`` and:

- ``floor_us``: the same family's µs per step at FLOOR_SIZE items, measured first in the same
  run: a step where the work is nothing and the launches (graph nodes) are all. A line leaves the
  floor where its µs per step rises above it.
- ``roofline_us``: the time to read and write once, at the device bandwidth measured in the same
  run (a device-to-device copy), the state a step carries to the next (``Stage.state_arrays``:
  points, bodies, the listed contact slots; the DEM's per-slot arrays counted for the slots in use,
  the grid, rebuilt every step, not counted): a lower bound, and ``us_per_step / roofline_us`` how
  far the step sits above it. ``state_bytes`` and ``bandwidth_gbs`` are in the line.

``--plot FILE.jsonl --png OUT.png`` draws the chart from such lines (log-log: a solid line per
family, its floor dashed, its roofline dotted). One JSON line per run on stdout (``--out``
appends them). Nothing about time is asserted.

    python bench/cost_vs_size.py --device cpu --sizes 1000,10000,100000 --steps 30 --warmup 5 \
        --out bench/results/cost_vs_size/cpu.jsonl
    python bench/cost_vs_size.py --plot bench/results/cost_vs_size/cpu.jsonl --png bench/results/cost_vs_size/cpu.png
    python bench/cost_vs_size.py --device cuda --out bench/results/cost_vs_size/h100.jsonl
"""

from __future__ import annotations

import argparse
import gc
import json
import sys
import time
from pathlib import Path

import numpy as np
import warp as wp

FAMILIES = ("mpm", "granular", "dem-grains", "coupled")
GPU_SIZES = (1000, 10000, 100000, 1000000, 10000000)
CPU_SIZES = (1000, 10000)
FLOOR_SIZE = 64  # items of the floor run (the coupled floor: FLOOR_SIZE × 4 points and one pentagon)
POINTS_PER_BODY = 100  # coupled: points per free pentagon (the 1M points with 10k pentagons)
MAX_BODIES = 10000
DT_FACTOR = 0.25
#: DEM arrays with one entry a listed-pair slot (bodies × K): a step touches the listed slots only
SLOT_ARRAYS = ("C.nbr", "C.key", "C.slip", "C.energy", "C.dissipated", "C.pairs", "D.incoming", "D.slip")


def build(family: str, n: int, max_bodies: int = MAX_BODIES):
    """(scene, config, the number of items, a set-up callable run on the Simulation before its first
    step) of one family at about n points or grains."""
    from mpmdem import SolverConfig

    if family in ("mpm", "granular"):
        from granular_overhead import dense_column

        from mpmdem.sim.mpm import initial_dt_bound

        scene = dense_column(n)
        dt = DT_FACTOR * initial_dt_bound(scene)
        return scene, SolverConfig(dt=dt, granular=family == "granular"), len(scene.particles()["mass"]), None
    if family == "dem-grains":
        from grain_throughput import JITTER, lattice_pack

        scene, dt = lattice_pack(n)

        def jitter(sim):
            dem = sim.dem
            free = int(np.count_nonzero(dem.motion == 0))
            v = dem.B.v.numpy()
            v[:free] = np.random.default_rng(0).uniform(-JITTER, JITTER, (free, 2))
            dem.B.v.assign(v)

        return scene, SolverConfig(dt=dt), n, jitter
    if family == "coupled":
        from coupled_throughput import build as build_case
        from coupled_throughput import make_scene

        from mpmdem.sim.coupling import contact_time_step_bound
        from mpmdem.sim.dem import dem_time_step_bound
        from mpmdem.sim.mpm import initial_dt_bound

        bodies = max(1, min(max_bodies, n // POINTS_PER_BODY))
        case = build_case(n, bodies)
        plain, scene = make_scene(case, False, False), make_scene(case, True, False)
        mass = float(np.min(scene.particles()["mass"]))
        dt = DT_FACTOR * min(initial_dt_bound(plain), contact_time_step_bound(scene, mass), dem_time_step_bound(scene))
        return scene, SolverConfig(transfer="PIC", shape="bspline2", dt=dt), len(scene.particles()["mass"]), None
    raise ValueError(f"family {family!r}: one of {', '.join(FAMILIES)}")


def state_bytes(sim) -> int:
    """Bytes of the state a step carries to the next (``state_arrays``), the DEM's per-slot arrays
    counted for their listed slots only."""
    arrays = sim.stage.state_arrays()
    dem = sim.dem
    listed = used = 1.0
    if dem is not None:
        listed, used = float(dem.C.count.numpy().sum()), float(dem.body_count * dem.slots)
    total = 0.0
    for name, a in arrays.items():
        size = a.size * wp.types.type_size_in_bytes(a.dtype)
        if name.split(".", 1)[-1] in SLOT_ARRAYS or name.replace("dem.", "", 1) in SLOT_ARRAYS:
            size *= listed / max(used, 1.0)
        total += size
    return int(total)


def bandwidth(device: str) -> float:
    """Device-to-device copy bandwidth [B/s]: bytes read plus written per second, over repeated copies
    of an array (256 MiB on a GPU, 32 MiB on a CPU)."""
    count = (256 if wp.get_device(device).is_cuda else 32) * 2**20 // 4
    src = wp.zeros(count, dtype=wp.float32, device=device)
    dst = wp.zeros_like(src)
    wp.copy(dst, src)
    wp.synchronize_device(device)
    reps = 20
    start = time.perf_counter()
    for _ in range(reps):
        wp.copy(dst, src)
    wp.synchronize_device(device)
    return 2.0 * 4 * count * reps / (time.perf_counter() - start)


def measure(family: str, n: int, steps: int, warmup: int, device: str, max_bodies: int = MAX_BODIES) -> dict:
    """µs per step of one family at about n items (see the module docstring)."""
    from mpmdem import Simulation

    t0 = time.perf_counter()
    scene, config, items, setup = build(family, n, max_bodies)
    sim = Simulation(scene, config, device=device)
    if setup is not None:
        setup(sim)
    stage = sim.stage
    sim.advance_to(1.0e-12)  # modules, the CUDA graph, one step
    t, dt, *_ = stage.read_clock()
    sim.advance_to(t + (warmup - 0.5) * dt)
    stage.set_stop_time(1.0e9)
    wp.synchronize_device(device)
    before = stage.read_clock()[3]
    build_seconds = time.perf_counter() - t0
    start = time.perf_counter()
    sim.advance(steps)
    wp.synchronize_device(device)
    seconds = time.perf_counter() - start
    t, dt, bound, after, status = stage.read_clock()
    if after - before != steps:
        raise RuntimeError(f"{family} at {n}: took {after - before} of {steps} timed steps")
    stage.check_status(t, dt, bound, status)
    row = dict(case="cost-vs-size", family=family, requested=n, items=items, steps=steps,
               us_per_step=1e6 * seconds / steps, item_steps_per_s=items * steps / seconds,
               state_bytes=state_bytes(sim), bodies=sim.body_count, cuda_graph=sim._graph is not None,
               device=str(sim.device), device_name=wp.get_device(device).name, build_seconds=build_seconds,
               warp=wp.__version__)
    del sim, stage
    gc.collect()
    return row


def plot(lines: list[dict], png: str) -> None:
    """The chart: µs per step against items per family (solid), its floor (dashed), its roofline (dotted)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 5.0))
    colours = dict(zip(FAMILIES, ("tab:blue", "tab:orange", "tab:green", "tab:red"), strict=True))
    rows = [r for r in lines if r.get("case") == "cost-vs-size" and not r.get("floor")]
    span = [min(r["items"] for r in rows), max(r["items"] for r in rows)] if rows else [1, 1]
    for family in FAMILIES:
        own = sorted((r for r in rows if r["family"] == family), key=lambda r: r["items"])
        if not own:
            continue
        c = colours[family]
        x = [r["items"] for r in own]
        ax.loglog(x, [r["us_per_step"] for r in own], "o-", color=c, label=f"{family}")
        ax.loglog(span, [own[0]["floor_us"]] * 2, "--", color=c, lw=0.9)
        ax.loglog(x, [r["roofline_us"] for r in own], ":", color=c, lw=1.2)
    ax.plot([], [], "k--", lw=0.9, label=f"launch floor (the family at {FLOOR_SIZE} items)")
    ax.plot([], [], "k:", lw=1.2, label="memory roofline (state read + written once)")
    device = rows[0]["device_name"] if rows else ""
    ax.set_xlabel("points or grains")
    ax.set_ylabel("µs per step")
    ax.set_title(f"Cost against size ({device})")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png, dpi=130)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--device", default=None)
    p.add_argument("--families", default=",".join(FAMILIES))
    p.add_argument("--sizes", default=None, help=f"items (default GPU {GPU_SIZES}, CPU {CPU_SIZES})")
    p.add_argument("--steps", type=int, default=100)
    p.add_argument("--warmup", type=int, default=10)
    p.add_argument("--max-bodies", type=int, default=MAX_BODIES, help="coupled: the most pentagons")
    p.add_argument("--out", default=None, help="append the JSON lines to this file")
    p.add_argument("--plot", default=None, help="draw the chart from this JSONL file (no run)")
    p.add_argument("--png", default=None, help="with --plot: the chart's file")
    args = p.parse_args(argv)
    if args.plot:
        plot([json.loads(s) for s in Path(args.plot).read_text().splitlines() if s.strip()],
             args.png or str(Path(args.plot).with_suffix(".png")))
        return 0
    wp.init()
    device = args.device or ("cuda" if wp.get_cuda_device_count() else "cpu")
    sizes = [int(float(s)) for s in args.sizes.split(",")] if args.sizes else list(
        GPU_SIZES if device.startswith("cuda") else CPU_SIZES)
    families = [f.strip() for f in args.families.split(",") if f.strip()]
    unknown = [f for f in families if f not in FAMILIES]
    if unknown:
        p.error(f"--families: {unknown} not among {', '.join(FAMILIES)}")
    bw = bandwidth(device)
    lines = []
    for family in families:
        floor = measure(family, FLOOR_SIZE * (4 if family == "coupled" else 1), args.steps, args.warmup, device,
                        args.max_bodies)
        floor.update(floor=True, bandwidth_gbs=bw / 1e9, roofline_us=1e6 * 2.0 * floor["state_bytes"] / bw)
        lines.append(floor)
        print(json.dumps(floor), flush=True)
        for n in sizes:
            row = measure(family, n, args.steps, args.warmup, device, args.max_bodies)
            row.update(floor_us=floor["us_per_step"], bandwidth_gbs=bw / 1e9,
                       roofline_us=1e6 * 2.0 * row["state_bytes"] / bw)
            row["over_floor"] = row["us_per_step"] / row["floor_us"]
            row["over_roofline"] = row["us_per_step"] / row["roofline_us"]
            lines.append(row)
            print(json.dumps(row), flush=True)
    if args.out:
        with open(args.out, "a") as f:
            for row in lines:
                f.write(json.dumps(row) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
