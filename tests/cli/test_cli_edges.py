"""Rough edges of the command line: one-line errors for bad inputs, a log-friendly progress
report, Warp's driver warning replaced by one line of ours, and the list of files written."""

import subprocess
import sys

import pytest
from helpers import ENV

from mpmdem.sim.warp_init import DRIVER_WARNING, cpu_only

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


def test_sigterm_ends_like_ctrl_c(tmp_path):
    """Verify SIGTERM (a batch scheduler's stop) ends a run as Ctrl-C does: exit 143, the run file
    marked "interrupted" (naming SIGTERM) and readable, summary.json written."""
    import json
    import signal
    import time

    from mpmdem.io import RunFile

    proc = subprocess.Popen(CLI + ["run", "axial-bar", "--quick", "--quiet", "--device", "cpu", "--out", str(tmp_path),
                                   "--end-time", "1e6", "--frames", "1000"], stderr=subprocess.PIPE, text=True, env=ENV)
    h5 = tmp_path / "axial_bar.h5"
    deadline = time.monotonic() + 120
    while not h5.exists() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.1)
    time.sleep(0.5)  # (the run is in its steps: the file is opened inside the signal handling)
    proc.send_signal(signal.SIGTERM)
    err = proc.communicate(timeout=120)[1]
    assert proc.returncode == 143, err
    assert "Traceback" not in err and "SIGTERM" in err
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["status"] == "interrupted" and "SIGTERM" in summary["message"]
    with RunFile(h5) as run:
        assert run.status == "interrupted" and run.frame_count >= 1


def test_list_into_a_closed_pipe_exits_quietly():
    """Verify `mpmdem list | head` (the reader gone before the list is written) ends without a
    traceback, with 141 (128 + SIGPIPE) as `ls | head` does."""
    proc = subprocess.Popen(CLI + ["list"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV)
    proc.stdout.close()
    err = proc.stderr.read()
    assert proc.wait(timeout=120) == 141 and err == "", err


def test_plot_out_that_is_a_file_names_out(tmp_path, capsys):
    """Verify `mpmdem plot RUN.h5 --out EXISTING_FILE` blames --out, not the run file."""
    from mpmdem.cli import main

    run, blocker = tmp_path / "run.h5", tmp_path / "taken"
    run.write_text("never read")
    blocker.write_text("a file")
    assert main(["plot", str(run), "--out", str(blocker)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--out=" in err[0] and "a file of that name exists" in err[0], err


def test_info_of_a_folder_says_folder_and_names_its_runs(tmp_path, capsys):
    """Verify `mpmdem info DIRECTORY` says it is a folder (not "does not exist") and names the run
    files in it."""
    from mpmdem.cli import main

    (tmp_path / "silo_discharge.h5").write_text("")
    assert main(["info", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not a folder" in err[0] and "silo_discharge.h5" in err[0], err


@pytest.mark.skipif(not cpu_only(), reason="a CUDA device is here: --device cuda is valid")
def test_cuda_without_a_gpu_is_one_line_of_ours():
    """Verify --device cuda on a machine without a GPU prints our one line, no Warp error lines."""
    proc = subprocess.run(CLI + ["run", "axial-bar", "--quick", "--device", "cuda"], capture_output=True, text=True,
                          env=ENV, timeout=120)
    _one_line_error(proc, "device='cuda' is invalid: cpu")


@pytest.mark.parametrize("flag", ["--version", "-V"])
def test_version_names_mpmdem_and_warp(flag, capsys):
    """Verify `mpmdem --version` (and -V) prints mpmdem's version and the Warp it runs on, and exits 0."""
    import warp as wp

    from mpmdem import __version__
    from mpmdem.cli.commands import main

    assert main([flag]) == 0
    out = capsys.readouterr().out.strip()
    assert out == f"mpmdem {__version__} (warp {wp.config.version})", out
