"""Frames written in a worker thread while the run steps on (``mpmdem.io.background``): the same
file as the writer in the caller's thread, frames in order, every frame before an error or a Ctrl-C
whole in the file, and a failed write raised by the next call."""

import xml.etree.ElementTree as ET

import numpy as np
import pytest
from test_io import N, make_fields

from mpmdem.io import FrameWriter, RunFile
from mpmdem.io.background import BackgroundFrameWriter


def write(path, background: bool, frames: int = 6):
    writer = FrameWriter(path, particle_count=N, attrs={"case": "test"}, csv_path=path.with_suffix(".csv"))
    if background:
        writer = BackgroundFrameWriter(writer)
    with writer as w:
        for k in range(frames):
            w.write_frame(0.1 * k, make_fields(k), {"energy_kinetic": float(k)})
        w.set_status("completed")


def test_background_frames_are_the_callers_frames(tmp_path):
    """Verify six frames written in the worker read back as those written in the caller's thread:
    times, every field of every frame, the status and the CSV log."""
    write(tmp_path / "a.h5", False)
    write(tmp_path / "b.h5", True)
    with RunFile(tmp_path / "a.h5") as a, RunFile(tmp_path / "b.h5") as b:
        np.testing.assert_array_equal(a.times, b.times)
        assert a.frame_count == b.frame_count == 6 and a.status == b.status == "completed"
        for name in a.fields:
            for k in range(6):
                np.testing.assert_array_equal(a.field(name, k), b.field(name, k))
    assert (tmp_path / "a.csv").read_text() == (tmp_path / "b.csv").read_text()


def test_a_failed_background_write_is_raised_and_keeps_the_frames_before(tmp_path):
    """Verify a frame the writer rejects (a wrong shape) raises ValueError at the next call, the
    status can still be set, and the two frames before it stay whole in the file."""
    path = tmp_path / "run.h5"
    w = BackgroundFrameWriter(FrameWriter(path, particle_count=N, attrs={}))
    w.write_frame(0.0, make_fields(0), {"e": 0.0})
    w.write_frame(0.1, make_fields(1), {"e": 1.0})
    bad = make_fields(2)
    bad["x"] = bad["x"][:-1]
    w.write_frame(0.2, bad, {"e": 2.0})  # (rejected in the worker)
    with pytest.raises(ValueError):
        w.write_frame(0.3, make_fields(3), {"e": 3.0})
    w.set_status("failed", "a bad frame")
    w.close()
    w.close()  # (harmless)
    with RunFile(path) as rf:
        assert rf.frame_count == 2 and rf.status == "failed"
        np.testing.assert_array_equal(rf.times, [0.0, 0.1])


def test_background_close_brings_the_sidecar_up_to_every_frame(tmp_path):
    """Verify a background writer with a sidecar_interval longer than the test lists every frame in
    its sidecar once closed (the worker's frames after the first did not rewrite it)."""
    path = tmp_path / "run.h5"
    with BackgroundFrameWriter(FrameWriter(path, particle_count=N, attrs={}, sidecar_interval=1e9)) as w:
        for k in range(4):
            w.write_frame(0.1 * k, make_fields(k), {"e": float(k)})
        w.wait()
        assert len(ET.parse(path.with_suffix(".xdmf")).getroot().find("Domain/Grid").findall("Grid")) == 1
    assert len(ET.parse(path.with_suffix(".xdmf")).getroot().find("Domain/Grid").findall("Grid")) == 4


def test_switch_interval_is_lowered_inside_and_restored_after():
    """Verify ``thread_switch_interval`` lowers Python's thread switch interval inside (a writer
    that gave up Python's lock around an HDF5 write gets it back sooner from a busy main thread),
    never raises it, leaves it for 0, and restores it after, also after an exception."""
    import sys

    from mpmdem.io.background import thread_switch_interval

    before = sys.getswitchinterval()
    with thread_switch_interval(before / 10):
        assert sys.getswitchinterval() == pytest.approx(before / 10)
    assert sys.getswitchinterval() == before
    for unchanged in (0.0, 10 * before):
        with thread_switch_interval(unchanged):
            assert sys.getswitchinterval() == before
    with pytest.raises(RuntimeError), thread_switch_interval(before / 10):
        raise RuntimeError("a failed run")
    assert sys.getswitchinterval() == before
