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

import numpy as np
import pytest
from helpers import ROOT

from mpmdem.study.builtin.beverloo_refinement import analyze_grain, analyze_refinement
from mpmdem.study.builtin.run_summaries import load_runs
from mpmdem.study.references.table3 import DENSITY, GRAVITY

STUDIES = ROOT / "bench" / "results" / "studies"


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


def change(res: dict, d0: float, fine: float, coarse: float) -> float:
    """|W(fine) − W(coarse)| / W(fine) at orifice d0 [m] between two grids [m]."""
    w_fine, w_coarse = rate_at(res, d0, fine), rate_at(res, d0, coarse)
    return abs(w_fine - w_coarse) / w_fine


def test_every_run_completed(mu_i, dp):
    for name, n in (("beverloo-mu-i", 30), ("beverloo-refined", 30), ("beverloo-mu-i-grain", 16), ("beverloo-dem", 10)):
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
        assert change(mu_i, d0, 0.001, 0.002) < 0.03, d0


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
    "Drucker–Prager (Table 3, φ = 35°, ψ = 25°, H100) at h = 1 mm runs 16, 19, 19, 20 and 19 % below the "
    "r_p = 1 mm grains at D0 = 2-6 cm (14.2, 25.8, 39.6, 55.3, 72.9 against 17.0, 31.8, 49.1, 68.9, 90.8 "
    "kg/(m s)); its Richardson W∞ (six grids, 5-1 mm) is still 10-18 % below: its friction is the static "
    "one at every rate, where the grains' (and μ(I)'s) rises with I"))
def test_drucker_prager_comes_within_10_percent_of_the_grains(dp):
    grains = dem_study()["0.001"]["rate"]
    for d0, w in grains.items():
        assert rate_at(dp, float(d0), 0.001) == pytest.approx(w, rel=0.10), d0
        assert dp["per_orifice"][f"{float(d0):g}"]["w_inf"] == pytest.approx(w, rel=0.10), d0


@pytest.mark.xfail(strict=True, reason=(
    "Drucker–Prager (H100): W changes over the last halving 2 -> 1 mm by +11.1, +8.1, +6.0 and +5.0 % at "
    "D0 = 3, 4, 5, 6 cm (+26 % at 2 cm): like μ(I), the intercept shrinks with the cell (D* = 3.5, 1.0, "
    "-0.2 mm at h = 2, 1.4, 1 mm) while C settles at 1.04-1.09"))
def test_drucker_prager_rate_converges_within_3_percent(dp):
    for d0 in (0.03, 0.04, 0.05, 0.06):
        assert change(dp, d0, 0.001, 0.002) < 0.03, d0


@pytest.mark.xfail(strict=True, reason=(
    "the DEM silos (H100) run 2.4 x (r_p = 1 mm, 48.9 kg/(m s)) and 2.8 x (0.5 mm, 56.9) the seed's curve "
    "(20.2 at D0 = 4 cm): free disks with μ = 0.5 and no rolling resistance flow faster than the paper's "
    "curve, as both continua do under refinement"))
def test_grains_match_the_seeds_beverloo_curve():
    assert abs(dem_rate("silo_dem_r1mm") / 20.22 - 1.0) < 0.2


def dem_study():
    from mpmdem.study.builtin.beverloo_refinement import analyze_dem

    return analyze_dem(load_runs(STUDIES / "beverloo-dem"), DENSITY, GRAVITY)["per_grain_radius"]


def test_dem_study_repeats_the_single_silo():
    """The r_p = 1 mm, D0 = 4 cm silo of the DEM study and the one run alone agree to the GPU-atomics
    scatter of a run (the rates repeat to about 1 %, docs/studies)."""
    assert dem_study()["0.001"]["rate"]["0.04"] == pytest.approx(dem_rate("silo_dem_r1mm"), rel=0.02)


def test_mu_i_at_1_mm_matches_the_grains_at_every_orifice(mu_i):
    """μ(I) with d = 2 mm at h = 1 mm against the r_p = 1 mm grains, D0 = 2-6 cm: within 10 %."""
    grains = dem_study()["0.001"]["rate"]
    for d0, w in grains.items():
        assert rate_at(mu_i, float(d0), 0.001) == pytest.approx(w, rel=0.10), d0


@pytest.mark.xfail(strict=True, reason=(
    "the r_p = 1 mm grains (H100, D0 = 2-6 cm) fit W^(2/3) = s (D0 − D*) with D* = 0.2 ± 0.3 mm "
    "(C = 1.30): no dead zone of k r_p with the 2D law's k ≈ 1-3; with r_p = 0.5 mm the intercept is "
    "negative (−2.4 ± 0.7 mm, C = 1.35): the smaller grains flow 11-25 % faster at every orifice, more than "
    "a dead zone of a grain explains"))
def test_grains_have_a_beverloo_dead_zone_of_a_few_radii():
    for r_p, line in dem_study().items():
        assert 1.0 <= line["D_star_m"] / float(r_p) <= 3.0, r_p


@pytest.mark.xfail(strict=True, reason=(
    "halving the grains raises the DEM rate at D0 = 4 cm by 16 % (49.1 -> 56.7 kg/(m s)); halving d in "
    "μ(I) (2 -> 1 mm, h = 2.5 mm) raises it by 3.4 % (40.6 -> 42.0): μ(I) carries the grain size, "
    "too weakly to follow the grains"))
