"""The nodes of one step's CUDA graph, listed on any device (issue 27): what a small scene pays per step.

A small scene's step is paid per graph node (bench/launch_floor.py: each dependent node costs a
few µs whatever it does), so the count of nodes per step is the figure to cut. This bench builds
each case of bench/small_scenes.py at its default size, takes a few steps, then records the
launches of one more step as the step lays them out: kernel launches, memsets and conditional
blocks (``launch_plan.IfFlag``, one conditional node in a CUDA graph, whose body runs only when its
flag is set; ``launch_plan.IfAny``, a kernel that ORs its flags and one conditional node). On a CPU
every launch of a conditional body is listed (indented) as well.

One JSON line per case (case, nodes: graph nodes of the step outside conditional bodies,
conditional_nodes: the launches inside them, items: the listing) to stdout; ``--list`` prints the
listing too. Nothing is asserted.

    python bench/step_nodes.py --device cpu --list --cases normal-force,silo-filling
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import warp as wp

sys.path.insert(0, str(Path(__file__).resolve().parent))
from small_scenes import CASES, build_case, commit  # noqa: E402

import mpmdem.sim.coupling  # noqa: E402
import mpmdem.sim.dem  # noqa: E402
import mpmdem.sim.mpm  # noqa: E402
from mpmdem.sim import launch_plan  # noqa: E402


class StepRecorder:
    """Records, while active, every wp.launch, array.zero_ and IfFlag block (with its depth)."""

    def __init__(self):
        self.items: list[tuple[int, str]] = []
        self.depth = 0

    def __enter__(self):
        self._launch, self._zero, self._run_plan = wp.launch, wp.array.zero_, launch_plan.run_plan
        recorder = self
        launch, zero, run_plan = self._launch, self._zero, self._run_plan

        def recorded_launch(kernel, dim, *args, **kwargs):
            recorder.items.append((recorder.depth, f"{kernel.key.split('__locals__')[-1]} dim={dim}"))
            return launch(kernel, dim, *args, **kwargs)

        def recorded_zero(array):
            recorder.items.append((recorder.depth, f"memset {array.shape}"))
            return zero(array)

        def recorded_run_plan(plan, device, extensions=None):
            for item in plan:
                if isinstance(item, launch_plan.IfAny):
                    # (in a CUDA graph: a one-thread kernel ORs the flags, then one conditional node)
                    recorder.items.append((recorder.depth, f"or_flags of {len(item.flags)} (CUDA graphs only)"))
                    recorder.items.append((recorder.depth, "if any flag:"))
                    recorder.depth += 1
                    recorded_run_plan(item.body, device, extensions)
                    recorder.depth -= 1
                elif isinstance(item, launch_plan.IfFlag):
                    recorder.items.append((recorder.depth, "if flag:"))
                    recorder.depth += 1
                    recorded_run_plan(item.body, device, extensions)
                    recorder.depth -= 1
                else:
                    run_plan([item], device, extensions)

        wp.launch = launch_plan.wp.launch = recorded_launch
        wp.array.zero_ = recorded_zero
        for module in (launch_plan, mpmdem.sim.mpm, mpmdem.sim.dem, mpmdem.sim.coupling):
            module.run_plan = recorded_run_plan
        return self

    def __exit__(self, *exc):
        wp.launch = launch_plan.wp.launch = self._launch
        wp.array.zero_ = self._zero
        for module in (launch_plan, mpmdem.sim.mpm, mpmdem.sim.dem, mpmdem.sim.coupling):
            module.run_plan = self._run_plan
        return False


def step_nodes(name: str, device: str, flags: list[str], tuning=None) -> dict:
    """The items of one step of case ``name`` (outside a capture: conditional bodies all listed;
    ``tuning``: a ``mpmdem.Tuning``, default ``Tuning()``)."""
    sim, _ = build_case(name, device, flags, tuning)
    sim.advance(3)
    with StepRecorder() as rec:
        sim.stage.step()
    top = sum(1 for depth, _ in rec.items if depth == 0)
    return {"case": name, "nodes": top, "conditional_nodes": len(rec.items) - top,
            "items": ["  " * d + text for d, text in rec.items], "commit": commit()}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--device", default="cpu")
    p.add_argument("--cases", default=",".join(CASES), help="comma-separated cases")
    p.add_argument("--list", action="store_true", help="print each step's listing")
    args, flags = p.parse_known_args(argv)
    for name in [c.strip() for c in args.cases.split(",") if c.strip()]:
        row = step_nodes(name, args.device, flags)
        print(json.dumps({k: v for k, v in row.items() if k != "items"}), flush=True)
        if args.list:
            print("\n".join(row["items"]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
