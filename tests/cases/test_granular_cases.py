"""The granular flow cases of "Granular MPM" §4.3 (silo filling) and §4.4 (Toyoura flume), run as a
user would (``--quick`` on the CPU)."""

import math

import pytest
from helpers import quick_run, run_script


@pytest.fixture(scope="module")
def silo(tmp_path_factory):
    return quick_run("silo_filling")[0]


@pytest.fixture(scope="module")
def flume(tmp_path_factory):
    return run_script("toyoura_flume", tmp_path_factory.mktemp("flume"))


def test_silo_filling_conserves_the_mass_it_is_fed(silo):
    assert silo["status"] == "completed"
    assert silo["released_points"] == silo["points"] == 30
    assert silo["final_mass_kg_per_m"] == pytest.approx(silo["expected_mass_kg_per_m"], rel=1e-12)
    # The mass in the scene is a sum of constant point masses (ρ × 0.15², equal for all points, never
    # updated), so at every frame it equals the count of points released by then times that mass up
    # to the round-off of summing at most 30 float64 values: ≤ 30 ulp ≈ 7e-15 relative.
    assert silo["max_relative_mass_error"] <= 1e-12


def test_silo_filling_deposits_every_point_at_rest(silo):
    # the quick run settles 2 s after the last release (which needs 1.22 s to fall), so every point
    # has landed and is counted as deposited
    assert silo["deposited_points"] == silo["released_points"]
    assert silo["deposit_inside_silo"]
    # Mass and density bound the deposit from below: the deposit's material (its mass at its mean
    # density, ≥ the critical 2235 kg/m³, E = 1 GPa leaves no room to compress further) cannot
    # fill less than its own area of the 2.7 m wide silo. An exact bound; 1e-9 is round-off.
    area = silo["final_mass_kg_per_m"] / silo["deposit_density"]
    assert silo["fill_height_m"] >= area / WIDTH * (1.0 - 1e-9)
    # "Granular MPM" §4.3: the points of Granular MPM's deposit move at 0-1 m/s (stress-free MPM's at
    # 4-6 m/s); after a second of rest, every deposited point is below the top of that range
    assert silo["deposit_max_speed"] < 1.0
    # density control (eq. 13-15) keeps points at or above the critical density, 2235 kg/m³
    assert silo["deposit_min_density"] >= 2235.0 * (1.0 - 1e-6)
    # at rest on a short pile the floor (a load cell) carries the deposit's weight; the no-slip side
    # walls may take a share of it (Janssen), never more than all of it
    assert 0.5 < silo["floor_load_over_weight"] < 1.05
    assert silo["layers_final"] >= 1


# "Granular MPM" §4.3 / Table 4: the silo's inner width and the point each release adds
WIDTH = 2.7  # m
POINT_AREA = 0.15**2  # m², the square each point stands for


@pytest.mark.xfail(strict=True, reason=(
    "we get a deposit 0.91 m high for 30 points, 3.6 × the void-free 0.25 m (packing 0.28), and "
    "95 % of the silo with all 504 points (paper: about half): with one point per 0.3 m cell, points "
    "that share nodes lock into arches around voids (cases/silo_filling.py header)"))
def test_silo_filling_packs_as_tightly_as_the_paper(silo):
    # Reference: "Granular MPM" §4.3, Fig. 15 at 27.79 s: Granular original MPM fills about half of
    # the 7.5 m silo with all 504 points, "regularly packed". 504 squares of 0.15 m cover 11.3 m²,
    # 4.2 m (0.56 H) of the 2.7 m silo without voids, and E = 1 GPa lets no point shrink: "about
    # half" is only reachable with a void-free deposit. So the paper's deposit is void-free, and so
    # should the quick run's 30 points be: their area over the width (0.25 m) plus at most one
    # ragged top row of points (0.15 m) — the tolerance is that one row.
    dense = silo["released_points"] * POINT_AREA / WIDTH
    assert silo["fill_height_m"] <= dense + 0.15


def test_toyoura_flume_hits_the_wall_and_settles(flume):
    assert flume["status"] == "completed"
    # the front reaches the wall within the run (a surge pushed by the sand behind it can beat a
    # frictionless slide, so no lower bound from kinematics)
    assert flume["arrival_time_s"] is not None and 0.0 < flume["arrival_time_s"] < flume["end_time"]
    assert flume["peak_force_N_per_m"] > 0.0
    final = flume["final_force_N_per_m"]
    # the impact overshoots the load of the sand at rest against the wall at the end ...
    assert flume["peak_force_N_per_m"] > final
    # ... which is a static value: positive, and between what the bed's friction leaves to the wall
    # and the whole down-slope weight of the sand (2 % margin for the residual motion)
    assert math.isfinite(final) and final > 0.0
    assert final <= 1.02 * flume["down_slope_weight_N_per_m"]
    assert final >= 0.98 * flume["static_load_cell_force_least_N_per_m"]
    # and it is steady: the sand is at rest and the last tenth of the force history is flat
    assert flume["final_max_speed_m_s"] < 0.05
    tail = [f for t, f in zip(flume["force_time_s"], flume["force_N_per_m"], strict=True)
            if t >= 0.9 * flume["end_time"]]
    assert max(tail) - min(tail) < 0.02 * final
    # No reference number: "Granular MPM" §4.4 compares with Moriguchi et al.'s load-cell record
    # only as a curve (Fig. 20) and gives no arrival time, peak force or runout in its text, so the
    # checks above are physical bounds, not a validation (cases/toyoura_flume.py, VALIDATION).
