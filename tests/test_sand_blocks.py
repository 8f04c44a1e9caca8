"""cases/sand_blocks.py --quick: the block impact of MPM-SDEM §6 on the experiment's geometry.

One coarse run (6.25 mm grid, 2048 points, 0.6 s; ~15 s on 2 CPU cores) shared by all checks.
"""

import math

import pytest
from helpers import quick_run

# the experiment, restated so that a change in the case has to be looked at here too
BLOCK_W, BLOCK_H = 0.020, 0.018  # m
COLUMN_W, COLUMN_H, SAND_RHO = 0.10, 0.20, 1500.0  # m, m, kg/m³
# MPM-SDEM §6 at g = 10 m/s² (see the case header for the ×10 of its printed times)
PAPER = {"reach": 0.25, "block2_ground": 0.40, "block1_ground": 0.45}
# The paper gives its times to 0.05 s (printed 2.5, 4.0, 4.5 s), i.e. each ±0.025 s; our frames are
# 0.01 s apart. The quick grid is half the default resolution (2048 against 8192 points): we allow
# twice the paper's reading resolution, ±0.05 s. A wrong g reading (sqrt(10) or 10 × in time), a
# stalled flow or a block that does not fall misses by far more.
TOLERANCE = 0.05  # s
# A block standing on a flat face tips once it has turned about its lower corner by atan(w/h).
TIP_ANGLE = math.degrees(math.atan(BLOCK_W / BLOCK_H))  # 48°


@pytest.fixture(scope="module")
def summary(tmp_path_factory):
    return quick_run("sand_blocks")[0]


def test_completed(summary):
    assert summary["status"] == "completed"
    assert summary["points"] == 2048  # 16 × 32 cells of 6.25 mm, 2 × 2 points each


def _check_event(summary, event):
    t = summary["event_times_s"][event]
    assert t is not None, f"{event} never happened"
    assert abs(t - PAPER[event]) <= TOLERANCE, f"{event} at {t:.3f} s, paper {PAPER[event]} s"


@pytest.mark.parametrize("event", ["reach", "block2_ground"])
def test_event_times_against_the_paper(summary, event):
    """The sand reaches the stack, and block 2 comes to lie on its side on the floor, at the paper's
    times (at the full grids, on the GPU: reach 0.22 s and block 2 at 0.39-0.40 s, docs/studies/index.md)."""
    _check_event(summary, event)


@pytest.mark.xfail(strict=True, reason="on the quick grid block 1 ends leaning on the sand, touching the floor at "
                   "0.49 s but never lying flat on it by 0.6 s; at the full grids (GPU, docs/studies/index.md) it "
                   "lies flat at 0.39-0.40 s with Table 3's friction (paper 0.45 s), 0.40-0.47 s or never with the "
                   "reproduction's")
def test_block1_lands_at_the_papers_time(summary):
    _check_event(summary, "block1_ground")


def test_block1_falls_to_the_floor_after_block2(summary):
    # block 1 rides block 2 down: it reaches the floor (a corner first) after block 2 does
    assert summary["block1_touch_time"] is not None
    assert summary["block1_touch_time"] > summary["block2_touch_time"]


def test_block2_ends_on_its_side(summary):
    """The paper's block 2 turns from 90° (upright) to about 0° (on its side). Lying on the floor it
    is at 0°; on a sand layer or against block 3 it may lean: ±15° is a block's height over a grain
    layer of a third of its width, far from the 90° of a block that was not toppled."""
    assert summary["block2_max_abs_angle_deg"] > TIP_ANGLE
    assert abs(summary["block2_final_orientation_deg"]) < 15.0


def test_blocks_move_only_after_the_flow_arrives(summary):
    # the stack stands in equilibrium on the glued block; a free block that moved (> 1 mm) before
    # the sand reached the pile would mean a spurious contact force (overlap, list or IMP error)
    reach = summary["reach_time"]
    for name in ("block1", "block2"):
        moved = summary[f"{name}_move_time"]
        assert moved is not None and moved >= reach


def test_no_sand_inside_a_block(summary):
    # the contact keeps every point centre r_p outside a block at every frame
    assert summary["deepest_penetration_m"] == 0.0


def test_glued_block_does_not_move(summary):
    # a fixed body is never integrated: exactly zero, whatever the sand and the blocks push
    assert summary["block3_displacement_m"] == 0.0
    assert summary["block3_rotation_deg"] == 0.0


def test_no_energy_gain(summary):
    # W_num = ΔE_total − Σ works (plastic, contact damping and friction, walls): what the scheme
    # itself made or lost. APIC and the contacts only dissipate; a gain above 0.5 % of the released
    # potential energy (round-off is ~1e-7 of it in f32) would be spurious work of the coupling.
    released = summary["released_potential_energy"]
    assert released > 0.0
    assert summary["work_numerical_max"] <= 0.005 * released


def test_mass_conserved(summary):
    # points carry fixed masses and none is released or removed
    assert summary["mass_max_relative_change"] <= 1.0e-6
    assert summary["mass_initial"] == pytest.approx(SAND_RHO * COLUMN_W * COLUMN_H, rel=1.0e-6)
