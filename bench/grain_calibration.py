"""Writes bench/results/studies/grain-calibration/calibration.json: the DEM grains as a continuum (issue 43
§2; what each number is: mpmdem/studies/grain_calibration.py).

    python bench/grain_calibration.py [STUDY_DIR ...] [--out FILE] [--max-a A]

Reads every completed run's summary.json under STUDY_DIR/runs/ (default: the committed
bench/results/studies/column-collapse-dem-heap, column-collapse-dem-seeds and column-collapse-dem) and
writes FILE (default bench/results/studies/grain-calibration/calibration.json); prints one line per
grain radius. Needs no GPU (it reads results).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from mpmdem.study.builtin.grain_calibration import METHOD, calibrate  # noqa: E402
from mpmdem.study.builtin.run_summaries import load_runs  # noqa: E402

STUDIES = ("column-collapse-dem-heap", "column-collapse-dem-seeds", "column-collapse-dem")
OUT = ROOT / "bench" / "results" / "studies" / "grain-calibration" / "calibration.json"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("studies", nargs="*", help="study folders (default: the committed column-collapse-dem ones)")
    p.add_argument("--out", default=str(OUT), help=f"the JSON to write (default {OUT.relative_to(ROOT)})")
    p.add_argument("--max-a", type=float, default=0.5, help="the tallest column whose deposit gives the angle")
    args = p.parse_args(argv)
    folders = [Path(s) for s in args.studies] or [ROOT / "bench" / "results" / "studies" / s for s in STUDIES]
    runs = [r | {"study": f.name} for f in folders if f.is_dir() for r in load_runs(f)]
    if not runs:
        print(f"grain_calibration: no runs under {', '.join(map(str, folders))}", file=sys.stderr)
        return 2
    result = {"source": [str(f) for f in folders if f.is_dir()], "max_aspect_ratio_for_angle": args.max_a,
              "method": METHOD,
              "per_grain": calibrate(runs, args.max_a)}
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=2) + "\n")
    for key, c in result["per_grain"].items():
        angle, phi = c["friction_angle_deg"], c["packing_fraction"]
        print(json.dumps({"grain": key, "friction_angle_deg": angle and [angle["mean"], angle["std"]],
                          "packing_fraction": [phi["mean"], phi["std"]], "bulk_density": c["bulk_density"]["mean"],
                          "coordination": c["coordination"]["mean"], "runs": len(c["cost"])}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