def test_mu_i_follows_the_grains_grain_size():
    grains = dem_study()
    dem_gain = grains["0.0005"]["rate"]["0.04"] / grains["0.001"]["rate"]["0.04"] - 1.0
    runs = {(r["orifice_m"], r["grain_diameter_m"]): r["rate"] for r in load_runs(STUDIES / "beverloo-mu-i-grain")}
    mu_i_gain = runs[(0.04, 0.001)] / runs[(0.04, 0.002)] - 1.0
    assert mu_i_gain == pytest.approx(dem_gain, rel=0.5)


@pytest.fixture(scope="module")
def calibrated():
    return analyze_refinement(load_runs(STUDIES / "beverloo-calibrated"), DENSITY, GRAVITY)


def test_calibrated_drucker_prager_at_2mm_within_10_percent_of_the_grains(calibrated):
    """Drucker–Prager with the grains' own friction angle (φ = 17.9°, the r_p = 1 mm disks' angle of repose,
    ψ = 0; study beverloo-calibrated, H100) on the 2 mm grid against the r_p = 1 mm DEM silo at every D0 it
    has a rate for (2-5 cm: at 6 cm the fast flow leaves too few frames in the window of those runs): the
    issue's 10 % criterion."""
    grains = dem_study()["0.001"]["rate"]
    compared = [d0 for d0 in grains if 0.002 in calibrated["per_orifice"].get(f"{float(d0):g}", {}).get("h_m", [])]
    assert len(compared) >= 4
    for d0 in compared:
        assert rate_at(calibrated, float(d0), 0.002) == pytest.approx(grains[d0], rel=0.10), d0


@pytest.mark.xfail(strict=True, reason=(
    "Drucker–Prager with the grains' φ = 17.9° (H100) is not converged at 2 mm: W still rises by 20.8, 8.1, "
    "6.1 and 5.2 % from 2.5 to 2 mm at D0 = 2-5 cm (14.8 -> 17.9, 32.0 -> 34.6, 50.3 -> 53.3, 69.9 -> 73.5 "
    "kg/(m s)): the cell size still sets the dead zone, as with Table 3's angles; its agreement with the grains "
    "at 2 mm is a crossing, and a Richardson W-inf from grids of 5-2 mm lies 26-41 % above them (1.4 and 1 mm "
    "not run)"))
def test_calibrated_drucker_prager_is_converged_at_2mm(calibrated):
    """The issue's convergence target: W changes by < 3 % over the last refinement step run (2.5 -> 2 mm)."""
    for d0 in (0.02, 0.03, 0.04, 0.05):
        assert change(calibrated, d0, 0.002, 0.0025) < 0.03, d0


@pytest.fixture(scope="module")
def mu_i_disks():
    return analyze_refinement(load_runs(STUDIES / "beverloo-mu-i-disks"), DENSITY, GRAVITY)


@pytest.mark.xfail(strict=True, reason=(
    "the disks' own mu(I) (H100) on its finest grid run, 2 mm, is 9.3, 11.2, 9.9 and 9.8 % above the grains at "
    "D0 = 3-6 cm (34.7, 54.6, 75.7, 99.7 against 31.8, 49.1, 68.9, 90.8 kg/(m s)), and still rising: it crossed "
    "them near 2.5 mm (+0 to +5 %), as Drucker-Prager at the grains' angle did near 2 mm"))
def test_disks_own_mu_i_on_its_finest_grid_within_10_percent_of_the_grains(mu_i_disks):
    """μ(I) with the r_p = 1 mm disks' own incline fit (μs 0.228, μ2 0.81, I0 0.38, d = 2 mm; study
    beverloo-mu-i-disks, H100) on the finest grid run against the r_p = 1 mm DEM silo, at the orifices
    at least MIN_CELLS_ACROSS (10) cells wide on every grid compared (3-6 cm): the issue's 10 %."""
    grains = dem_study()["0.001"]["rate"]
    h = min(mu_i_disks["per_orifice"]["0.04"]["h_m"])
    for d0 in (0.03, 0.04, 0.05, 0.06):
        assert rate_at(mu_i_disks, d0, h) == pytest.approx(grains[f"{d0:g}"], rel=0.10), d0


@pytest.mark.xfail(strict=True, reason=(
    "the disks' own mu(I) (H100) is not converged at 2 mm: W changes by 8.1, 6.4, 4.6 and 4.6 % of its 2 mm "
    "value from 2.5 to 2 mm at D0 = 3-6 cm (31.9 -> 34.7, 51.1 -> 54.6, 72.3 -> 75.7, 95.1 -> 99.7 kg/(m s)), "
    "as Drucker-Prager at the grains' angle does (1.4 and 1 mm not run)"))
def test_disks_own_mu_i_is_converged(mu_i_disks):
    """The issue's convergence target: W changes by < 3 % over the last refinement step run."""
    for d0 in (0.03, 0.04, 0.05, 0.06):
        fine, coarse = sorted(mu_i_disks["per_orifice"][f"{d0:g}"]["h_m"])[:2]
        assert change(mu_i_disks, d0, fine, coarse) < 0.03, d0
