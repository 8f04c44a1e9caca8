"""The committed silo refinement studies (bench/results/studies/beverloo-{refined,mu-i,mu-i-grain,dem},
H100) against the targets of the μ(I) and grain-scale issues, read from the runs' own summaries.

References and tolerances:
* convergence: the issue's target, W changes by < 3 % over the last grid halving (2 → 1 mm) at
  every D0 ≥ 3 cm; the same 3 % for the Beverloo prefactor C.
* the grain length: in the 2D Beverloo law the dead zone is D* = k d/2 with k ≈ 1-3 (MPM-SDEM
  Fig. 16's k = 2.2 on r_p; Mankoc et al. 2007), so dD*/dd lies in [0.5, 1.5] and D* must not
  follow the cell size: |dD*/dh| below 0.5 (a tenth of the per-cell intercept of a grid-set dead zone,
  D* ≈ 3.5 h, issue 43's fit of the Drucker–Prager study).
* the grains: the DEM silo of r_p = 1 mm disks (d = 2 mm, as the μ(I) runs' d) at D0 = 4 cm is the
  reference; "within 10 %" is the issue's criterion.
"""

import json
from pathlib import Path

import numpy as np
import pytest

from mpmdem.cases._table3 import DENSITY, GRAVITY
from mpmdem.studies.beverloo_refinement import analyze_grain, analyze_refinement
from mpmdem.studies.run_summaries import load_runs

STUDIES = Path(__file__).resolve().parents[1] / "bench" / "results" / "studies"


@pytest.fixture(scope="module")
def mu_i():
    return analyze_refinement(load_runs(STUDIES / "beverloo-mu-i"), DENSITY, GRAVITY)


@pytest.fixture(scope="module")
def dp():
    return analyze_refinement(load_runs(STUDIES / "beverloo-refined"), DENSITY, GRAVITY)


def dem_rate(name: str) -> float:
    return json.loads((STUDIES / "beverloo-dem" / f"{name}.json").read_text())["rate"]


def rate_at(res: dict, d0: float, h: float) -> float:
    e = res["per_orifice"][f"{d0:g}"]
    return e["rate"][e["h_m"].index(h)]


def test_every_run_completed(mu_i, dp):
    for name, n in (("beverloo-mu-i", 30), ("beverloo-refined", 25), ("beverloo-mu-i-grain", 16)):
        runs = load_runs(STUDIES / name)
        assert len(runs) == n and all(r["status"] == "completed" for r in runs), name


def test_mu_i_beverloo_prefactor_converges(mu_i):
    """The prefactor C of the μ(I) silo (line through W^(2/3), orifices ≥ 10 cells) moves by less than
    3 % from 2 to 1 mm: what the grid changes is the intercept, not the slope."""
    c2, c1 = mu_i["per_grid"]["0.002"]["C"], mu_i["per_grid"]["0.001"]["C"]
    assert abs(c1 - c2) / c1 < 0.03


@pytest.mark.xfail(strict=True, reason=(
    "μ(I), d = 2 mm (H100): W changes over the last halving 2 -> 1 mm by +15.5, +11.3, +8.4 and +7.4 % at "
    "D0 = 3, 4, 5, 6 cm: the Beverloo intercept shrinks with the cell (D* = 4.5, 3.5, 1.3, 0.1 mm at "
    "h = 2.5, 2, 1.4, 1 mm) while C stays at 1.28-1.30; the continuum has no dead zone of its own"))
def test_mu_i_rate_converges_within_3_percent(mu_i):
    for d0 in (0.03, 0.04, 0.05, 0.06):
        w2, w1 = rate_at(mu_i, d0, 0.002), rate_at(mu_i, d0, 0.001)
        assert abs(w1 - w2) / w1 < 0.03, d0


@pytest.mark.xfail(strict=True, reason=(
    "the μ(I) intercept follows the grid: dD*/dh = 3.0 over h = 2.5-1 mm (D* 4.5 -> 0.1 mm), while at "
    "h = 2.5 mm it grows with the grain only as dD*/dd = 0.63 (D* = 3.2, 4.3, 4.6, 5.7 mm at d = 0.5, 1, "
    "2, 4 mm): the grain sets a part of D*, the cell the rest"))
def test_mu_i_intercept_follows_the_grain_not_the_grid(mu_i):
    pts = [(float(h), v["D_star_m"]) for h, v in mu_i["per_grid"].items() if v.get("D_star_m") is not None
           and float(h) <= 0.0025]
    h, ds = np.array(pts).T
    assert abs(np.polyfit(h, ds, 1)[0]) < 0.5
    grain = analyze_grain(load_runs(STUDIES / "beverloo-mu-i-grain"), DENSITY, GRAVITY)
    assert 0.5 <= grain["d_star_slope_per_d"] <= 1.5


def test_mu_i_intercept_grows_with_the_grain():
    """At one grid (2.5 mm), D* grows with d: the grain length does enter through I."""
    grain = analyze_grain(load_runs(STUDIES / "beverloo-mu-i-grain"), DENSITY, GRAVITY)
    ds = [v["D_star_m"] for _, v in sorted(grain["per_grain_diameter"].items(), key=lambda kv: float(kv[0]))]
    assert all(b > a for a, b in zip(ds, ds[1:], strict=False))


def test_mu_i_comes_within_10_percent_of_the_grains_at_1_4_mm(mu_i):
    """D0 = 4 cm: μ(I) with d = 2 mm at h ≤ 1.4 mm against the r_p = 1 mm DEM silo (48.9 kg/(m s))."""
    grains = dem_rate("silo_dem_r1mm")
    for h in (0.0014, 0.001):
        assert abs(rate_at(mu_i, 0.04, h) / grains - 1.0) < 0.10, h


@pytest.mark.xfail(strict=True, reason=(
    "Drucker–Prager (Table 3, φ = 35°, ψ = 25°) at D0 = 4 cm: 38.4 kg/(m s) at 1.4 mm, Richardson W∞ = "
    "40.5 ± 2.1, against 48.9 for the r_p = 1 mm grains: 17-21 % below; its friction is the static one at "
    "every rate"))
def test_drucker_prager_comes_within_10_percent_of_the_grains(dp):
    assert abs(rate_at(dp, 0.04, 0.0014) / dem_rate("silo_dem_r1mm") - 1.0) < 0.10


@pytest.mark.xfail(strict=True, reason=(
    "the DEM silos (H100) run 2.4 x (r_p = 1 mm, 48.9 kg/(m s)) and 2.8 x (0.5 mm, 56.9) the seed's curve "
    "(20.2 at D0 = 4 cm): free disks with μ = 0.5 and no rolling resistance flow faster than the paper's "
    "curve, as both continua do under refinement"))
def test_grains_match_the_seeds_beverloo_curve():
    assert abs(dem_rate("silo_dem_r1mm") / 20.22 - 1.0) < 0.2
