"""The DEM grains as a continuum (issue 43 §2): friction angle, bulk density, packing fraction and
coordination of the cases' sphero-disks, from the column-collapse-dem studies' runs.

    python bench/grain_calibration.py [STUDY_DIR ...] [--out FILE] [--max-a A]

Reads every completed run's summary.json under STUDY_DIR/runs/ (default: the committed
bench/results/studies/column-collapse-dem-heap, column-collapse-dem-seeds and column-collapse-dem) and
writes FILE (default bench/results/studies/grain-calibration/calibration.json), per grain radius:

* friction_angle_deg: the angle of repose by the discharge method, from the heap runs
  (``column-collapse --sand dem --floor ledge``, study column-collapse-dem-heap): a column behind a
  gate whose floor ends at the gate over a pit; once the gate is gone the grains beyond the slope
  slide off the ledge and the heap left stands at the angle of repose. Its angle is the flank's
  (``mpmdem.grain_deposit.flank_angle``: a least-squares line through the heap's surface between 80 %
  and 20 % of its height at the wall). The value is the mean over the runs (seeds), its uncertainty
  the runs' standard deviation and the standard error of the mean; the fits' own standard errors are
  kept beside. For a cohesionless material the angle of repose stands for the Mohr–Coulomb /
  Drucker–Prager φ (Coulomb's infinite slope). Without heap runs, the collapse deposits' flank over
  the runs with a ≤ --max-a is used instead (``collapse_flank_angle_deg``, kept in any case): a
  deposit that stops after flowing sets its flank at or below the angle of repose, and taller columns
  spread flatter deposits (``flank_angle_by_a``).
* packing_fraction, bulk_density [kg/m³], coordination: the settled columns' (``mpmdem.packing``),
  mean ± standard deviation over every run.
* cost: per run, grains, steps, the run's and the settling's wall time [s], the device, and
  body-steps per second.

Prints the JSON. Needs no GPU (it reads results).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from mpmdem.studies.run_summaries import load_runs  # noqa: E402

STUDIES = ("column-collapse-dem-heap", "column-collapse-dem-seeds", "column-collapse-dem")
OUT = ROOT / "bench" / "results" / "studies" / "grain-calibration" / "calibration.json"


def spread(values) -> dict | None:
    """mean, standard deviation (ddof 1; None for one value), standard error of the mean and count."""
    v = np.asarray([x for x in values if x is not None], dtype=float)
    if not len(v):
        return None
    sd = float(v.std(ddof=1)) if len(v) > 1 else None
    return {"mean": float(v.mean()), "std": sd, "stderr": sd / math.sqrt(len(v)) if sd is not None else None,
            "n": len(v)}


def calibrate(runs: list[dict], max_a: float = 0.5) -> dict:
    """The calibration of the module docstring from the runs' summaries (completed --sand dem runs)."""
    done = [r for r in runs if r.get("status") == "completed" and r.get("sand") == "dem"]
    out = {}
    for radius in sorted({r["grain_radius_m"] for r in done}):
        at = [r for r in done if r["grain_radius_m"] == radius]
        heap = [r for r in at if r.get("floor") == "ledge" and r["flank_angle_deg"] is not None]
        spread_runs = [r for r in at if r.get("floor") != "ledge"]
        short = [r for r in spread_runs if r["aspect_ratio"] <= max_a + 1e-12 and r["flank_angle_deg"] is not None]
        used = heap or short
        angle = spread(r["flank_angle_deg"] for r in used)
        settled = [r["settled"] for r in at]
        cost = [{"run": r["run"], "a": r["aspect_ratio"], "grains": r["grains"], "steps": r["steps"],
                 "wall_seconds": r["wall_seconds"], "settle_wall_seconds": r["settled"].get("wall_seconds"),
                 "settle_time_s": r["settled"]["time"], "simulated_s": r["end_time"], "device": r["device"],
                 "body_steps_per_second": r["bodies"] * r["steps"] / r["wall_seconds"]} for r in at]
        by_a = {}
        for a in sorted({r["aspect_ratio"] for r in spread_runs}):
            by_a[str(a)] = spread(r["flank_angle_deg"] for r in spread_runs if r["aspect_ratio"] == a)
        out[f"{radius:g}"] = {
            "grain_radius_m": radius, "grain_diameter_mean_m": at[0]["grain_diameter_mean_m"],
            "width_in_diameters": sorted({round(r["width_in_diameters"], 1) for r in at}),
            "grain_density": at[0]["grain_density"], "grain_friction": at[0]["grain_friction"],
            "restitution": at[0]["restitution"], "normal_stiffness": at[0]["normal_stiffness"],
            "tangential_stiffness": at[0]["tangential_stiffness"], "shape": at[0]["grain_shape"],
            "friction_angle_deg": angle, "friction_angle_method": ("heap on a ledge (discharge method)" if heap else
                                                                    f"collapse deposits' flank, a <= {max_a:g}"),
            "friction_angle_runs": [r["study"] + ":" + r["run"] for r in used],
            "friction_angle_fit_stderr_deg": spread(r["flank_angle_stderr_deg"] for r in used),
            "collapse_flank_angle_deg": spread(r["flank_angle_deg"] for r in short),
            "heap_mass_fraction_left": spread(r.get("heap_mass_fraction") for r in heap),
            "tan_friction_angle": math.tan(math.radians(angle["mean"])) if angle else None,
            "flank_angle_by_a": by_a,
            "packing_fraction": spread(s["packing_fraction"] for s in settled),
            "bulk_density": spread(s["bulk_density"] for s in settled),
            "coordination": spread(s["coordination"] for s in settled),
            "cost": cost,
        }
    return out


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
              "method": __doc__.split("\n\n", 2)[2].split("\n\nPrints")[0],
              "per_grain_radius": calibrate(runs, args.max_a)}
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=2) + "\n")
    for key, c in result["per_grain_radius"].items():
        angle, phi = c["friction_angle_deg"], c["packing_fraction"]
        print(json.dumps({"grain_radius_m": key, "friction_angle_deg": angle and [angle["mean"], angle["std"]],
                          "packing_fraction": [phi["mean"], phi["std"]], "bulk_density": c["bulk_density"]["mean"],
                          "coordination": c["coordination"]["mean"], "runs": len(c["cost"])}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
