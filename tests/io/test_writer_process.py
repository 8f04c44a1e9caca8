"""Frames written by a child process (``mpmdem.io.writer_process``): the same files as
``FrameWriter`` writes itself, errors raised in the parent, and a killed parent's files readable."""

import subprocess
import sys
import textwrap
from pathlib import Path

import h5py
import numpy as np
import pytest

from mpmdem.io import FrameWriter
from mpmdem.io.reader import RunFile
from mpmdem.io.writer_process import WriterProcess

POINTS, BODIES, FRAMES = 64, 2, 4


def frames(seed=0):
    rng = np.random.default_rng(seed)
    out = []
    for k in range(FRAMES):
        fields = {"x": rng.random((POINTS, 2)), "v": rng.random((POINTS, 2)), "stress": rng.random((POINTS, 2, 2)),
                  "volume": rng.random(POINTS), "mass": rng.random(POINTS), "F": rng.random((POINTS, 2, 2)),
                  "body": np.zeros(POINTS, np.int32)}
        bodies = {"x": rng.random((BODIES, 2)), "angle": rng.random(BODIES), "v": rng.random((BODIES, 2)),
                  "omega": rng.random(BODIES), "force": rng.random((BODIES, 2)), "torque": rng.random(BODIES)}
        out.append((1e-3 * k, fields, {"kinetic": float(rng.random()), "steps": float(k)}, bodies))
    return out


def geometry():
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    return {"vertex_start": 4 * np.arange(BODIES), "vertex_count": np.full(BODIES, 4),
            "vertices": np.tile(square, (BODIES, 1)), "radius": np.full(BODIES, 1e-3),
            "motion": np.zeros(BODIES, np.int32), "mass": np.ones(BODIES), "name": [f"b{i}" for i in range(BODIES)]}


def kwargs(tmp_path, name):
    return {"particle_count": POINTS, "attrs": {"precision": "f32"}, "csv_path": tmp_path / f"{name}.csv",
            "body_count": BODIES, "body_geometry": geometry()}


def datasets(path):
    out = {}
    with h5py.File(path, "r") as f:
        f.visititems(lambda name, obj: out.__setitem__(name, obj[()]) if isinstance(obj, h5py.Dataset) else None)
        out["status"] = f.attrs.get("status")
    return out


def test_two_files_of_a_child_are_the_files_a_frame_writer_writes(tmp_path):
    """Two files fed in turn by one child, against FrameWriter in this process: every dataset
    (fields, bodies, diagnostics, XDMF views and outlines), the status and the CSV the same."""
    data = [frames(0), frames(1)]
    with WriterProcess() as child:
        files = [child.open(tmp_path / f"c{k}.h5", **kwargs(tmp_path, f"c{k}")) for k in range(2)]
        for k in range(FRAMES):
            for f, d in zip(files, data, strict=True):
                t, fields, diag, bodies = d[k]
                f.write_frame(t, fields, diag, body_fields=bodies)
        for f in files:
            f.set_status("completed")
            f.close()
    for k in range(2):
        with FrameWriter(tmp_path / f"r{k}.h5", **kwargs(tmp_path, f"r{k}")) as ref:
            for t, fields, diag, bodies in data[k]:
                ref.write_frame(t, fields, diag, body_fields=bodies)
            ref.set_status("completed")
        a, b = datasets(tmp_path / f"c{k}.h5"), datasets(tmp_path / f"r{k}.h5")
        assert a.keys() == b.keys() and a["status"] == "completed"
        for name in a:
            assert np.array_equal(a[name], b[name]), name
        assert (tmp_path / f"c{k}.csv").read_text() == (tmp_path / f"r{k}.csv").read_text()


def test_a_write_that_fails_in_the_child_is_raised_here_and_its_file_is_still_marked(tmp_path):
    data = frames()
    with WriterProcess() as child:
        f = child.open(tmp_path / "bad.h5", **kwargs(tmp_path, "bad"))
        t, fields, diag, bodies = data[0]
        f.write_frame(t, fields, diag, body_fields=bodies)
        f.write_frame(t + 1e-3, {**fields, "x": fields["x"][:3]}, diag, body_fields=bodies)  # (a short field)
        with pytest.raises(RuntimeError, match="frame writer process failed"):
            f.wait()
        f.set_status("interrupted", "stopped")
        f.close()
    with RunFile(tmp_path / "bad.h5") as r:
        assert r.frame_count == 1 and r.status == "interrupted"


def test_a_file_the_child_cannot_open_raises_at_open(tmp_path):
    with WriterProcess() as child, pytest.raises(RuntimeError, match="open.*particle_count"):
        child.open(tmp_path / "x.h5", **{**kwargs(tmp_path, "x"), "particle_count": -1})


def test_a_killed_parent_leaves_every_frame_it_sent_readable(tmp_path):
    """The parent sends three frames and is killed (no close, no status): the child writes them,
    sees its stdin end, closes the file; the file reads with its three frames."""
    script = textwrap.dedent(f"""
        import os, signal, sys
        sys.path.insert(0, {str(tmp_path)!r})
        from pathlib import Path
        from mpmdem.io.writer_process import WriterProcess
        import test_frames
        child = WriterProcess()
        f = child.open(Path({str(tmp_path)!r}) / "killed.h5", **test_frames.kwargs(Path({str(tmp_path)!r}), "k"))
        for t, fields, diag, bodies in test_frames.frames()[:3]:
            f.write_frame(t, fields, diag, body_fields=bodies)
        f.wait()
        print(child._process.pid, flush=True)
        os.kill(os.getpid(), signal.SIGKILL)
    """)
    (tmp_path / "test_frames.py").write_text(open(__file__).read())
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert proc.returncode == -9, proc.stderr
    child_pid = int(proc.stdout.split()[0])
    import os
    import time

    deadline = time.time() + 30
    while time.time() < deadline:
        try:
            os.kill(child_pid, 0)
        except ProcessLookupError:
            break
        time.sleep(0.1)
    with RunFile(tmp_path / "killed.h5") as r:
        assert r.frame_count == 3
        x = r.field("x", 2)
        assert np.array_equal(x, frames()[2][1]["x"].astype(x.dtype))


def test_the_child_imports_the_run_files_modules_without_warp():
    """The child's program loads ``mpmdem.io.writer_process`` without the package's ``__init__`` (which
    imports Warp and the simulation), so that a batch's writers start in a fraction of a second."""
    import mpmdem.io.writer_process as wp

    program = wp.CHILD.replace("main()", "print(sorted(m for m in ('warp', 'mpmdem.sim') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", program, str(Path(wp.__file__).resolve().parents[1])],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"
