"""The continuum against DEM grains of the same scene (issue 43), read from the committed H100 studies:
the column collapse (bench/results/studies/column-collapse-dem*, against_grains.json) and the block
impact (block-impact-dem against block-impact-ensemble).

References and tolerances:
* the reference grains of the column are the rounded pentagons (r = 1 mm), whose angle of repose the
  heap study measures (grain-calibration/calibration.json) and which must stand at the continuum's
  φ = 30° within two standard deviations of its seeds for the comparison to be a calibrated one;
* "within 10 % of the grains" is the issue's criterion, applied to the finest continuum grid (80
  cells across the column, < 7 % from the next grid: docs/studies);
* a lower friction angle runs out farther (Coulomb's least runout, tests/cases/test_column_dem.py): the
  disks (18°) must run out past the pentagons (30°) at every a;
* the block impact's events: the grains' median time within 10 % of the continuum ensemble's median.
"""

import json
from pathlib import Path

import pytest
from helpers import ROOT

from mpmdem.study.builtin.collapse_against_grains import against_grains

STUDIES = ROOT / "bench" / "results" / "studies"
FINEST = 80


@pytest.fixture(scope="module")
def collapse():
    return against_grains(STUDIES)


def finest(collapse, law: str) -> dict[float, dict]:
    return {r["a"]: r for r in collapse["continuum"] if r["law"].startswith(law) and r["cells"] == FINEST}


def test_the_pentagons_stand_at_the_continuums_friction_angle():
    cal = json.loads((STUDIES / "grain-calibration" / "calibration.json").read_text())["per_grain"]
    angle = cal["polygon:0.001"]["friction_angle_deg"]
    assert angle["n"] >= 5
    assert abs(angle["mean"] - 30.0) <= 2.0 * angle["std"]


def test_every_aspect_ratio_has_its_grains_and_both_continua(collapse):
    assert sorted(float(a) for a in collapse["grains"]) == [0.5, 1.0, 2.0, 4.0, 8.0]
    for law in ("Mohr", "mu"):
        assert sorted(finest(collapse, law)) == [0.5, 1.0, 2.0, 4.0, 8.0]


def test_mu_i_runout_within_10_percent_of_the_grains_for_short_columns(collapse):
    """μ(I) (Jop's μs, μ2, I0; d = 1 mm) at 80 cells against the pentagons at a = 0.5, 1, 2."""
    rows = finest(collapse, "mu")
    for a in (0.5, 1.0, 2.0):
        assert abs(rows[a]["runout_deviation"]) <= 0.10, a


@pytest.mark.xfail(strict=True, reason=(
    "μ(I) at 80 cells runs 14 % (a = 4) and 11 % (a = 8) short of the pentagons (7.25 against 8.48, 13.07 "
    "against 14.72): its parameters are Jop's glass beads, not calibrated to these grains"))
def test_mu_i_runout_within_10_percent_of_the_grains_at_every_a(collapse):
    for a, r in finest(collapse, "mu").items():
        assert abs(r["runout_deviation"]) <= 0.10, a


@pytest.mark.xfail(strict=True, reason=(
    "Mohr–Coulomb (φ = 30°, the pentagons' own angle of repose) at 80 cells runs 18, 20, 22, 25 and 31 % "
    "short of the pentagons at a = 0.5-8, where μ(I) misses by 5-14 %: likely its friction, the static one at "
    "every rate, stops the flow earlier than the grains' (not tested here)"))
def test_mohr_coulomb_runout_within_10_percent_of_the_grains(collapse):
    for a, r in finest(collapse, "Mohr").items():
        assert abs(r["runout_deviation"]) <= 0.10, a


def test_the_disks_run_out_past_the_pentagons(collapse):
    for a, g in collapse["grains"].items():
        assert collapse["disks"][a]["runout"] > g["runout"], a


def block_events(path: Path, key: str) -> list[dict]:
    return json.loads(path.read_text())[key]


def test_grains_reach_the_blocks_when_the_continuum_does():
    ensemble = block_events(STUDIES / "block-impact-ensemble" / "block_impact.json", "ensemble")[0]["events_s"]
    for g in block_events(STUDIES / "block-impact-dem" / "block_impact_dem.json", "per_grain_radius"):
        ev = g["events_s"]
        assert ev["reach"]["missing"] == 0
        assert ev["reach"]["median"] == pytest.approx(ensemble["reach"]["median"], rel=0.10), g["grain_radius_m"]
        assert ev["block2_touch"]["missing"] == 0
        assert ev["block2_touch"]["median"] == pytest.approx(ensemble["block2_touch"]["median"], rel=0.10)


@pytest.mark.xfail(strict=True, reason=(
    "block 1 never touches the floor in any of the 16 grain packs (r = 1 and 0.5 mm, 0.6 s), where the "
    "continuum's 16 starts touch at a median 0.40 s (paper 0.45): the grains leave a bed under the blocks, "
    "and their friction pairs are not the continuum's (cases/_blocks_grains.py)"))
def test_grains_tip_block_1_onto_the_floor():
    for g in block_events(STUDIES / "block-impact-dem" / "block_impact_dem.json", "per_grain_radius"):
        assert g["events_s"]["block1_touch"]["missing"] < g["events_s"]["block1_touch"]["n"]
