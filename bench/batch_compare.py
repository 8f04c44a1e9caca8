"""Batched against lone runs of one study (issue 46 item 1): the relative difference of every number
the two tables share, per run.

Run a study twice, batched and not (``mpmdem study beverloo --gpus 1 --out A`` and ``... --no-batch
--out B``), then ``python bench/batch_compare.py A B``: one JSON line per run (id, the batch it ran
in, its world, status in each, and the largest relative difference over the numeric columns with
the column it is in), then a summary line (runs, the worst difference and its run and column).
On a GPU the atomics' summation order differs from run to run, so even two lone runs differ; run
the lone study twice (``--out B2``) for that noise floor. Nothing is asserted.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

#: columns that are how a run went, not what it computed
SKIPPED = {"wall_seconds", "sim_seconds", "worker", "device", "batch", "batch_world", "batch_worlds", "message",
           "status", "id"}


def rows(folder: Path) -> dict[str, dict]:
    """The last row of each run id in ``folder``/results.jsonl."""
    out = {}
    for line in (folder / "results.jsonl").read_text().splitlines():
        row = json.loads(line)
        out[row["id"]] = row
    return out


def compare(a: dict, b: dict, columns: list[str] | None = None) -> tuple[float, str]:
    """(largest relative difference, its column) over the numeric columns both rows have (or ``columns``)."""
    worst, where = 0.0, ""
    for key, va in a.items():
        vb = b.get(key)
        if (columns and key not in columns) or key in SKIPPED or isinstance(va, bool):
            continue
        if not (isinstance(va, int | float) and isinstance(vb, int | float)):
            continue
        if not (math.isfinite(va) and math.isfinite(vb)):
            continue
        d = abs(va - vb) / max(abs(va), abs(vb), 1e-300)
        if d > worst:
            worst, where = d, key
    return worst, where


def main(argv=None) -> int:
    import argparse

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("batched", type=Path, help="the batched study's folder")
    p.add_argument("lone", type=Path, help="the lone study's folder")
    p.add_argument("--columns", default="", help="comma-separated columns (default: every numeric one; "
                   "a column that is itself a small error, such as acceleration_error_relative, is round-off)")
    args = p.parse_args(argv)
    columns = [c for c in args.columns.split(",") if c] or None
    batched, lone = rows(args.batched), rows(args.lone)
    worst = (0.0, "", "")
    for run_id, a in batched.items():
        b = lone.get(run_id)
        if b is None:
            continue
        d, col = compare(a, b, columns)
        print(json.dumps({"id": run_id, "batch": a.get("batch"), "batch_world": a.get("batch_world"),
                          "status": [a.get("status"), b.get("status")], "max_rel_diff": d, "column": col}))
        worst = max(worst, (d, run_id, col))
    print(json.dumps({"runs": len(set(batched) & set(lone)), "max_rel_diff": worst[0], "run": worst[1],
                      "column": worst[2]}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
