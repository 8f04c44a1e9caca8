"""The summary.json of every run of a study: a study's table keeps scalars only, the analyses of
histories (M(t), block angles) read the runs' own summaries."""

from __future__ import annotations

import json
from pathlib import Path


def load_runs(out: Path) -> list[dict]:
    """Every run's summary.json under OUT/runs/, with its folder name as ``run``."""
    runs = []
    for path in sorted(Path(out).glob("runs/*/summary.json")):
        s = json.loads(path.read_text())
        s["run"] = path.parent.name
        s["flags"] = run_flags(s["run"])
        runs.append(s)
    return runs


def run_flags(run_id: str) -> dict[str, str]:
    """The grid values a run id spells (``"method=original,dem-kappa=0.1"`` → {"method": "original",
    "dem-kappa": "0.1"}): what a run that failed before writing its summary scalars still tells."""
    return dict(part.split("=", 1) for part in run_id.split(",") if "=" in part)
