"""The granular flow cases of "Granular MPM" §4.3 (silo filling) and §4.4 (Toyoura flume), run as a
user would (``--quick`` on the CPU)."""

import math

import pytest
from helpers import run_script


@pytest.fixture(scope="module")
def silo(tmp_path_factory):
    return run_script("silo_filling", tmp_path_factory.mktemp("silo"))


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
    assert 0.0 < silo["fill_height_m"] < 7.5
    # "Granular MPM" §4.3: the points of Granular MPM's deposit move at 0-1 m/s (stress-free MPM's at
    # 4-6 m/s); after a second of rest, every deposited point is below the top of that range
    assert silo["deposit_max_speed"] < 1.0
    # density control (eq. 13-15) keeps points at or above the critical density, 2235 kg/m³
    assert silo["deposit_min_density"] >= 2235.0 * (1.0 - 1e-6)
    # at rest on a short pile the floor (a load cell) carries the deposit's weight; the no-slip side
    # walls may take a share of it (Janssen), never more than all of it
    assert 0.5 < silo["floor_load_over_weight"] < 1.05
    assert silo["layers_final"] >= 1


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
    assert flume["peak_force_N_times_width"] == pytest.approx(0.3 * flume["peak_force_N_per_m"])
