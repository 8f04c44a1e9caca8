"""Batched runs (issue 46 item 1): µs per step of N silo worlds stepped as one batch, against N lone runs.

The silo (``silo-discharge``, the Beverloo study's case) is launch-bound on a GPU: a step costs about
the same at 1 or a few worlds' points. This bench builds N worlds of the silo (orifices 2, 3, 4, 5,
6 cm in turn, the Beverloo study's grid; ``--cell-size`` as the study's), steps them as one
``BatchedSimulation`` (``mpmdem.sim.batch_run``) and times ``--steps`` steps after ``--warmup`` ones
(compilation, graph capture and the first list builds excluded), as ``small_scenes.py`` times one
case; each distinct orifice is also timed alone, and the speed-up is N × (mean lone µs per step) /
(batch µs per step). One JSON line per N (worlds, points, us_per_step, us_per_world_step,
lone_us_per_step, speedup, device, commit), to stdout and appended to ``--out``. Nothing is asserted.

``--study`` also runs ``mpmdem study beverloo`` batched on one GPU and prints a line with its
``study``, ``runs``, ``wall_s`` and ``commit`` (the rows of bench/results/study_times_h100.jsonl);
``--study-flags`` passes flags to it (``--no-batch --workers-per-gpu 4`` for the unbatched time).

    python bench/batch_throughput.py --device cuda
    python bench/batch_throughput.py --device cuda --worlds 1,2,4,8,16 --cell-size 0.0025
    python bench/batch_throughput.py --device cuda --worlds 1 --study
    python bench/batch_throughput.py --device cpu --worlds 1,2 --warmup 5 --steps 10 --cell-size 0.01 --quick
"""

from __future__ import annotations

import argparse
import json
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import warp as wp

sys.path.insert(0, str(Path(__file__).resolve().parent))
from small_scenes import RESULTS, commit  # noqa: E402

from mpmdem import Simulation  # noqa: E402
from mpmdem.sim.batch_run import BatchedSimulation  # noqa: E402
from mpmdem.study.runner import case_module, config_from_args, make_case_parser  # noqa: E402

ORIFICES = (0.02, 0.03, 0.04, 0.05, 0.06)  # [m] the Beverloo study's grid


def build(orifice: float, device: str, flags: list[str]):
    """(scene, config) of the silo with this orifice, built as ``mpmdem run`` does."""
    module = case_module("silo-discharge")
    args = make_case_parser(module).parse_args(["--device", device, "--quiet", "--orifice", str(orifice), *flags])
    setup = module.build(args)
    return setup.scene, config_from_args(setup, module, args)


def time_steps(sim: Simulation, device: str, warmup: int, steps: int) -> float:
    """µs per step of ``sim`` after ``warmup`` steps stepped as a run steps (``advance_to``)."""
    sim._capture()
    sim.stage.set_stop_time(1.0e9)
    sim.advance(1)
    t, dt, *_ = sim.stage.read_clock()
    sim.advance_to(t + max(warmup - 1, 1) * dt)
    sim.stage.set_stop_time(1.0e9)
    wp.synchronize_device(device)
    start = time.perf_counter()
    sim.advance(steps)
    wp.synchronize_device(device)
    seconds = time.perf_counter() - start
    t, dt, bound, done, status = sim.stage.read_clock()
    sim.stage.check_status(t, dt, bound, status)
    return 1e6 * seconds / steps


def study_time(flags: str) -> dict:
    """Wall time of ``mpmdem study beverloo`` on one GPU, batched unless ``flags`` say otherwise."""
    out = Path(tempfile.mkdtemp(prefix="beverloo-batch-"))
    cmd = [sys.executable, "-m", "mpmdem.cli", "study", "beverloo", "--gpus", "1", "--out", str(out),
           *shlex.split(flags)]
    start = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - start
    rows = [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()] if (
        out / "results.jsonl").is_file() else []
    grouping = next((ln for ln in proc.stderr.splitlines() if "batch" in ln and "runs" in ln), "")
    return {"study": "beverloo", "runs": len(rows), "completed": sum(r.get("status") == "completed" for r in rows),
            "wall_s": round(wall, 1), "flags": flags, "grouping": grouping, "rc": proc.returncode,
            "commit": commit()}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--device", default="cuda" if wp.get_cuda_device_count() else "cpu")
    p.add_argument("--worlds", default="1,2,4,8,16", help="comma-separated world counts N")
    p.add_argument("--warmup", type=int, default=1000, help="steps before timing (through advance_to, as a run)")
    p.add_argument("--steps", type=int, default=3000, help="timed steps")
    p.add_argument("--study", action="store_true", help="also time the whole Beverloo study, batched")
    p.add_argument("--study-flags", default="", help="flags for that study (e.g. '--no-batch --workers-per-gpu 4')")
    p.add_argument("--out", type=Path, default=RESULTS / "batch_throughput" / "h100.jsonl")
    args, flags = p.parse_known_args(argv)
    lone: dict[float, float] = {}
    rows = []
    for n in [int(v) for v in args.worlds.split(",") if v.strip()]:
        orifices = [ORIFICES[k % len(ORIFICES)] for k in range(n)]
        built = [build(d, args.device, flags) for d in orifices]
        for d, (scene, config) in zip(orifices, built, strict=True):
            if d not in lone:
                lone[d] = time_steps(Simulation(scene, config, device=args.device), args.device, args.warmup,
                                     args.steps)
        batch = BatchedSimulation([s for s, _ in built], built[0][1], device=args.device)
        us = time_steps(batch.sim, args.device, args.warmup, args.steps)
        lone_us = sum(lone[d] for d in orifices) / n
        row = {"bench": "batch_throughput", "case": "silo-discharge", "worlds": n, "points": batch.sim.particle_count,
               "flags": flags, "us_per_step": us, "us_per_world_step": us / n, "lone_us_per_step": lone_us,
               "speedup": n * lone_us / us, "margin_cells": batch.layout.margin,
               "width_m": batch.combined.domain[1][0] - batch.combined.domain[0][0],
               "device": str(wp.get_device(args.device).name if args.device != "cpu" else "cpu"),
               "commit": commit()}
        print(json.dumps(row), flush=True)
        rows.append(row)
    if args.study:
        row = study_time(args.study_flags)
        print(json.dumps(row), flush=True)
        rows.append(row)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with args.out.open("a") as f:
        for row in rows:
            f.write(json.dumps(row) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
