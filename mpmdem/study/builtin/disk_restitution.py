"""Demo study: the disk-collision case's measured head-on restitution against the one it is set to."""

import json
from pathlib import Path

from mpmdem.study.study import Study


def restitution_error(rows: list[dict], out: Path) -> None:
    """Writes ``OUT/restitution.json``: the largest |e_measured − e_set| of the completed runs."""
    done = [r for r in rows if r.get("status") == "completed"]
    errors = {r["id"]: abs(r["restitution_head_on"] - r["restitution_set"]) for r in done}
    worst = max(errors.values(), default=None)
    (out / "restitution.json").write_text(json.dumps({"runs": len(done), "max_abs_error": worst,
                                                      "per_run": errors}, indent=2) + "\n")


STUDY = Study(
    name="disk-restitution",
    case="disk-collision",
    description="head-on restitution of the DEM spring-dashpot vs the set e (quick runs, ~1 s each on a CPU)",
    grid={"--restitution": [0.3, 0.6, 0.9]},
    fixed={"--quick": True},
    analyze=restitution_error,
)
