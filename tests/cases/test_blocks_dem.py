"""cases/sand_blocks.py --sand dem: the block impact of MPM-SDEM §6 with the sand column as DEM grains, at a
quick size (r = 3 mm, ±15 %: ~580 grains settled behind a gate, then 0.6 s; about 20 s on 2 CPU cores)."""

import math

import pytest
from helpers import quick_run, run_refused

from mpmdem.cases import sand_blocks as sb
from mpmdem.study.references.table3 import DENSITY

QUICK = ("--sand", "dem", "--grain-radius", "0.003")


@pytest.fixture(scope="module")
def quick():
    return quick_run("sand_blocks", *QUICK)[0]


def test_the_grains_settle_to_the_continuums_column(quick):
    """The settled column, at rest, is a 2D random close packing (φ = 0.82 ± 0.02, Berryman 1983,
    widened by 0.01 for a window of ~300 grains: tests/cases/test_column_dem.py) whose bulk density is
    Table 3's 1500 kg/m³ within 3.5 % (ρ_s = 1500 / 0.82); the grains keep their mass (f32 probe sums)
    and no grain centre ever ends a frame inside a block (the deepest reading, as the MPM run's)."""
    s = quick["settled"]
    assert quick["status"] == "completed" and quick["sand"] == "dem" and quick["grains"] > 400
    assert 0.79 <= s["packing_fraction"] <= 0.85
    assert s["bulk_density"] == pytest.approx(DENSITY, rel=0.035)
    assert quick["mass_max_relative_change"] < 1e-6
    assert quick["deepest_penetration_m"] == 0.0


def test_the_flow_reaches_the_blocks_when_the_experiment_does(quick):
    """The front (the farthest grain's edge) reaches block 3's face at the paper's 0.25 s (MPM-SDEM §6,
    at g = 10 m/s²: the case's header) within the validation's tolerance, its 0.05 s reading resolution
    plus a frame (±0.035 s); and no sooner than energy allows: a grain falling the column's height
    H = 0.2 m moves at most sqrt(2 g H) = 2 m/s, so it crosses the 0.2 m to the blocks in ≥ 0.1 s."""
    gap = sb.BLOCK_X - 0.5 * sb.BLOCK[0] - sb.COLUMN[0]
    assert quick["reach_time"] >= gap / math.sqrt(2.0 * sb.GRAVITY * sb.COLUMN[1])
    assert quick["reach_time"] == pytest.approx(sb.T_PAPER["reach"], abs=0.035)
    # block 3 is glued: the grains do not move it; blocks 1 and 2 are hit and move after the reach
    assert quick["block3_displacement_m"] == 0.0
    assert quick["block2_move_time"] >= quick["reach_time"]


def test_bad_grain_radius_is_one_line(tmp_path):
    code, lines = run_refused("sand_blocks", tmp_path, "--sand", "dem", "--grain-radius", "0.01")
    assert code == 2 and len(lines) == 1 and "--grain-radius" in lines[0]
