"""What a run will cost, checked before its first step (mpmdem.study.run_plan): the frame interval against
the stable step, the output size against a limit, a warning for a run of days."""

import subprocess
import sys

import pytest
from helpers import ENV

from mpmdem.errors import InputError
from mpmdem.study.run_plan import (
    check_frame_interval,
    check_output_size,
    estimate_output_bytes,
    long_run_warning,
    parse_size,
)

CLI = [sys.executable, "-m", "mpmdem.cli"]


def test_estimate_counts_points_frames_fields_and_bytes():
    """Verify the estimate grows by points × 60 B a frame in f32 (14 floats and an int32 body index;
    116 B in f64; 8 B more coupled), counts the bodies, and is linear in the frames."""
    empty = estimate_output_bytes(0, 0, 9)
    assert estimate_output_bytes(1000, 0, 9) - empty == 10 * 1000 * 60
    assert estimate_output_bytes(1000, 0, 9, "f64") - empty == 10 * 1000 * 116
    assert estimate_output_bytes(1000, 0, 9, coupled=True) - estimate_output_bytes(1000, 0, 9) == 10 * 1000 * 8
    assert estimate_output_bytes(0, 3, 9) > empty
    one = estimate_output_bytes(1000, 2, 9) - estimate_output_bytes(1000, 2, 8)
    assert estimate_output_bytes(1000, 2, 99) - estimate_output_bytes(1000, 2, 9) == 90 * one


def test_frame_interval_below_the_step_is_refused_naming_the_most_frames():
    """Verify frames whose interval is below dt are refused with the most frames allowed; one frame
    of a run shorter than a step is accepted."""
    check_frame_interval(1.0, 1000, 1e-3)
    check_frame_interval(1e-4, 1, 1e-3)
    with pytest.raises(InputError, match="--frames.*at most 1000 ") as err:
        check_frame_interval(1.0, 1001, 1e-3)
    assert "stable step 0.001 s" in str(err.value)


def test_output_above_the_limit_is_refused_with_the_estimate(tmp_path):
    """Verify an estimate above --max-output is refused naming the estimate and the limit; without
    a limit, a size beyond 20 % of any disk (1e30 B) is refused too."""
    check_output_size(10**6, tmp_path, 10, limit=10**6)
    with pytest.raises(InputError, match=r"about 2 MB, above the limit 1 MB \(--max-output\)"):
        check_output_size(2 * 10**6, tmp_path, 10, limit=10**6)
    with pytest.raises(InputError, match="free disk"):
        check_output_size(10**30, tmp_path / "not" / "yet", 10)


@pytest.mark.parametrize("text, size", [("500M", 5 * 10**8), ("2G", 2 * 10**9), ("2gb", 2 * 10**9), ("1e9", 10**9),
                                        ("4096", 4096), ("1.5k", 1500)])
def test_sizes_parse_with_decimal_units(text, size):
    """Verify --max-output reads bytes and k/M/G/T suffixes."""
    assert parse_size(text) == size


@pytest.mark.parametrize("text", ["0", "-1G", "nan", "inf", "2X", "G"])
def test_bad_sizes_are_refused(text):
    """Verify --max-output refuses 0, negatives, NaN, inf and unknown units."""
    import argparse

    with pytest.raises(argparse.ArgumentTypeError, match="is invalid"):
        parse_size(text)


def test_a_run_of_days_is_announced_and_a_short_one_is_not():
    """Verify the warning gives the steps and a lower bound on the time (years for 1e9 s at a
    1e-4 s step on a GPU), and that a run of minutes gets none."""
    line = long_run_warning(1e9, 1e-4, 1000, "cuda:0")
    assert line is not None and "1e+13 steps" in line and "years" in line
    assert long_run_warning(1.0, 1e-4, 1000, "cuda:0") is None
    assert "days" in long_run_warning(1e4, 1e-4, 10**6, "cpu")
    assert long_run_warning(1e9, 1e-4, 0, "cpu") is None  # no points: no measured CPU bound


def test_cli_refuses_frames_below_the_step_before_running(tmp_path):
    """Verify the issue's `--frames 100000000 --end-time 0.01` exits 2 with one line naming
    --frames, and writes no run file."""
    proc = subprocess.run(CLI + ["run", "axial-bar", "--quick", "--quiet", "--device", "cpu", "--out", str(tmp_path),
                                 "--frames", "100000000", "--end-time", "0.01"], capture_output=True, text=True,
                          env=ENV, timeout=120)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "--frames=100000000 is invalid" in lines[0], proc.stderr
    assert not list(tmp_path.glob("*.h5"))


def test_grains_are_estimated_as_points_not_outlines():
    """A grain's XDMF view is one point (RUN_grains.xdmf), so 1e6 grains cost their fields only:
    the estimate drops by the outline bytes of every grain, and no more."""
    from mpmdem.study.run_plan import OUTLINE_BYTES_PER_BODY, estimate_output_bytes

    as_bodies = estimate_output_bytes(0, 1_000_000, 20, "f32")
    as_grains = estimate_output_bytes(0, 1_000_000, 20, "f32", grains=1_000_000)
    assert as_bodies - as_grains == 21 * 1_000_000 * OUTLINE_BYTES_PER_BODY
    assert as_grains < 21 * 1_000_000 * 64  # a few floats a grain a frame
