"""Per-kernel device time of the disk-grain step with and without a list rebuild in every step.

The pack of ``grain_throughput.py`` (n disks on a lattice, f32, the disk–disk pass), settled for
--warmup steps on the step's CUDA graph; then --steps eager steps timed kernel by kernel under
Warp's activity timing, first as they come ("natural": a rebuild about every 11 steps), then with
the rebuild flag raised before each step ("forced": every step rebuilds its lists). Prints one JSON
line: listed pairs (owned, incoming) and µs per step of the six most expensive kernels each way.

The committed rows of 2026-11-28 with a ``skip`` other than "" were taken with a temporary patch
that left out one part of a kernel (``hist``: the history hand-over of ``build_lists``; ``cells``:
its cell search; ``large``: its large-body loop; ``touch``: the touch force of ``disk_forces``;
``store``: its slot stores) to see what each part costs; the patch is not in the tree.
Usage: python bench/rebuild_split.py --grains 1000000 (CUDA)
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections import defaultdict

import numpy as np
import warp as wp
from grain_throughput import JITTER, lattice_pack  # (a script beside this one)

from mpmdem import Simulation, SolverConfig, Tuning


def kernel_split(sim: Simulation, steps: int, forced: bool) -> dict:
    """µs per step of the six most expensive kernels over ``steps`` eager steps."""
    dem = sim.dem
    wp.synchronize_device(sim.device)
    wp.timing_begin(cuda_filter=wp.TIMING_KERNEL)
    for _ in range(steps):
        if forced:
            dem.flags.fill_(1)
        sim.stage.step()
    per = defaultdict(float)
    for r in wp.timing_end():
        name = r.name.replace("forward kernel ", "").split("__locals__")[-1].rsplit("_", 1)[0]
        per[name] += 1e3 * r.elapsed / steps
    return {k: round(v, 1) for k, v in sorted(per.items(), key=lambda x: -x[1])[:6]}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--grains", type=int, default=1000000)
    p.add_argument("--warmup", type=int, default=200)
    p.add_argument("--steps", type=int, default=6)
    args = p.parse_args(argv)
    wp.init()
    if not wp.get_cuda_device_count():
        print("rebuild_split: needs a CUDA device (kernel timing)", file=sys.stderr)
        return 2
    scene, dt = lattice_pack(args.grains)
    sim = Simulation(scene, SolverConfig(precision="f32", dt=dt), device="cuda", tuning=Tuning(disk_pairs=True))
    dem = sim.dem
    free = int(np.count_nonzero(dem.motion == 0))
    v = dem.B.v.numpy()
    v[:free] = np.random.default_rng(0).uniform(-JITTER, JITTER, (free, 2))
    dem.B.v.assign(v)
    sim._capture()
    dem.set_stop_time(1e30)
    sim.advance(args.warmup)
    row = {"grains": args.grains, "skip": os.environ.get("PROF_SKIP", ""),
           "owned": int(dem.C.count.numpy().sum()), "incoming": int(dem.D.count.numpy().sum())}
    row["natural"] = kernel_split(sim, args.steps, False)
    row["forced"] = kernel_split(sim, args.steps, True)
    print(json.dumps(row), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
