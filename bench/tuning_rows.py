"""One line per row of ``step_profile.py`` and ``granular_overhead.py`` output files: the scene, the
tuning the row ran with and its µs a step (the summary the ``*_gpu.sh`` A/B scripts print at their end).

    python bench/tuning_rows.py OUT/step_profile.jsonl OUT/granular_overhead.jsonl
"""

from __future__ import annotations

import json
import sys
from pathlib import Path


def summary(row: dict) -> str:
    """The row's scene, mode, tuning and µs a step (the graph's for a step profile)."""
    if "graph_us_per_step" in row:
        return f"{row['case']} {row.get('tuning')} graph_us {row['graph_us_per_step']:.1f}"
    return f"{row['case']} {row['mode']} {row.get('tuning')} us {row['seconds_per_step'] * 1e6:.1f}"


def main(paths: list[str]) -> None:
    for path in paths:
        if Path(path).exists():
            for line in open(path):
                print(summary(json.loads(line)))


if __name__ == "__main__":
    main(sys.argv[1:])
