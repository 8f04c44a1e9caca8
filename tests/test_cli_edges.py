"""Rough edges of the command line: one-line errors for bad inputs, a log-friendly progress
report, Warp's driver warning replaced by one line of ours, and the list of files written."""

import subprocess
import sys

import pytest
from helpers import ENV

from mpmdem.warp_init import DRIVER_WARNING, cpu_only

CLI = [sys.executable, "-m", "mpmdem.cli"]


def _one_line_error(proc, needle):
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, proc.stderr
    assert needle in lines[0]


@pytest.mark.parametrize("frames", ["-1", "0", "two"])
def test_frames_below_one_is_a_one_line_error(tmp_path, frames):
    """Verify --frames -1 / 0 / a word exits 2 with one line naming --frames (the API refuses them)."""
    proc = subprocess.run(CLI + ["run", "axial-bar", "--quick", "--quiet", "--device", "cpu", "--out", str(tmp_path),
                                 "--frames", frames], capture_output=True, text=True, env=ENV, timeout=120)
    _one_line_error(proc, "--frames")


def test_out_that_cannot_be_created_is_a_one_line_error(tmp_path):
    """Verify an --out below a regular file exits 2 with one line naming --out."""
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    proc = subprocess.run(CLI + ["run", "axial-bar", "--quick", "--quiet", "--device", "cpu",
                                 "--out", str(blocker / "run")], capture_output=True, text=True, env=ENV, timeout=300)
    _one_line_error(proc, "--out")


@pytest.mark.parametrize("command", ["plot", "info"])
def test_plot_and_info_of_a_non_hdf5_file_are_one_line_errors(tmp_path, command):
    """Verify `mpmdem plot` (and `info`) on a text file exits 2 with one line naming the file."""
    bogus = tmp_path / "run.h5"
    bogus.write_text("not HDF5")
    proc = subprocess.run(CLI + [command, str(bogus)], capture_output=True, text=True, env=ENV, timeout=120)
    _one_line_error(proc, "not a readable mpmdem HDF5 file")


def test_run_in_a_log_reports_progress_lines_and_every_file(tmp_path):
    """Verify a run whose stderr is not a terminal prints progress lines (no carriage returns), no
    Warp driver warning (one line of ours instead when there is no driver), and ends naming all
    the files it wrote: summary, HDF5, XDMF and CSV."""
    proc = subprocess.run(CLI + ["run", "axial-bar", "--quick", "--device", "cpu", "--out", str(tmp_path),
                                 "--end-time", "1.0", "--frames", "10"], capture_output=True, text=True, env=ENV,
                          timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert "\r" not in proc.stderr and DRIVER_WARNING not in proc.stderr
    progress = [ln for ln in proc.stderr.splitlines() if ln.startswith("sim time")]
    # a line each time a batch of steps passes the next 5 % (ten frames: at least one per frame),
    # the last at 100 %
    assert 10 <= len(progress) <= 21 and "(100 %)" in progress[-1]
    assert ("running on the CPU" in proc.stderr) == cpu_only()
    last = proc.stdout.strip().splitlines()[-1]
    for name in ("summary.json", "axial_bar.h5", "axial_bar.xdmf", "energy.csv"):
        assert name in last, last
