"""Tests of the run-file writer/reader (mpmdem.io) and the quick-look plots (mpmdem.plotting).

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


def _load_standalone() -> tuple[types.ModuleType, types.ModuleType]:
    """Import mpmdem.io and mpmdem.plotting without running the package __init__ (and Warp)."""
    pkg_dir = Path(__file__).resolve().parents[1] / "mpmdem"
    saved = {k: sys.modules.pop(k) for k in ("mpmdem", "mpmdem.io", "mpmdem.plotting") if k in sys.modules}
    stub = types.ModuleType("mpmdem")
    stub.__path__ = [str(pkg_dir)]
    sys.modules["mpmdem"] = stub
    try:
        return importlib.import_module("mpmdem.io"), importlib.import_module("mpmdem.plotting")
    finally:
        # Drop the stub so that a later `import mpmdem` elsewhere runs the real package.
        for k in ("mpmdem", "mpmdem.io", "mpmdem.plotting"):
            sys.modules.pop(k, None)
        sys.modules.update(saved)


try:
    from mpmdem.io import FrameWriter, RunFile
    from mpmdem.plotting import plot_run

    IO_SOURCE = Path(sys.modules["mpmdem.io"].__file__).resolve()
except ImportError:  # the package __init__ cannot be imported here (no Warp, or mid-edit)
    _io, _plotting = _load_standalone()
    FrameWriter, RunFile, plot_run = _io.FrameWriter, _io.RunFile, _plotting.plot_run
    IO_SOURCE = Path(_io.__file__).resolve()

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
    names = {a.get("Name") for a in root.iter("Attribute")}
    assert {"C_xx", "C_xy", "C_yx", "C_yy", "x_x", "x_y"} <= names


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


def _resolve_hyperslab(item: ET.Element, h5dir: Path) -> np.ndarray:
    """Read the data an XDMF HyperSlab DataItem points at, with h5py."""
    assert item.get("ItemType") == "HyperSlab"
    sel, src = list(item)
    start, stride, count = np.array(sel.text.split(), dtype=int).reshape(3, -1)
    fname, dset = src.text.strip().split(":")
    with h5py.File(h5dir / fname, "r") as f:
        ds = f[dset]
        assert list(ds.shape) == [int(d) for d in src.get("Dimensions").split()]
        idx = tuple(slice(b, b + c * s, s) for b, s, c in zip(start, stride, count, strict=False))
        out = ds[idx]
    return out.reshape([int(d) for d in item.get("Dimensions").split()])


def test_xdmf_has_one_grid_per_frame(tmp_path):
    """Verify the XDMF sidecar parses, has 3 grids and its hyperslabs select the right data."""
    path = tmp_path / "run.h5"
    write_run(path)
    xdmf = path.with_suffix(".xdmf")
    assert xdmf.exists() and not xdmf.with_name(xdmf.name + ".tmp").exists()
    root = ET.parse(xdmf).getroot()
    collection = root.find("Domain/Grid")
    assert collection.get("GridType") == "Collection" and collection.get("CollectionType") == "Temporal"
    grids = collection.findall("Grid")
    assert len(grids) == 3
    for k, grid in enumerate(grids):
        assert float(grid.find("Time").get("Value")) == pytest.approx(0.1 * k)
        topo = grid.find("Topology")
        assert topo.get("TopologyType") == "Polyvertex" and topo.get("NumberOfElements") == str(N)
        geom = grid.find("Geometry")
        assert geom.get("GeometryType") == "XY"
        expected = make_fields(k)
        np.testing.assert_array_equal(_resolve_hyperslab(geom.find("DataItem"), tmp_path), expected["x"])
        attrs = {a.get("Name"): a for a in grid.findall("Attribute")}
        assert {"v_x", "v_y", "stress_xx", "stress_xy", "stress_yx", "stress_yy", "volume", "mass", "body",
                "F_xx", "F_yy"} <= set(attrs)
        for a in attrs.values():
            assert a.get("AttributeType") == "Scalar" and a.get("Center") == "Node"
        np.testing.assert_array_equal(_resolve_hyperslab(attrs["v_y"][0], tmp_path), expected["v"][:, 1])
        np.testing.assert_array_equal(
            _resolve_hyperslab(attrs["stress_xy"][0], tmp_path), expected["stress"][:, 0, 1]
        )
        np.testing.assert_array_equal(_resolve_hyperslab(attrs["body"][0], tmp_path), expected["body"])


CHILD = textwrap.dedent(
    """
    import importlib.util, os, signal, sys
    import numpy as np

    spec = importlib.util.spec_from_file_location("mpmdem_io_child", {io_source!r})
    io = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(io)
    n = {n}
    w = io.FrameWriter({path!r}, particle_count=n, attrs={{"precision": "f64", "version": "test"}},
                       csv_path={csv!r})
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


@pytest.mark.parametrize("mode", ["exit", "sigkill"])
def test_killed_writer_leaves_readable_file(tmp_path, mode):
    """Verify a writer that dies without closing (os._exit / SIGKILL) leaves its 2 frames readable."""
    path = tmp_path / "run.h5"
    csv = tmp_path / "energy.csv"
    code = CHILD.format(io_source=str(IO_SOURCE), n=N, path=str(path), csv=str(csv), mode=mode)
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
    assert len(csv.read_text().splitlines()) == 3
    assert len(ET.parse(path.with_suffix(".xdmf")).getroot().find("Domain/Grid").findall("Grid")) == 2


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
