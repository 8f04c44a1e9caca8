"""Tests of the run-file writer/reader (mpmdem.io) and the quick-look plots (mpmdem.io.plotting).

Pure numpy/h5py/matplotlib: nothing here needs Warp or a GPU.
"""

from __future__ import annotations

import importlib
import json
import subprocess
import sys
import textwrap
import types
import xml.etree.ElementTree as ET
from pathlib import Path

import h5py
import numpy as np
import pytest
from helpers import ROOT

STANDALONE = ("mpmdem", "mpmdem.io", "mpmdem.io.closing", "mpmdem.io.csv", "mpmdem.io.format", "mpmdem.io.reader",
              "mpmdem.io.writer", "mpmdem.io.xdmf", "mpmdem.io.plotting", "mpmdem.model", "mpmdem.model.outlines")


def _load_standalone() -> tuple[types.ModuleType, types.ModuleType]:
    """Import mpmdem.io and mpmdem.io.plotting without running the package __init__ (and Warp)."""
    pkg_dir = ROOT / "mpmdem"
    saved = {k: sys.modules.pop(k) for k in STANDALONE if k in sys.modules}
    stub = types.ModuleType("mpmdem")
    stub.__path__ = [str(pkg_dir)]
    sys.modules["mpmdem"] = stub
    try:
        return importlib.import_module("mpmdem.io"), importlib.import_module("mpmdem.io.plotting")
    finally:
        # Drop the stub so that a later `import mpmdem` elsewhere runs the real package.
        for k in STANDALONE:
            sys.modules.pop(k, None)
        sys.modules.update(saved)


try:
    from mpmdem.io import FrameWriter, RunFile
    from mpmdem.io.plotting import plot_run

    PKG_DIR = Path(sys.modules["mpmdem.io"].__file__).resolve().parents[1]  # .../mpmdem
except ImportError:  # the package __init__ cannot be imported here (no Warp, or mid-edit)
    _io, _plotting = _load_standalone()
    FrameWriter, RunFile, plot_run = _io.FrameWriter, _io.RunFile, _plotting.plot_run
    PKG_DIR = Path(_io.__file__).resolve().parents[1]

N = 7
DIAG_NAMES = ["energy_kinetic", "energy_strain", "energy_total", "momentum_x", "momentum_y", "dt"]


