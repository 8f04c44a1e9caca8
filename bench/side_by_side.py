"""Batches side by side on one GPU: do their steps overlap?

Builds one batched silo (``BatchedSimulation`` of ``--worlds`` silo-discharge worlds, the Beverloo
study's orifices) per ``--cells`` grid, as the Beverloo study's groups are, and steps each from its
start for ``--steps`` of its steps (``advance_to``, as a run steps; no frames):

- ``sequential``: one batch after the other in this thread (the device's stream);
- ``round-robin`` (CUDA): from this thread, each batch on a stream of its own, 400 steps at a time in
  turn, nothing read back until the end: how far the batches' steps can overlap at all;
- ``side-by-side``: each batch in its own thread, taking turns on the device on its own CUDA
  stream (``mpmdem.sim.device_turns``, as ``mpmdem study --gpus 1`` runs its batches).

Each is timed from the first step to the last batch's end, after a first pass that compiled the
kernels and captured the graphs. One JSON line per mode (``seconds``, and each batch's own
``batch_seconds``); ``overlap`` on the side-by-side row is the sequential seconds over its own.

    python bench/side_by_side.py --device cuda --out bench/results/side_by_side/h100.jsonl
"""

from __future__ import annotations

import argparse
import json
import sys
import threading
import time
from pathlib import Path

import warp as wp

sys.path.insert(0, str(Path(__file__).resolve().parent))
from batch_throughput import ORIFICES, build  # noqa: E402
from small_scenes import commit  # noqa: E402

from mpmdem.sim.batch_run import BatchedSimulation  # noqa: E402
from mpmdem.sim.device_turns import DeviceTurns  # noqa: E402

#: steps a batch launches at a time in the round-robin mode (``advance_to``'s largest batch on a GPU)
ROUND_STEPS = 400


def make_batch(cell: float, worlds: int, device: str, flags: list[str], tuning=None) -> BatchedSimulation:
    built = [build(ORIFICES[k % len(ORIFICES)], device, ["--cell-size", str(cell), *flags]) for k in range(worlds)]
    return BatchedSimulation([s for s, _ in built], built[0][1], device=device, tuning=tuning)


def step(batch: BatchedSimulation, steps: int) -> float:
    """Seconds to step ``batch`` ``steps`` of its first dt on from where it is, as a run steps."""
    sim = batch.sim
    start = time.perf_counter()
    t = sim.stage.read_clock().t
    dt, _ = sim.initial_step()
    sim.advance_to(t + steps * dt)
    return time.perf_counter() - start


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--device", default="cuda" if wp.get_cuda_device_count() else "cpu")
    p.add_argument("--cells", default="0.0025,0.0035,0.005", help="one batch per grid [m]")
    p.add_argument("--worlds", type=int, default=5)
    p.add_argument("--steps", type=int, default=3000)
    p.add_argument("--build", choices=("in-turn", "outside"), default="in-turn",
                   help="side by side: each batch built (and its graphs recorded) in its thread's turn, as a "
                        "study does, or all built here on the device's stream first (then handed their turns)")
    p.add_argument("--out", type=Path)
    args, flags = p.parse_known_args(argv)
    cells = [float(c) for c in args.cells.split(",")]
    device = args.device
    rows = []

    seq = [make_batch(c, args.worlds, device, flags) for c in cells]
    for b in seq:  # (compiles, captures, first lists)
        step(b, 50)
    wp.synchronize_device(device)
    start = time.perf_counter()
    own = [step(b, args.steps) for b in seq]
    sequential = time.perf_counter() - start
    rows.append({"mode": "sequential", "seconds": sequential, "batch_seconds": own})
    if wp.get_device(device).is_cuda:
        # one thread, a stream a batch, chunks of ``ROUND_STEPS`` launched in turn and nothing read
        # until the end: how far these batches' steps can overlap on the GPU at all
        streams = [wp.Stream(device) for _ in seq]
        for b in seq:
            b.sim.stage.set_stop_time(1.0e9)
        wp.synchronize_device(device)
        start = time.perf_counter()
        for _ in range(0, args.steps, ROUND_STEPS):
            for b, s in zip(seq, streams, strict=True):
                with wp.ScopedStream(s, sync_enter=False):
                    b.sim.advance(ROUND_STEPS)
        wp.synchronize_device(device)
        rounds = time.perf_counter() - start
        rows.append({"mode": "round-robin", "seconds": rounds, "overlap": sequential / rounds})
    del seq

    turns = DeviceTurns(device)
    batches: list = [None] * len(cells)
    own = [0.0] * len(cells)
    ready = threading.Barrier(len(cells) + 1)
    go = threading.Barrier(len(cells) + 1)

    if args.build == "outside":
        for k, c in enumerate(cells):
            batches[k] = make_batch(c, args.worlds, device, flags)
            step(batches[k], 50)

    def worker(k):
        if args.build == "in-turn":
            with turns.turn():
                batches[k] = make_batch(cells[k], args.worlds, device, flags)
                step(batches[k], 50)
                turns.wait()
        else:
            batches[k].sim.turns = turns
        ready.wait()
        go.wait()
        turns.seconds.pop(threading.current_thread().name, None)  # (the timed turn's alone)
        with turns.turn():
            own[k] = step(batches[k], args.steps)

    threads = [threading.Thread(target=worker, args=(k,)) for k in range(len(cells))]
    for t in threads:
        t.start()
    ready.wait()
    wp.synchronize_device(device)
    start = time.perf_counter()
    go.wait()
    for t in threads:
        t.join()
    side = time.perf_counter() - start
    # (where each thread's time went in the timed turns: issuing, waiting for the turn, for its stream)
    split = {name: {k: round(v, 4) for k, v in parts.items()} for name, parts in turns.seconds.items()}
    rows.append({"mode": "side-by-side", "seconds": side, "batch_seconds": own, "overlap": sequential / side,
                 "thread_seconds": split})

    name = wp.get_device(device).name if device != "cpu" else "cpu"
    lines = [json.dumps({**row, "bench": "side_by_side", "build": args.build, "cells": cells, "worlds": args.worlds,
                         "steps": args.steps, "flags": flags, "device": name, "commit": commit()}) for row in rows]
    print("\n".join(lines), flush=True)
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        with args.out.open("a") as f:
            f.write("".join(line + "\n" for line in lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
