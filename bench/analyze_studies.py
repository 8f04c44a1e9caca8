"""Re-run the analysis (fits, tables, charts) of committed studies from their run summaries.

    python bench/analyze_studies.py [bench/results/studies]

Each folder holds a study's results.jsonl, study.json and runs/<id>/summary.json, as `mpmdem study`
writes them (bench/gpu_studies.sh brings them back from a GPU machine); the analysis of the study
named in study.json writes its JSON and PNG files beside them.
"""

import json
import sys
from pathlib import Path

from mpmdem.study.builtin import STUDIES
from mpmdem.study.study import load_study


def main(root: Path) -> None:
    for folder in sorted(p for p in root.iterdir() if (p / "results.jsonl").is_file()):
        rows = [json.loads(line) for line in (folder / "results.jsonl").read_text().splitlines() if line.strip()]
        name = folder.name
        if name not in STUDIES:
            print(f"{name}: no built-in study of that name, table only")
            continue
        study = load_study(name)
        if study.analyze is not None:
            study.analyze(rows, folder)
            print(f"{name}: {len(rows)} runs analysed")


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else Path(__file__).parent / "results" / "studies"))
