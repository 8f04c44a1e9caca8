"""The DEM grains as a continuum (issue 43 §2): friction angle, bulk density, packing fraction and mean
coordination number of the cases' grains, from the runs of the column-collapse-dem studies
(``bench/grain_calibration.py`` writes bench/results/studies/grain-calibration/calibration.json; the
study column-collapse-dem-heap writes OUT/grain_calibration.json). Per grain shape and radius (the key
"disk:0.001" is sphero-disks of mean radius 1 mm):

* friction_angle_deg: the angle of repose by the discharge method, from the heap runs
  (``column-collapse --sand dem --floor ledge``, study column-collapse-dem-heap): a column behind a
  gate whose floor ends at the gate over a pit; once the gate is gone the grains beyond the slope
  slide off the ledge and the heap left stands at the angle of repose. Its angle is the flank's
  (``mpmdem.study.grain_deposit.flank_angle``: a least-squares line through the heap's surface between 80 %
  and 20 % of its height at the wall). The value is the mean over the runs (seeds), its uncertainty
  the runs' standard deviation and the standard error of the mean; the fits' own standard errors are
  kept beside. For a cohesionless material the angle of repose stands for the Mohr–Coulomb /
  Drucker–Prager φ (Coulomb's infinite slope). Without heap runs, the collapse deposits' flank over
  the runs with a ≤ --max-a is used instead (``collapse_flank_angle_deg``, kept in any case): a
  deposit that stops after flowing sets its flank at or below the angle of repose, and taller columns
  spread flatter deposits (``flank_angle_by_a``).
* packing_fraction, bulk_density [kg/m³], coordination: the settled columns' (``mpmdem.sim.packing``),
  mean ± standard deviation over every run.
* cost: per run, grains, steps, the run's and the settling's wall time [s], the device, and
  body-steps per second.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from .run_summaries import load_runs

__all__ = ["METHOD", "analyze_heap", "calibrate", "spread"]

#: what the calibration's numbers are (this module's docstring, from its list on), for the JSON
METHOD = __doc__.split("\n\n", 1)[1].strip()


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
    for shape, radius in sorted({(r.get("grain_shape", "disk"), r["grain_radius_m"]) for r in done}):
        at = [r for r in done if r["grain_radius_m"] == radius and r.get("grain_shape", "disk") == shape]
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
        out[f"{shape}:{radius:g}"] = {
            "grain_radius_m": radius, "grain_diameter_mean_m": at[0]["grain_diameter_mean_m"],
            "width_in_diameters": sorted({round(r["width_in_diameters"], 1) for r in at}),
            "grain_density": at[0]["grain_density"], "grain_friction": at[0]["grain_friction"],
            "restitution": at[0]["restitution"], "normal_stiffness": at[0]["normal_stiffness"],
            "tangential_stiffness": at[0]["tangential_stiffness"], "shape": at[0]["grain_shape"],
            "friction_angle_deg": angle, "friction_angle_method": ("heap on a ledge (discharge method)" if heap else
                                                                    f"collapse deposits' flank, a <= {max_a:g}"),
            "friction_angle_runs": [f"{r['study']}:{r['run']}" if "study" in r else r["run"] for r in used],
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


def analyze_heap(rows: list[dict], out: Path) -> dict:
    """The column-collapse-dem-heap study's analysis: the calibration of its runs, OUT/grain_calibration.json."""
    result = {"source": [str(out)], "method": METHOD, "per_grain": calibrate(load_runs(out))}
    (Path(out) / "grain_calibration.json").write_text(json.dumps(result, indent=2) + "\n")
    return result
