"""The grain calibration (mpmdem/studies/grain_calibration.py, bench/grain_calibration.py): which runs give
the friction angle, and the committed calibration (bench/results/studies/grain-calibration/) against
the 2D packing literature and the ordering of its two angle readings."""

import json
import math

import pytest
from helpers import ROOT

from mpmdem.study.builtin.grain_calibration import calibrate

RESULTS = ROOT / "bench" / "results" / "studies" / "grain-calibration"


def run(run_id, a, angle, floor="rough", radius=0.001):
    settled = {"packing_fraction": 0.82, "bulk_density": 1550.0, "coordination": 3.5, "wall_seconds": 1.0,
               "time": 0.1}
    return {"run": run_id, "status": "completed", "sand": "dem", "grain_radius_m": radius, "aspect_ratio": a,
            "floor": floor, "flank_angle_deg": angle, "flank_angle_stderr_deg": 1.0, "settled": settled,
            "grain_diameter_mean_m": 2 * radius, "width_in_diameters": 100.0, "grain_density": 1890.0,
            "grain_friction": 0.5, "restitution": 0.5, "normal_stiffness": 1e6, "tangential_stiffness": 5e4,
            "grain_shape": "disk", "grains": 1000, "steps": 100, "wall_seconds": 2.0, "end_time": 1.0,
            "device": "cpu", "bodies": 1010, "heap_mass_fraction": 0.7 if floor == "ledge" else None}


def test_the_heap_gives_the_angle_and_the_short_collapses_stand_beside_it():
    """Heap runs (--floor ledge) give φ when there are any; the collapse deposits' flank is read over
    the columns with a <= max_a only (a = 2 spreads a flatter deposit), and stands in for φ without
    heap runs; one value has no standard deviation."""
    runs = [run("h1", 0.3, 20.0, "ledge"), run("h2", 0.3, 24.0, "ledge"), run("c1", 0.5, 15.0),
            run("c2", 2.0, 8.0), {"run": "broken", "status": "blown-up"}]
    c = calibrate(runs)["disk:0.001"]
    assert c["friction_angle_deg"]["mean"] == pytest.approx(22.0)
    assert c["friction_angle_deg"]["std"] == pytest.approx(math.sqrt(8.0))
    assert c["friction_angle_method"].startswith("heap")
    assert c["collapse_flank_angle_deg"] == {"mean": 15.0, "std": None, "stderr": None, "n": 1}
    assert set(c["flank_angle_by_a"]) == {"0.5", "2.0"}
    without = calibrate([r for r in runs if r.get("floor") != "ledge"])["disk:0.001"]
    assert without["friction_angle_deg"]["mean"] == pytest.approx(15.0)
    assert without["friction_angle_method"].startswith("collapse")


@pytest.fixture(scope="module")
def committed():
    return json.loads((RESULTS / "calibration.json").read_text())["per_grain"]


def test_committed_packing_is_a_2d_random_close_packing(committed):
    """Every grain size's settled packs: φ within Berryman's 2D random close packing 0.82 ± 0.02
    (Phys. Rev. A 27, 1053, 1983), the bulk density φ ρ_s to the round-off of the means, the mean
    coordination number between the isostatic 3 (frictional) and 4 (frictionless) less rattlers
    (van Hecke 2010), as tests/model/test_grains.py reads one pack. (Disks only: the literature is for disks.)"""
    disks = [c for key, c in committed.items() if key.startswith("disk:")]
    assert disks
    for c in disks:
        phi = c["packing_fraction"]["mean"]
        assert 0.80 <= phi <= 0.84
        assert c["bulk_density"]["mean"] == pytest.approx(phi * c["grain_density"], rel=1e-9)
        assert 2.7 <= c["coordination"]["mean"] <= 4.0


def test_committed_collapse_flank_is_no_steeper_than_the_heap(committed):
    """A collapse deposit stops after flowing: its flank stands at the angle at which a flow stops, at
    or below the angle of repose of a heap (the calibration's φ). Tolerance: two standard errors of
    the difference of the two means (the seeds' scatter)."""
    for c in committed.values():
        heap, flank = c["friction_angle_deg"], c["collapse_flank_angle_deg"]
        if not (c["friction_angle_method"].startswith("heap") and flank and flank["stderr"]):
            continue
        assert flank["mean"] <= heap["mean"] + 2.0 * math.hypot(heap["stderr"], flank["stderr"])


def test_the_references_copy_the_committed_angles(committed):
    """mpmdem.study.references.grain_calibration holds the heaps' angles that continuum runs take as φ
    (the beverloo-calibrated study): they must be the committed calibration's, to the 0.1° they print."""
    from mpmdem.study.references import grain_calibration as ref

    for key, mean, std in (("disk:0.001", ref.DISK_REPOSE_DEG, ref.DISK_REPOSE_STD_DEG),
                           ("polygon:0.001", ref.POLYGON_REPOSE_DEG, ref.POLYGON_REPOSE_STD_DEG)):
        angle = committed[key]["friction_angle_deg"]
        assert committed[key]["friction_angle_method"].startswith("heap")
        assert mean == pytest.approx(angle["mean"], abs=0.05)
        assert std == pytest.approx(angle["std"], abs=0.05)
