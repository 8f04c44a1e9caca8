"""The floor under a small scene's step (issue 27): its CUDA graph with every kernel emptied.

A small scene's step is a chain of dependent, latency-bound launches; what each costs is the
node's own launch and drain plus its longest thread's chain of dependent instructions. This bench
separates the two for each case of bench/small_scenes.py at its default size: it steps the case
``--warmup`` steps as a run does (the Granular MPM blocks laid out by how often they ran), times
``--steps`` steps of its graphs, then records the same step again with every ``wp.launch``
replaced by a launch of an empty kernel over the same threads (block size kept; the conditional
nodes, memsets and branches as they were) and times that. The emptied step moves nothing (its
clock does not advance), so every replay repeats the same nodes.

``floor_us_per_step`` is then the least this step can cost on this GPU with the same nodes in the
same order, whatever its kernels do; ``us_per_step`` minus it is what the kernels' own chains add.
With ``--empty REGEX`` only the kernels whose Warp key the expression finds are emptied (the
others run, on a state that no longer changes): the drop is what those kernels add to the step,
overlaps included. Also written: ``emptied``, ``launches_per_step`` (kernel launches emptied in one
step as recorded; those inside a conditional node count whether or not it runs) and those kernels
by name. One JSON line per case on
stdout and to ``--out`` (appended; default bench/results/step_floor/h100.jsonl). Nothing is asserted.

    python bench/step_floor.py --device cuda --cases normal-force,silo-filling
"""

from __future__ import annotations

import argparse
import re
import sys
import time
from collections import Counter
from pathlib import Path

import warp as wp

sys.path.insert(0, str(Path(__file__).resolve().parent))
from small_scenes import CASES, RESULTS, build_case, commit, run_cases  # noqa: E402


@wp.kernel
def nothing():
    """An empty kernel: a node's launch and drain with no work."""
    pass


def timed(sim, device: str, steps: int) -> float:
    """µs per step of ``sim.advance(steps)`` between two synchronisations."""
    wp.synchronize_device(device)
    start = time.perf_counter()
    sim.advance(steps)
    wp.synchronize_device(device)
    return 1e6 * (time.perf_counter() - start) / steps


def floor_case(name: str, device: str, warmup: int, steps: int, flags: list[str], empty: str = "") -> dict:
    """µs per step of case ``name`` and of its step's graph with every kernel emptied (``empty``: only
    those whose Warp key this regular expression finds)."""
    pattern = re.compile(empty)
    sim, _ = build_case(name, device, flags)
    sim.advance(1)  # (the first step sets dt)
    t, dt, *_ = sim.stage.read_clock()
    sim.advance_to(t + (warmup - 1) * dt)  # as a run steps: the block layout chosen
    sim.stage.set_stop_time(1.0e9)
    real = timed(sim, device, steps)
    launched = Counter()
    launch = wp.launch

    def empty_launch(kernel, dim, *args, device=None, block_dim=256, **kwargs):
        if not pattern.search(kernel.key):
            return launch(kernel, dim, *args, device=device, block_dim=block_dim, **kwargs)
        launched[kernel.key.split("__")[-1]] += 1
        return launch(nothing, dim, inputs=[], device=device, block_dim=block_dim)

    wp.launch = empty_launch
    try:
        sim._record_graphs()
    finally:
        wp.launch = launch
    # _record_graphs records one step, then steps_per_graph steps: 1 + steps_per_graph steps in all
    recorded = 1 + sim.tuning.steps_per_graph
    floor = timed(sim, device, steps)
    return {"case": name, "device": str(wp.get_device(device).name), "points": sim.particle_count,
            "bodies": sim.body_count, "granular": sim.config.granular, "steps": steps, "us_per_step": real,
            "emptied": empty or "(every kernel)", "floor_us_per_step": floor,
            "launches_per_step": sum(launched.values()) / recorded,
            "kernels": sorted(((k, v / recorded) for k, v in launched.items()), key=lambda kv: -kv[1]),
            "commit": commit()}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--device", default="cuda")
    p.add_argument("--cases", default=",".join(CASES), help="comma-separated cases")
    p.add_argument("--warmup", type=int, default=1000, help="steps before timing (through advance_to, as a run)")
    p.add_argument("--steps", type=int, default=5000, help="timed steps per case")
    p.add_argument("--empty", default="", help="empty only the kernels whose Warp key this regular expression "
                   "finds (default: every kernel); the time then falls by what those kernels add")
    p.add_argument("--out", type=Path, default=RESULTS / "step_floor" / "h100.jsonl")
    args, flags = p.parse_known_args(argv)
    if not wp.get_device(args.device).is_cuda:
        p.error("--device: the floor is that of a CUDA graph; give a CUDA device")
    run_cases(args.cases, args.out,
              lambda name: floor_case(name, args.device, args.warmup, args.steps, flags, args.empty))
    return 0


if __name__ == "__main__":
    sys.exit(main())
