"""Step latency of the small scenes users wait on (issue 27): µs per step of whole cases.

The studies users run (a Beverloo sweep, a block impact, a compression test) are scenes of a few
thousand to a few tens of thousands of points stepped 1e5-1e6 times; there a step costs launches
and host round trips more than memory traffic. This bench builds each case at its default size
(`sand-blocks`, `normal-force`, `silo-filling`, `silo-discharge`), exactly as `mpmdem run` does,
steps it ``--warmup`` steps as a run does (``Simulation.advance_to``: kernel compilation,
CUDA-graph capture, the first list builds, the layout of the Granular MPM block chosen from how
often it ran, ``mpmdem.sim.block_layout``: excluded), then times ``--steps`` steps between two device
synchronisations, with the stepping ``Simulation.advance`` does (captured graphs of
``Tuning.steps_per_graph`` steps on CUDA, no output, no host reads). The
targets of issue 27 are per step, so a fixed number of steps measures them; a case's full run is
``steps`` of its own end time.

One JSON line per case to stdout and to ``--out`` (default bench/results/small_scenes/h100.jsonl,
appended): case, device, points, bodies, granular, steps, seconds (stepping only), us_per_step,
the case's end time and dt (so its full run is end_time / dt steps), and how often the step's
conditional parts ran (``list_rebuilds_per_step``, ``imp_rebuilds_per_step``, ``granular_rebuilds_per_step``,
``granular_relabels_per_step``, where the scene has them). Nothing is asserted.

    python bench/small_scenes.py --device cuda
    python bench/small_scenes.py --device cuda --out bench/results/small_scenes/h200.jsonl   # another machine
    python bench/small_scenes.py --device cpu --steps 200 --cases silo-discharge
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import warp as wp

from mpmdem import Simulation, Tuning
from mpmdem.study.runner import case_module, config_from_args, make_case_parser

CASES = ("sand-blocks", "normal-force", "silo-filling", "silo-discharge")
#: Diagnostics that count how often a conditional part of the step ran (its rate per step is written)
REBUILD_COUNTS = ("list_rebuilds", "imp_rebuilds", "granular_rebuilds", "granular_relabels")
RESULTS = Path(__file__).resolve().parent / "results"


def commit() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                              cwd=Path(__file__).parent).stdout.strip()
    except OSError:
        return ""


def build_case(name: str, device: str, flags: list[str], tuning: Tuning | None = None):
    """(simulation, setup) of case ``name`` at its default size, built as ``mpmdem run`` does (with
    ``tuning``, default ``Tuning()``), its step captured and its stop time set out of reach (every timed step steps)."""
    module = case_module(name)
    args = make_case_parser(module).parse_args(["--device", device, "--quiet", *flags])
    setup = module.build(args)
    sim = Simulation(setup.scene, config_from_args(setup, module, args), device=device, tuning=tuning)
    sim._capture()
    sim.stage.set_stop_time(1.0e9)  # never reached: the timed steps all step
    return sim, setup


def layout(sim) -> dict:
    """Granular MPM in CUDA graphs: how the relabel and rebuild blocks were laid out for the timed
    steps (``mpmdem.sim.block_layout``)."""
    layouts = getattr(sim, "block_layouts", [])
    names = ("granular_relabel_block", "granular_rebuild_block")
    return {name: "inline" if b.inline else "conditional" for name, b in zip(names, layouts, strict=False)}


def time_case(name: str, device: str, warmup: int, steps: int, flags: list[str],
              tuning: Tuning | None = None) -> dict:
    """µs per step of case ``name`` at its default size on ``device``."""
    sim, setup = build_case(name, device, flags, tuning)
    sim.advance(1)  # (the first step sets dt)
    t, dt, *_ = sim.stage.read_clock()
    sim.advance_to(t + (warmup - 1) * dt)  # as a run steps: checks after each batch, the block layout chosen
    sim.stage.set_stop_time(1.0e9)
    before = sim.diagnostics()
    wp.synchronize_device(device)
    start = time.perf_counter()
    sim.advance(steps)
    wp.synchronize_device(device)
    seconds = time.perf_counter() - start
    t, dt, bound, done, status = sim.stage.read_clock()
    sim.stage.check_status(t, dt, bound, status)
    after = sim.diagnostics()
    # how often the conditional parts of a step ran in the timed steps (list rebuilds, relabels)
    rates = {f"{k}_per_step": (after[k] - before[k]) / steps for k in REBUILD_COUNTS if k in after}
    return {"case": name, "device": str(wp.get_device(device).name if device != "cpu" else "cpu"),
            "points": sim.particle_count, "bodies": sim.body_count, "granular": sim.config.granular,
            "steps": steps, "seconds": seconds, "us_per_step": 1e6 * seconds / steps,
            "end_time": setup.end_time, "dt": dt, "steps_per_graph": sim.tuning.steps_per_graph, **rates,
            **layout(sim),
            "commit": commit()}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--device", default="cuda" if wp.get_cuda_device_count() else "cpu")
    p.add_argument("--cases", default=",".join(CASES), help="comma-separated cases")
    p.add_argument("--warmup", type=int, default=1000, help="steps before timing (through advance_to, as a run)")
    p.add_argument("--steps", type=int, default=5000, help="timed steps per case")
    p.add_argument("--steps-per-graph", type=int, default=None,
                   help="steps per CUDA-graph launch (default Tuning().steps_per_graph; 1: one per step)")
    p.add_argument("--out", type=Path, default=RESULTS / "small_scenes" / "h100.jsonl")
    args, flags = p.parse_known_args(argv)
    tuning = Tuning() if args.steps_per_graph is None else Tuning(steps_per_graph=args.steps_per_graph)
    run_cases(args.cases, args.out, lambda name: time_case(name, args.device, args.warmup, args.steps, flags, tuning))
    return 0


def run_cases(cases: str, out: Path, measure) -> list[dict]:
    """``measure(name)`` for each of the comma-separated ``cases``: its row printed as a JSON line as
    it comes, and every row appended to ``out`` at the end."""
    rows = []
    for name in [c.strip() for c in cases.split(",") if c.strip()]:
        row = measure(name)
        print(json.dumps(row), flush=True)
        rows.append(row)
    out.parent.mkdir(parents=True, exist_ok=True)
    with out.open("a") as f:
        for row in rows:
            f.write(json.dumps(row) + "\n")
    return rows


if __name__ == "__main__":
    sys.exit(main())
