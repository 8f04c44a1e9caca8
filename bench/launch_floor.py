"""What one node of a small scene's CUDA graph costs at least (issue 27): the floor under a step.

A small scene's step is a chain of dependent kernels, each waiting for the one before (P2G before
the grid update before G2P...). This bench records chains of K kernels that do next to nothing
as CUDA graphs, replays them, and divides the time by the nodes replayed:

- ``one-thread``: K launches of a one-thread kernel that adds 1 to a float64 (the clock kernels);
- ``points``: K launches over ``--threads`` threads, each reading and writing one vec2 (a
  point- or node-sized pass that does no work);
- ``conditional``: K conditional nodes (``wp.capture_if``) whose flag is 0, each holding one
  one-thread kernel (a skipped list rebuild or relabel);
- ``memset``: K ``array.zero_()`` of an array of ``--threads`` vec2.

The µs per node of a chain times a scene's nodes per step is the least its step can cost on this
GPU whatever each kernel does; bench/step_profile.py gives the nodes and the kernels' own times.
One JSON line per chain (case, device, nodes, threads, replays, us_per_node). Nothing is asserted.

    python bench/launch_floor.py --device cuda --out bench/results/launch_floor/h100.jsonl
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import warp as wp


@wp.kernel
def bump(a: wp.array(dtype=wp.float64)):
    a[0] = a[0] + wp.float64(1.0)


@wp.kernel
def touch(a: wp.array(dtype=wp.vec2)):
    i = wp.tid()
    a[i] = a[i] + wp.vec2(1.0, 0.0)


def chain(kind: str, nodes: int, threads: int, device: str):
    """A function that launches one chain of ``nodes`` items of ``kind``."""
    scalar = wp.zeros(1, dtype=wp.float64, device=device)
    field = wp.zeros(threads, dtype=wp.vec2, device=device)
    flag = wp.zeros(1, dtype=wp.int32, device=device)

    def run():
        for _ in range(nodes):
            if kind == "one-thread":
                wp.launch(bump, 1, inputs=[scalar], device=device)
            elif kind == "points":
                wp.launch(touch, threads, inputs=[field], device=device)
            elif kind == "conditional":
                wp.capture_if(flag, on_true=lambda: wp.launch(bump, 1, inputs=[scalar], device=device))
            elif kind == "memset":
                field.zero_()

    return run


def measure(kind: str, nodes: int, threads: int, replays: int, device: str) -> dict:
    """µs per node of a graph of ``nodes`` items of ``kind``, replayed ``replays`` times."""
    run = chain(kind, nodes, threads, device)
    if kind != "conditional":
        run()  # (loads the module outside the capture)
    else:
        wp.load_module(device=device)
    wp.synchronize_device(device)
    with wp.ScopedCapture(device=device) as cap:
        run()
    for _ in range(3):
        wp.capture_launch(cap.graph)
    wp.synchronize_device(device)
    start = time.perf_counter()
    for _ in range(replays):
        wp.capture_launch(cap.graph)
    wp.synchronize_device(device)
    seconds = time.perf_counter() - start
    return {"case": kind, "device": wp.get_device(device).name, "nodes": nodes, "threads": threads,
            "replays": replays, "seconds": seconds, "us_per_node": 1e6 * seconds / (replays * nodes)}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--device", default="cuda")
    p.add_argument("--nodes", type=int, default=64, help="items per graph")
    p.add_argument("--threads", default="2601,8192,65536", help="comma-separated thread counts of 'points'/'memset'")
    p.add_argument("--replays", type=int, default=200)
    p.add_argument("--out", type=Path, default=None, help="also append the JSON lines to this file")
    args = p.parse_args(argv)
    wp.init()
    rows = [measure("one-thread", args.nodes, 1, args.replays, args.device),
            measure("conditional", args.nodes, 1, args.replays, args.device)]
    for n in (int(s) for s in args.threads.split(",")):
        rows += [measure("points", args.nodes, n, args.replays, args.device),
                 measure("memset", args.nodes, n, args.replays, args.device)]
    for row in rows:
        print(json.dumps(row), flush=True)
        if args.out:
            with args.out.open("a") as f:
                f.write(json.dumps(row) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
