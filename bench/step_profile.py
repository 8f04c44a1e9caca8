"""Where a small scene's step goes on the GPU (issue 27): a per-kernel split of one step.

For each case of bench/small_scenes.py at its default size: the step replayed as CUDA graphs
(``Simulation.advance``, as runs do) and launched eagerly, both timed between two device
synchronisations, then ``--steps`` eager steps under Warp's activity timing (CUDA events around
every kernel, memset and memcpy), summed per kernel name. The gap between the graph's µs per step
and the sum of the kernels' device time is what launching costs (graph nodes, dependencies,
conditional nodes); the kernel rows show which kernels to fuse or shrink. The events around every
eager kernel inflate its time: in a batch of five Beverloo silos (190k points, H100) the eager
kernels added to 386 µs where the graph's whole step took 249, and P2G read 106 µs against the
34 µs Nsight Compute gives it in the graph (``results/ncu_split/h100_silo_batch.txt``, made with
``bench/without_conditionals.py`` and ``ncu_split.py``). Read the rows as a ranking, not as µs
of the graph's step.

One JSON line per case to stdout and ``--out`` (appended): case, device, points, bodies,
graph_us_per_step, eager_us_per_step, device_us_per_step (sum of activities), launches_per_step,
and ``kernels``: [name, launches per step, µs per step] sorted by time. Nothing is asserted.

    python bench/step_profile.py --device cuda --cases normal-force,silo-filling
"""

from __future__ import annotations

import argparse
import ast
import functools
import json
import sys
import time
from collections import defaultdict
from pathlib import Path

import warp as wp

sys.path.insert(0, str(Path(__file__).resolve().parent))
from small_scenes import CASES, build_case, commit  # noqa: E402


def timed(fn, device: str, steps: int) -> float:
    """µs per step of ``fn(steps)`` between two synchronisations."""
    wp.synchronize_device(device)
    start = time.perf_counter()
    fn(steps)
    wp.synchronize_device(device)
    return 1e6 * (time.perf_counter() - start) / steps


def profile_case(name: str, device: str, warmup: int, steps: int, flags: list[str], knobs: dict) -> dict:
    """Graph and eager µs per step of one case and its per-kernel device time, with ``Tuning(**knobs)``."""
    from mpmdem import Tuning

    sim, _ = build_case(name, device, flags, Tuning(**knobs))
    return {**profile_sim(name, sim, device, warmup, steps), "tuning": knobs}


def profile_silo_batch(spec: str, device: str, warmup: int, steps: int, flags: list[str], knobs: dict) -> dict:
    """The same split for a Beverloo batch ``CELL:WORLDS`` (bench/side_by_side.py's silo worlds),
    with ``Tuning(**knobs)``."""
    from side_by_side import make_batch

    from mpmdem import Tuning

    cell, worlds = spec.split(":")
    batch = make_batch(float(cell), int(worlds), device, flags, tuning=Tuning(**knobs))
    row = profile_sim(f"silo-batch {cell} m x {worlds}", batch.sim, device, warmup, steps)
    return {**row, "cell_size": float(cell), "worlds": int(worlds), "tuning": knobs}


def profile_sim(name: str, sim, device: str, warmup: int, steps: int) -> dict:
    """Graph and eager µs per step of a built Simulation and its per-kernel device time."""
    sim._capture()  # as a run does before its first advance_to; advance() replays the graphs
    sim.stage.set_stop_time(1.0e9)
    sim.advance(warmup)

    def eager(n):
        for _ in range(n):
            sim.stage.step()

    graph_us = timed(sim.advance, device, 10 * steps)
    eager_us = timed(eager, device, steps)
    wp.timing_begin(cuda_filter=wp.TIMING_KERNEL | wp.TIMING_MEMSET | wp.TIMING_MEMCPY)
    eager(steps)
    results = wp.timing_end()
    per = defaultdict(lambda: [0, 0.0])
    for r in results:
        per[r.name][0] += 1
        per[r.name][1] += 1e3 * r.elapsed  # ms -> µs
    kernels = sorted(([k, n / steps, us / steps] for k, (n, us) in per.items()), key=lambda row: -row[2])
    return {"case": name, "device": wp.get_device(device).name, "points": sim.particle_count,
            "bodies": sim.body_count, "granular": sim.config.granular, "steps": steps,
            "graph_us_per_step": graph_us, "eager_us_per_step": eager_us,
            "device_us_per_step": sum(row[2] for row in kernels),
            "launches_per_step": sum(row[1] for row in kernels),
            "kernels": [[k, round(n, 3), round(us, 3)] for k, n, us in kernels], "commit": commit()}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--device", default="cuda")
    p.add_argument("--cases", default=",".join(CASES), help="comma-separated cases")
    p.add_argument("--warmup", type=int, default=200, help="steps before timing")
    p.add_argument("--steps", type=int, default=200, help="profiled eager steps (the graph runs 10x as many)")
    p.add_argument("--out", type=Path, default=None, help="also append the JSON lines to this file")
    p.add_argument("--silo-batches", default="", help="comma-separated CELL:WORLDS Beverloo batches to "
                   "profile instead of the cases, e.g. 0.0025:5")
    p.add_argument("--tuning", action="append", default=[], metavar="KNOB=VALUE",
                   help="a Tuning knob of the cases or silo batches (Python literal), e.g. tiled_p2g_granular=True")
    args, flags = p.parse_known_args(argv)
    knobs = {k: ast.literal_eval(v) for k, v in (item.split("=", 1) for item in args.tuning)}
    if args.silo_batches:
        jobs = [(functools.partial(profile_silo_batch, knobs=knobs), s.strip())
                for s in args.silo_batches.split(",") if s.strip()]
    else:
        jobs = [(functools.partial(profile_case, knobs=knobs), c.strip()) for c in args.cases.split(",") if c.strip()]
    for profile, name in jobs:
        row = profile(name, args.device, args.warmup, args.steps, flags)
        print(json.dumps(row), flush=True)
        if args.out:
            with args.out.open("a") as f:
                f.write(json.dumps(row) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
