"""The refinement analysis of the silo studies (``studies/beverloo_refinement``) on data made from
known laws: the Richardson extrapolation recovers W∞ and the order, the Beverloo line recovers D*
and C, and a law whose intercept follows d is told from one whose intercept does not."""

import math

import numpy as np
import pytest

from mpmdem.study.builtin.beverloo import REFINED_GRIDS
from mpmdem.study.builtin.beverloo_refinement import analyze_grain, analyze_refinement, beverloo_line, richardson

RHO, G = 1500.0, 10.0


def law(d0, d_star, c=0.6):
    return c * RHO * math.sqrt(G) * (d0 - d_star) ** 1.5


@pytest.mark.parametrize("order", [1.0, 2.0])
def test_richardson_recovers_the_limit(order):
    h = np.array(REFINED_GRIDS)
    w = 30.0 - 4.0 * (h / 0.005) ** order
    r = richardson(h, w)
    assert r["w_inf"] == pytest.approx(30.0, rel=1e-6)
    assert r["order"] == pytest.approx(order, rel=1e-4)
    # the uncertainty is at least the distance to the finest grid
    assert r["w_inf_err"] >= abs(30.0 - w[-1]) * (1 - 1e-9)


def test_beverloo_line_recovers_intercept_and_prefactor():
    d0 = np.array([0.03, 0.04, 0.05, 0.06])
    line = beverloo_line(d0, law(d0, 0.007), RHO, G)
    assert line["D_star_m"] == pytest.approx(0.007, rel=1e-9)
    assert line["C"] == pytest.approx(0.6, rel=1e-9)


def _runs(rate_of, key, values, extra):
    return [{"status": "completed", "orifice_m": d, key: v, "rate": rate_of(d, v), **extra}
            for d in (0.02, 0.03, 0.04, 0.05, 0.06) for v in values]


def test_grid_set_intercept_is_read_per_grid():
    runs = _runs(lambda d, h: law(d, 3.5 * h), "cell_size", REFINED_GRIDS, {})
    res = analyze_refinement(runs, RHO, G)
    for h, line in res["per_grid"].items():
        if line["n"] < 3:  # 5 mm: only D0 = 5 and 6 cm are ten cells wide, too few for a line
            assert float(h) == 0.005 and line["D_star_m"] is None
            continue
        assert line["D_star_m"] == pytest.approx(3.5 * float(h), rel=1e-6)
        # only orifices at least ten cells wide enter
        assert min(line["orifices_m"]) >= 10 * float(h) - 1e-12


def test_grain_set_intercept_follows_d_and_grid_set_does_not():
    ds = [0.0005, 0.001, 0.002, 0.004]
    follows = analyze_grain(_runs(lambda d, dg: law(d, 1.6 * dg), "grain_diameter_m", ds, {"cell_size": 0.0025}),
                            RHO, G)
    assert follows["d_star_slope_per_d"] == pytest.approx(1.6, rel=1e-6)
    ignores = analyze_grain(_runs(lambda d, dg: law(d, 0.009), "grain_diameter_m", ds, {"cell_size": 0.0025}),
                            RHO, G)
    assert abs(ignores["d_star_slope_per_d"]) < 1e-6


def test_against_grains_is_the_ratio_to_the_dem_rate_per_orifice():
    """The continuum's finest-grid W and W∞ against the DEM silo's W at the same D0, as W / W_DEM − 1;
    an orifice the DEM study lacks is left out (not compared with nothing)."""
    from mpmdem.study.builtin.beverloo_refinement import against_grains

    result = {"per_orifice": {"0.04": {"h_m": [0.002, 0.001], "rate": [30.0, 36.0], "w_inf": 40.0},
                              "0.06": {"h_m": [0.001], "rate": [70.0], "w_inf": None}}}
    grains = {"per_grain_radius": {"0.001": {"rate": {"0.04": 48.0}}}}
    rows = against_grains(result, grains)
    assert set(rows) == {"0.04"}
    assert rows["0.04"] == {"dem": 48.0, "finest": pytest.approx(36.0 / 48.0 - 1.0),
                            "w_inf": pytest.approx(40.0 / 48.0 - 1.0)}