def make_fields(k: int, n: int = N, dtype=np.float64) -> dict[str, np.ndarray]:
    """Deterministic particle fields for frame k: a small grid of points that moves and deforms."""
    rng = np.random.default_rng(k)
    i = np.arange(n)
    x = np.stack([0.1 * (i % 3), 0.1 * (i // 3)], axis=1) + 0.01 * k
    F = np.tile(np.eye(2), (n, 1, 1)) + 0.01 * rng.standard_normal((n, 2, 2))
    return {
        "x": x.astype(dtype),
        "v": rng.standard_normal((n, 2)).astype(dtype),
        "stress": (1e3 * rng.standard_normal((n, 2, 2))).astype(dtype),
        "volume": np.full(n, 0.01, dtype),
        "mass": np.full(n, 20.0, dtype),
        "F": F.astype(dtype),
        "body": (i % 2).astype(np.int32),
    }


def make_diag(k: int) -> dict[str, float]:
    """Deterministic diagnostics for frame k."""
    return {name: float(j + 0.5 * k) for j, name in enumerate(DIAG_NAMES)}


ATTRS = {
    "version": "0.1.0",
    "device": "cpu",
    "precision": "f64",
    "scene": {"bodies": [{"name": "block", "E": 1e6}], "gravity": [0.0, -9.81]},
    "config": {"dx": 0.05, "cfl": 0.4},
    "end_time": 0.5,
}


def write_run(path: Path, frames: int = 3, *, csv: bool = True, attrs: dict | None = None) -> None:
    """Write a small run of `frames` frames at t = 0.1 k."""
    with FrameWriter(
        path, particle_count=N, attrs=ATTRS if attrs is None else attrs,
        csv_path=path.parent / "energy.csv" if csv else None,
    ) as w:
        for k in range(frames):
            w.write_frame(0.1 * k, make_fields(k), make_diag(k))
        assert w.frame_count == frames


def test_round_trip_three_frames(tmp_path):
    """Verify fields, times, diagnostics and attrs read back equal what was written."""
    path = tmp_path / "run.h5"
    write_run(path)
    with RunFile(path) as rf:
        assert rf.frame_count == 3
        assert rf.particle_count == N
        np.testing.assert_array_equal(rf.times, [0.0, 0.1, 0.2])
        for k in range(3):
            expected = make_fields(k)
            for name, a in expected.items():
                got = rf.field(name, k)
                assert got.dtype == a.dtype, name
                np.testing.assert_array_equal(got, a, err_msg=name)
        np.testing.assert_array_equal(rf.field("x", -1), make_fields(2)["x"])
        diags = rf.diagnostics
        assert set(diags) == set(DIAG_NAMES)
        for name in DIAG_NAMES:
            np.testing.assert_array_equal(diags[name], [make_diag(k)[name] for k in range(3)])
        attrs = rf.attrs
        assert attrs["format"] == "mpmdem-1"
        for key, value in ATTRS.items():
            assert attrs[key] == value, key
        assert "status" not in attrs and rf.status is None
    with h5py.File(path, "r") as f:
        assert json.loads(f.attrs["scene"]) == ATTRS["scene"]
        ds = f["particles/stress"]
        assert ds.shape == (3, N, 2, 2) and ds.maxshape == (None, N, 2, 2) and ds.chunks == (1, N, 2, 2)
        assert f["time"].dtype == np.float64 and f["diagnostics/dt"].dtype == np.float64


def test_diagnostics_are_one_table_and_a_view_of_each_column(tmp_path):
    """A frame's diagnostics are one row of ``/diagnostic_values`` (columns named by its ``names``);
    ``/diagnostics/<name>`` is a virtual dataset of its column, which plain h5py reads as the values."""
    path = tmp_path / "run.h5"
    write_run(path)
    with h5py.File(path, "r") as f:
        table = f["diagnostic_values"]
        names = [n.decode() if isinstance(n, bytes) else n for n in table.attrs["names"]]
        assert names == list(DIAG_NAMES) and table.shape == (3, len(DIAG_NAMES))
        for j, name in enumerate(names):
            view = f["diagnostics"][name]
            assert view.is_virtual and view.shape == (3,)
            np.testing.assert_array_equal(view[...], [make_diag(k)[name] for k in range(3)])
            np.testing.assert_array_equal(table[:, j], view[...])


def test_files_with_a_dataset_per_diagnostic_still_read(tmp_path):
    """Files written before the table (a plain dataset per name, no ``/diagnostic_values``) read the same."""
    path = tmp_path / "run.h5"
    write_run(path)
    with RunFile(path) as rf:
        expected = rf.diagnostics
    with h5py.File(path, "r+") as f:
        values = {name: f["diagnostics"][name][...] for name in f["diagnostics"]}
        del f["diagnostic_values"]
        for name, v in values.items():
            del f["diagnostics"][name]
            f["diagnostics"].create_dataset(name, data=v, maxshape=(None,), chunks=(1024,))
    with RunFile(path) as rf:
        got = rf.diagnostics
    assert list(got) == list(expected)
    for name in expected:
        np.testing.assert_array_equal(got[name], expected[name], err_msg=name)


def test_precision_sets_float_dtype(tmp_path):
    """Verify "float" fields are float32 by default and float64 with precision f64; body stays int32."""
    for precision, dtype in ((None, np.float32), ("f32", np.float32), ("f64", np.float64)):
        path = tmp_path / f"run_{precision}.h5"
        attrs = {} if precision is None else {"precision": precision}
        with FrameWriter(path, particle_count=N, attrs=attrs) as w:
            w.write_frame(0.0, make_fields(0), {"energy_kinetic": 1.0})
        with RunFile(path) as rf:
            assert rf.field("v", 0).dtype == dtype
            assert rf.field("body", 0).dtype == np.int32
            np.testing.assert_allclose(rf.field("v", 0), make_fields(0)["v"], rtol=1e-6)


def test_extra_field_spec(tmp_path):
    """Verify a larger field_specs adds a per-frame dataset (C) that reads back."""
    specs = {"x": ((2,), "float"), "C": ((2, 2), "float")}
    path = tmp_path / "run.h5"
    C = np.arange(N * 4, dtype=np.float32).reshape(N, 2, 2)
    with FrameWriter(path, particle_count=N, attrs={}, field_specs=specs) as w:
        w.write_frame(0.0, {"x": make_fields(0)["x"], "C": C}, {})
    with RunFile(path) as rf:
        assert set(rf.fields) == {"x", "C"}
        np.testing.assert_array_equal(rf.field("C", 0), C)
    root = ET.parse(path.with_suffix(".xdmf")).getroot()
    types_ = {a.get("Name"): a.get("AttributeType") for a in root.iter("Attribute")}
    assert types_ == {"x": "Vector", "C": "Tensor"}


def test_write_frame_rejects_bad_input(tmp_path):
    """Verify wrong shapes, missing fields and changed diagnostic names raise ValueError and write nothing."""
    path = tmp_path / "run.h5"
    with FrameWriter(path, particle_count=N, attrs={}) as w:
        bad = make_fields(0)
        bad["v"] = bad["v"][:-1]
        with pytest.raises(ValueError, match="'v'"):
            w.write_frame(0.0, bad, {})
        missing = make_fields(0)
        del missing["F"]
        with pytest.raises(ValueError, match="missing"):
            w.write_frame(0.0, missing, {})
        w.write_frame(0.0, make_fields(0), {"energy_kinetic": 1.0})
        with pytest.raises(ValueError, match="first frame"):
            w.write_frame(0.1, make_fields(1), {"energy_strain": 1.0})
        assert w.frame_count == 1
    with RunFile(path) as rf:
        assert rf.frame_count == 1


def test_energy_csv_header_and_rows(tmp_path):
    """Verify energy.csv holds the header time,<diagnostics> and one row per frame."""
    path = tmp_path / "run.h5"
    write_run(path)
    lines = (tmp_path / "energy.csv").read_text().splitlines()
    assert lines[0] == ",".join(["time", *DIAG_NAMES])
    assert len(lines) == 4
    for k, line in enumerate(lines[1:]):
        values = [float(v) for v in line.split(",")]
        assert values[0] == pytest.approx(0.1 * k)
        assert values[1:] == [make_diag(k)[n] for n in DIAG_NAMES]


def test_no_csv_when_csv_path_is_none(tmp_path):
    """Verify no energy.csv is written when csv_path is None."""
    write_run(tmp_path / "run.h5", csv=False)
    assert not (tmp_path / "energy.csv").exists()


CHILD = textwrap.dedent(
    """
    import os, signal, sys, types
    import numpy as np

    pkg = types.ModuleType("mpmdem")  # mpmdem.io without the package __init__ (and Warp)
    pkg.__path__ = [{pkg_dir!r}]
    sys.modules["mpmdem"] = pkg
    import mpmdem.io as io
    n = {n}
    w = io.FrameWriter({path!r}, particle_count=n, attrs={{"precision": "f64", "version": "test"}},
                       csv_path={csv!r}, sidecar_interval={interval!r})
    for k in range(2):
        x = np.full((n, 2), float(k))
        w.write_frame(0.5 * k, {{"x": x, "v": x, "stress": np.zeros((n, 2, 2)), "volume": np.ones(n),
                                 "mass": np.ones(n), "F": np.tile(np.eye(2), (n, 1, 1)),
                                 "body": np.zeros(n, np.int32)}},
                      {{"energy_kinetic": float(k), "momentum_x": 2.0 * k}})
    if {mode!r} == "exit":
        os._exit(1)
    os.kill(os.getpid(), signal.SIGKILL)
    """
)


@pytest.mark.parametrize(("mode", "interval", "listed"), [("exit", 0.0, 2), ("sigkill", 0.0, 2), ("sigkill", 1e9, 1)])
def test_killed_writer_leaves_readable_file(tmp_path, mode, interval, listed):
    """Verify a writer that dies without closing (os._exit / SIGKILL) leaves its 2 frames readable, and
    sidecars that list both with sidecar_interval 0 but only the first (written at once) with a long one."""
    path = tmp_path / "run.h5"
    csv = tmp_path / "energy.csv"
    code = CHILD.format(pkg_dir=str(PKG_DIR), n=N, path=str(path), csv=str(csv), mode=mode, interval=interval)
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == (1 if mode == "exit" else -9), proc.stderr
    with RunFile(path) as rf:
        assert rf.frame_count == 2
        np.testing.assert_array_equal(rf.times, [0.0, 0.5])
        np.testing.assert_array_equal(rf.field("x", 1), np.ones((N, 2)))
        np.testing.assert_array_equal(rf.diagnostics["momentum_x"], [0.0, 2.0])
        assert rf.attrs["version"] == "test" and rf.status is None
        text = rf.summary()
        assert "frames:      2" in text and "not set" in text
    with h5py.File(path, "r") as f:  # (the per-name views too, as any HDF5 reader sees them)
        np.testing.assert_array_equal(f["diagnostics/momentum_x"][...], [0.0, 2.0])
    assert len(csv.read_text().splitlines()) == 3
    assert len(ET.parse(path.with_suffix(".xdmf")).getroot().find("Domain/Grid").findall("Grid")) == listed


def test_status_and_summary(tmp_path):
    """Verify set_status is stored and summary() reports the run's metadata, diagnostics and status."""
    path = tmp_path / "run.h5"
    with FrameWriter(path, particle_count=N, attrs=ATTRS) as w:
        for k in range(2):
            w.write_frame(0.1 * k, make_fields(k), make_diag(k))
        w.set_status("blown-up", "non-finite velocity at t = 0.1 s")
    with RunFile(path) as rf:
        assert rf.status == "blown-up"
        assert rf.attrs["status_message"] == "non-finite velocity at t = 0.1 s"
        text = rf.summary()
    for needle in ("run.h5", "mpmdem-1", "0.1.0", "cpu", "f64", "frames:      2", "0 .. 0.1 s", str(N),
                   "stress (2x2", "energy_total", "blown-up: non-finite velocity"):
        assert needle in text, needle


def test_plot_run_writes_pngs(tmp_path):
    """Verify plot_run writes energy.png, momentum.png and the first/middle/last snapshots."""
    path = tmp_path / "run.h5"
    write_run(path, frames=5)
    out = tmp_path / "plots"
    files = plot_run(path, out)
    names = [p.name for p in files]
    assert names == ["energy.png", "momentum.png",
                     "snapshot_0000.png", "snapshot_0002.png", "snapshot_0004.png"]
    for p in files:
        assert p.parent == out and p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    files = plot_run(path, out, field="pressure", frames=[1, -1])
    assert [p.name for p in files][2:] == ["snapshot_0001.png", "snapshot_0004.png"]
    for field in ("J", "body", "stress_xy"):
        assert all(p.exists() for p in plot_run(path, tmp_path / field, field=field, frames=[0]))


def test_plot_run_unknown_field_raises(tmp_path):
    """Verify an unknown snapshot field raises ValueError naming the allowed fields."""
    path = tmp_path / "run.h5"
    write_run(path, frames=1)
    with pytest.raises(ValueError, match="speed.*pressure.*J"):
        plot_run(path, tmp_path / "plots", field="temperature")


# ---------------------------------------------------------------------------------------- rigid bodies

BODY_DIAG_NAMES = ["energy_kinetic", "energy_gravity", "energy_contact", "energy_total", "work_contact_damping",
                   "work_contact_friction", "momentum_x", "momentum_y", "momentum_angular"]
BODY_FIELD_NAMES = ["x", "angle", "v", "omega", "force", "torque"]


def make_geometry() -> dict:
    """Five spheropolygons: a disk, a stadium, a rounded square, a fixed ground box and a kinematic triangle."""
    vertices = np.array([
        [0.0, 0.0],                                              # disk: one vertex
        [-0.05, 0.0], [0.05, 0.0],                               # stadium: two vertices
        [-0.04, -0.04], [0.04, -0.04], [0.04, 0.04], [-0.04, 0.04],  # rounded square
        [-1.0, -0.05], [1.0, -0.05], [1.0, 0.05], [-1.0, 0.05],  # ground box
        [0.0, 0.0], [0.1, 0.0], [0.0, 0.1],                      # triangle, sharp corners
    ])
    return {
        "vertex_start": np.array([0, 1, 3, 7, 11]),
        "vertex_count": np.array([1, 2, 4, 4, 3]),
        "vertices": vertices,
        "radius": np.array([0.05, 0.02, 0.01, 0.0, 0.0]),
        "motion": np.array([0, 0, 0, 1, 2]),
        "mass": np.array([7.8, 3.1, 5.0, np.inf, 1.0]),
        "name": ["disk", "stadium", "Würfel", "ground", "wedge"],
    }


M = 5


def make_body_fields(k: int, m: int = M, dtype=np.float64) -> dict[str, np.ndarray]:
    """Deterministic body fields for frame k: bodies spread along x, falling and turning."""
    rng = np.random.default_rng(100 + k)
    i = np.arange(m)
    x = np.stack([0.3 * i - 0.6, 0.2 + 0.0 * i - 0.01 * k], axis=1)
    x[3] = [0.0, -0.1]  # the ground
    return {
        "x": x.astype(dtype),
        "angle": (0.1 * k * (i + 1)).astype(dtype),
        "v": rng.standard_normal((m, 2)).astype(dtype),
        "omega": rng.standard_normal(m).astype(dtype),
        "force": (10.0 * rng.standard_normal((m, 2))).astype(dtype),
        "torque": rng.standard_normal(m).astype(dtype),
    }


def make_body_diag(k: int) -> dict[str, float]:
    """Deterministic DEM diagnostics for frame k."""
    return {name: float(j - 0.25 * k) for j, name in enumerate(BODY_DIAG_NAMES)}


def write_body_run(path: Path, frames: int = 3, *, particles: int = 0, csv: bool = True) -> None:
    """Write a run of M bodies (and `particles` particles) of `frames` frames at t = 0.1 k."""
    with FrameWriter(
        path, particle_count=particles, attrs=ATTRS, body_count=M, body_geometry=make_geometry(),
        csv_path=path.parent / "energy.csv" if csv else None,
    ) as w:
        for k in range(frames):
            fields = make_fields(k, particles) if particles else {}
            w.write_frame(0.1 * k, fields, make_body_diag(k), body_fields=make_body_fields(k))
        assert w.frame_count == frames


def assert_geometry_equal(got: dict, expected: dict) -> None:
    assert set(got) == set(expected)
    assert got["name"] == expected["name"] and all(type(s) is str for s in got["name"])
    for key, dtype in (("vertex_start", np.int32), ("vertex_count", np.int32), ("vertices", np.float64),
                       ("radius", np.float64), ("motion", np.int32), ("mass", np.float64)):
        assert got[key].dtype == dtype, key
        np.testing.assert_array_equal(got[key], expected[key], err_msg=key)


def test_bodies_only_round_trip(tmp_path):
    """Verify a bodies-only run reads back: no particles, geometry, per-frame body fields, diagnostics, summary."""
    path = tmp_path / "run.h5"
    write_body_run(path)
    with RunFile(path) as rf:
        assert rf.frame_count == 3 and rf.particle_count == 0 and rf.fields == []
        assert rf.body_count == M and rf.body_fields == BODY_FIELD_NAMES
        np.testing.assert_array_equal(rf.times, [0.0, 0.1, 0.2])
        for k in range(3):
            for name, a in make_body_fields(k).items():
                got = rf.body_field(name, k)
                assert got.dtype == np.float64 and got.shape == a.shape, name
                np.testing.assert_array_equal(got, a, err_msg=name)
        np.testing.assert_array_equal(rf.body_field("angle", -1), make_body_fields(2)["angle"])
        assert_geometry_equal(rf.body_geometry(), make_geometry())
        for name in BODY_DIAG_NAMES:
            np.testing.assert_array_equal(rf.diagnostics[name], [make_body_diag(k)[name] for k in range(3)])
        with pytest.raises(KeyError):
            rf.field("x", 0)
        with pytest.raises(KeyError, match="omega.*torque"):
            rf.body_field("spin", 0)
        with pytest.raises(IndexError):
            rf.body_field("x", 3)
        text = rf.summary()
        assert "particles:   0" in text and "bodies:      5 (3 free, 1 fixed, 1 kinematic)" in text
        assert "angle (scalar, float64)" in text and "work_contact_friction" in text
        assert "bodies=5" in repr(rf)
    with h5py.File(path, "r") as f:
        assert "particles" not in f
        ds = f["bodies/force"]
        assert ds.shape == (3, M, 2) and ds.maxshape == (None, M, 2) and ds.chunks == (1, M, 2)
        assert h5py.check_string_dtype(f["bodies/geometry/name"].dtype).encoding == "utf-8"
    assert (tmp_path / "energy.csv").read_text().splitlines()[0] == ",".join(["time", *BODY_DIAG_NAMES])


def test_particle_only_file_has_no_bodies(tmp_path):
    """Verify a file without bodies (as written before bodies existed) reports body_count 0 and empty geometry."""
    path = tmp_path / "run.h5"
    write_run(path, frames=1, csv=False)
    with RunFile(path) as rf:
        assert rf.body_count == 0 and rf.body_fields == []
        geo = rf.body_geometry()
        assert geo["name"] == [] and geo["vertices"].shape == (0, 2) and len(geo["radius"]) == 0
        assert "bodies:      0" in rf.summary()
        with pytest.raises(KeyError):
            rf.body_field("x", 0)
    with h5py.File(path, "r") as f:
        assert "bodies" not in f


def test_mixed_round_trip(tmp_path):
    """Verify particles and bodies in one run read back."""
    path = tmp_path / "run.h5"
    write_body_run(path, particles=N, csv=False)
    with RunFile(path) as rf:
        assert rf.frame_count == 3 and rf.particle_count == N and rf.body_count == M
        for k in range(3):
            np.testing.assert_array_equal(rf.field("stress", k), make_fields(k)["stress"])
            np.testing.assert_array_equal(rf.body_field("v", k), make_body_fields(k)["v"])
        assert_geometry_equal(rf.body_geometry(), make_geometry())
        assert f"particles:   {N}" in rf.summary() and "bodies:      5" in rf.summary()


def test_body_fields_validation(tmp_path):
    """Verify wrong body field shapes/names and bad geometry raise ValueError and write nothing."""
    path = tmp_path / "run.h5"
    with FrameWriter(path, particle_count=0, attrs={}, body_count=M, body_geometry=make_geometry()) as w:
        bad = make_body_fields(0)
        bad["v"] = bad["v"][:, :1]
        with pytest.raises(ValueError, match=r"'v'.*\(5, 2\)"):
            w.write_frame(0.0, {}, {}, body_fields=bad)
        bad = make_body_fields(0)
        bad["omega"] = bad["omega"][:-1]
        with pytest.raises(ValueError, match="'omega'"):
            w.write_frame(0.0, {}, {}, body_fields=bad)
        missing = make_body_fields(0)
        del missing["torque"]
        with pytest.raises(ValueError, match=r"missing \['torque'\]"):
            w.write_frame(0.0, {}, {}, body_fields=missing)
        unknown = {**make_body_fields(0), "spin": np.zeros(M)}
        with pytest.raises(ValueError, match=r"unknown \['spin'\]"):
            w.write_frame(0.0, {}, {}, body_fields=unknown)
        with pytest.raises(ValueError, match="missing"):
            w.write_frame(0.0, {}, {})
        with pytest.raises(ValueError, match="no particles"):
            w.write_frame(0.0, make_fields(0), {}, body_fields=make_body_fields(0))
        assert w.frame_count == 0
        w.write_frame(0.0, None, {"energy_total": 1.0}, body_fields=make_body_fields(0))
    with RunFile(path) as rf:
        assert rf.frame_count == 1 and rf.body_count == M
    # Particle runs without bodies refuse body data (but accept none or empty).
    with FrameWriter(tmp_path / "p.h5", particle_count=N, attrs={}) as w:
        with pytest.raises(ValueError, match="no bodies"):
            w.write_frame(0.0, make_fields(0), {}, body_fields=make_body_fields(0))
        w.write_frame(0.0, make_fields(0), {}, body_fields={})
    specs = {"x": ((2,), "float")}
    with FrameWriter(tmp_path / "s.h5", particle_count=0, attrs={}, body_count=M, body_field_specs=specs,
                     body_geometry=make_geometry()) as w:
        w.write_frame(0.0, {}, {}, body_fields={"x": np.zeros((M, 2))})
    with RunFile(tmp_path / "s.h5") as rf:
        assert rf.body_fields == ["x"]


@pytest.mark.parametrize(
    ("change", "match"),
    [
        (None, "body_geometry is required"),
        ({"vertex_count": np.array([1, 2, 4, 4, 4])}, "inside vertices"),
        ({"vertex_count": np.array([0, 2, 4, 4, 3])}, "non-empty"),
        ({"radius": np.array([0.05, -0.02, 0.01, 0.0, 0.0])}, "radius"),
        ({"motion": np.array([0, 0, 0, 3, 2])}, "motion"),
        ({"name": ["a", "b"]}, "name"),
        ({"mass": np.ones(4)}, "'mass'"),
        ({"vertices": np.zeros((14, 3))}, "'vertices'"),
    ],
)
def test_bad_body_geometry_raises(tmp_path, change, match):
    """Verify missing or inconsistent body geometry raises ValueError before any file is written."""
    geometry = None if change is None else {**make_geometry(), **change}
    path = tmp_path / "run.h5"
    with pytest.raises(ValueError, match=match):
        FrameWriter(path, particle_count=0, attrs={}, body_count=M, body_geometry=geometry)
    assert not path.exists()


def test_reserved_and_negative_body_specs(tmp_path):
    """Verify a body field named "geometry" and a negative body_count are refused."""
    with pytest.raises(ValueError, match="geometry"):
        FrameWriter(tmp_path / "a.h5", particle_count=0, attrs={}, body_count=M, body_geometry=make_geometry(),
                    body_field_specs={"geometry": ((), "float")})
    with pytest.raises(ValueError, match="body_count"):
        FrameWriter(tmp_path / "b.h5", particle_count=0, attrs={}, body_count=-1)


CHILD_BODIES = textwrap.dedent(
    """
    import os, signal, sys, types
    import numpy as np

    pkg = types.ModuleType("mpmdem")  # mpmdem.io without the package __init__ (and Warp)
    pkg.__path__ = [{pkg_dir!r}]
    sys.modules["mpmdem"] = pkg
    import mpmdem.io as io
    n, m = {n}, 2
    geometry = {{"vertex_start": [0, 1], "vertex_count": [1, 2], "vertices": [[0, 0], [-0.1, 0], [0.1, 0]],
                 "radius": [0.1, 0.05], "motion": [0, 1], "mass": [1.0, 2.0], "name": ["ball", "bar"]}}
    w = io.FrameWriter({path!r}, particle_count=n, attrs={{"precision": "f64"}}, body_count=m,
                       body_geometry=geometry, sidecar_interval=0)
    for k in range(2):
        x = np.full((n, 2), float(k))
        fields = {{"x": x, "v": x, "stress": np.zeros((n, 2, 2)), "volume": np.ones(n), "mass": np.ones(n),
                   "F": np.tile(np.eye(2), (n, 1, 1)), "body": np.zeros(n, np.int32)}} if n else {{}}
        body = {{"x": np.full((m, 2), 1.0 + k), "angle": np.full(m, 0.5 * k), "v": np.zeros((m, 2)),
                 "omega": np.full(m, 3.0), "force": np.zeros((m, 2)), "torque": np.zeros(m)}}
        w.write_frame(0.5 * k, fields, {{"energy_kinetic": float(k)}}, body_fields=body)
    # A third frame interrupted after some body data: /time is not grown, so it must stay invisible.
    w._body_datasets["x"].resize(3, axis=0)
    w._body_datasets["x"][2] = 99.0
    w._file.flush()
    os.kill(os.getpid(), signal.SIGKILL)
    """
)


@pytest.mark.parametrize("n", [0, N])
def test_killed_body_writer_leaves_readable_frames(tmp_path, n):
    """Verify a SIGKILLed writer of bodies (alone or with particles) leaves its 2 complete frames readable."""
    path = tmp_path / "run.h5"
    code = CHILD_BODIES.format(pkg_dir=str(PKG_DIR), n=n, path=str(path))
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == -9, proc.stderr
    with RunFile(path) as rf:
        assert rf.frame_count == 2 and rf.body_count == 2 and rf.particle_count == n
        np.testing.assert_array_equal(rf.body_field("x", -1), np.full((2, 2), 2.0))
        np.testing.assert_array_equal(rf.body_field("angle", 1), [0.5, 0.5])
        with pytest.raises(IndexError):
            rf.body_field("x", 2)
        assert rf.body_geometry()["name"] == ["ball", "bar"]
        if n:
            np.testing.assert_array_equal(rf.field("x", 1), np.ones((n, 2)))
        assert rf.status is None
    assert path.with_suffix(".xdmf").exists() == bool(n)
    bodies = ET.parse(tmp_path / "run_bodies.xdmf").getroot().find("Domain/Grid")
    assert bodies.get("Name") == "bodies" and len(bodies.findall("Grid")) == 2


def test_body_outlines_areas_and_pose():
    """Verify the dilated outlines: disk, stadium, rounded square and bare polygon areas; rotation and shift."""
    geometry = make_geometry()
    x = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [0.0, -1.0], [5.0, 5.0]])
    angle = np.array([0.0, np.pi / 2, 0.3, 0.0, np.pi])
    geoms = _plotting_module().body_outlines(geometry, x, angle, quad_segs=64)
    a = geometry["radius"]
    areas = [g.area for g in geoms]
    assert areas[0] == pytest.approx(np.pi * a[0] ** 2, rel=1e-3)
    assert areas[1] == pytest.approx(0.1 * 2 * a[1] + np.pi * a[1] ** 2, rel=1e-3)
    assert areas[2] == pytest.approx(0.08**2 + 4 * 0.08 * a[2] + np.pi * a[2] ** 2, rel=1e-3)
    assert areas[3] == pytest.approx(2.0 * 0.1) and areas[4] == pytest.approx(0.005)
    # The stadium, turned by 90 degrees, stands upright at x = 1.
    minx, miny, maxx, maxy = geoms[1].bounds
    assert (minx, maxx) == pytest.approx((1.0 - a[1], 1.0 + a[1]), abs=1e-9)
    assert (miny, maxy) == pytest.approx((-0.05 - a[1], 0.05 + a[1]), abs=1e-6)
    # The triangle turned by pi about its body origin, then moved to (5, 5).
    assert geoms[4].bounds == pytest.approx((4.9, 4.9, 5.0, 5.0), abs=1e-12)
    # A body with a non-finite pose is left out (empty), the others are unaffected.
    x[0] = np.nan
    geoms = _plotting_module().body_outlines(geometry, x, angle)
    assert geoms[0].is_empty and not geoms[1].is_empty


def _plotting_module() -> types.ModuleType:
    return sys.modules[plot_run.__module__]


PNG = b"\x89PNG\r\n\x1a\n"


def test_plot_run_bodies_only(tmp_path):
    """Verify plot_run on a bodies-only run (energy_*, work_*, momentum_angular diagnostics) writes all PNGs."""
    path = tmp_path / "run.h5"
    write_body_run(path, frames=3, csv=False)
    out = tmp_path / "plots"
    files = plot_run(path, out)
    assert [p.name for p in files] == ["energy.png", "momentum.png",
                                       "snapshot_0000.png", "snapshot_0001.png", "snapshot_0002.png"]
    assert all(p.read_bytes()[:8] == PNG for p in files)
    for field in ("omega", "force", "pressure"):  # a body quantity, another one, a particle-only one
        assert all(p.exists() for p in plot_run(path, tmp_path / field, field=field, frames=[-1]))


def test_plot_run_mixed_and_blown_up(tmp_path):
    """Verify plot_run on a particles + bodies run, and on one whose last frame holds non-finite bodies."""
    path = tmp_path / "run.h5"
    write_body_run(path, frames=2, particles=N, csv=False)
    for field in ("speed", "pressure", "torque"):
        files = plot_run(path, tmp_path / field, field=field)
        assert [p.name for p in files] == ["energy.png", "momentum.png", "snapshot_0000.png", "snapshot_0001.png"]
        assert all(p.read_bytes()[:8] == PNG for p in files)
    blown = tmp_path / "blown.h5"
    with FrameWriter(blown, particle_count=0, attrs={}, body_count=M, body_geometry=make_geometry()) as w:
        w.write_frame(0.0, {}, {}, body_fields=make_body_fields(0))
        fields = make_body_fields(1)
        fields["x"][1] = np.nan
        fields["v"][2] = np.inf
        w.write_frame(0.1, {}, {}, body_fields=fields)
    files = plot_run(blown, tmp_path / "blown", frames=[1])
    assert files[-1].name == "snapshot_0001.png" and files[-1].read_bytes()[:8] == PNG
