r"""Per-kernel GPU time from an Nsight Compute CSV (issue 27): where a step's device time goes.

Run a bench under ``ncu`` with one metric, the kernel's duration, and graph nodes profiled one by
one (so kernels replayed from CUDA graphs are timed as the step runs them; Nsight Compute skips
graphs with conditional nodes, hence bench/without_conditionals.py). ``--cache-control none``
keeps the caches warm between kernels, as in a step (ncu's default flushes them, which inflates
small kernels):

    ncu --graph-profiling node --metrics gpu__time_duration.sum --clock-control none --cache-control none \
        --csv python bench/without_conditionals.py bench/small_scenes.py --device cuda --cases normal-force \
        --steps 64 --warmup 16 --out /dev/null > nf.csv
    python bench/ncu_split.py nf.csv --last 64

Each kernel's name (Warp's ``make_x__locals__name_hash`` shortened to ``name``), launches, mean and
total µs. ``--per N`` divides launches and time by N (the steps the CSV holds) for a per-step
split. ``--last N`` keeps each kernel's last N launches only (the timed steps, after the warm-up).
One JSON line per kernel, sorted by total time, and a total line. Nothing is asserted.
"""

from __future__ import annotations

import argparse
import csv
import json
import re
import sys
from collections import defaultdict


def short(name: str) -> str:
    """``make_p2g__locals__p2g_227f950c`` → ``p2g``."""
    name = re.sub(r"_cuda_kernel_forward.*$", "", name.split("(")[0])
    name = name.split("__locals__")[-1]
    return re.sub(r"_[0-9a-f]{6,}$", "", name)


def read(path: str) -> list[tuple[str, float]]:
    """(kernel, µs) of every profiled launch, in order."""
    rows = []
    with open(path, newline="") as f:
        lines = [line for line in f if line.startswith('"')]  # (ncu's and the program's own output skipped)
    for row in csv.DictReader(lines):
        if row.get("Metric Name") != "gpu__time_duration.sum":
            continue
        value = float(row["Metric Value"].replace(",", ""))
        unit = row.get("Metric Unit", "ns")
        scale = {"ns": 1e-3, "nsecond": 1e-3, "usecond": 1.0, "us": 1.0, "msecond": 1e3, "ms": 1e3}.get(unit, 1e-3)
        rows.append((short(row["Kernel Name"]), value * scale))
    return rows


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("csv")
    p.add_argument("--per", type=float, default=1.0, help="divide launches and time by this (steps)")
    p.add_argument("--last", type=int, default=None, help="keep each kernel's last N launches")
    args = p.parse_args(argv)
    by = defaultdict(list)
    for name, us in read(args.csv):
        by[name].append(us)
    out = []
    for name, times in by.items():
        if args.last:
            times = times[-args.last:]
        out.append({"kernel": name, "launches": len(times) / args.per, "mean_us": sum(times) / len(times),
                    "total_us": sum(times) / args.per})
    out.sort(key=lambda r: -r["total_us"])
    for row in out:
        print(json.dumps({k: round(v, 3) if isinstance(v, float) else v for k, v in row.items()}))
    print(json.dumps({"kernel": "(all)", "launches": round(sum(r["launches"] for r in out), 3),
                      "total_us": round(sum(r["total_us"] for r in out), 3)}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
