"""Tests of the XDMF 3 sidecars (mpmdem.io.xdmf): read by meshio, checked against the rules ParaView's
XDMF readers apply and, where ``pvbatch`` is installed, opened by ParaView itself.

No Warp: run files are written by FrameWriter with made-up fields (those of tests/io/test_io.py).
"""

from __future__ import annotations

import shutil
import subprocess
import textwrap
import xml.etree.ElementTree as ET
from pathlib import Path

import h5py
import numpy as np
import pytest
from test_io import M, N, make_body_fields, make_fields, make_geometry, write_body_run, write_run

meshio = pytest.importorskip("meshio")

TIMES = [0.0, 0.1, 0.2]
#: Components ParaView's readers give each AttributeType.
COMPONENTS = {"Scalar": 1, "Vector": 3, "Tensor": 9}


def padded(a: np.ndarray) -> np.ndarray:
    """A (n, 2) field as the sidecar's (n, 3) Vector, or a (n, 2, 2) one as its (n, 9) Tensor."""
    n = len(a)
    if a.ndim == 2:
        return np.column_stack([a, np.zeros(n)])
    out = np.zeros((n, 3, 3))
    out[:, :2, :2] = a
    return out.reshape(n, 9)


def read_item(item: ET.Element, folder: Path) -> np.ndarray:
    """The HDF5 dataset a DataItem names, checked to be a whole dataset of the item's Dimensions."""
    assert item.get("Format") == "HDF" and item.get("ItemType") in (None, "Uniform")
    fname, dset = item.text.strip().split(":")
    with h5py.File(folder / fname, "r") as f:
        data = f[dset][()]
    assert list(data.shape) == [int(d) for d in item.get("Dimensions").split()], dset
    kind = {"Float": "f", "Int": "i", "UInt": "u"}[item.get("NumberType")]
    assert data.dtype.kind == kind and data.dtype.itemsize == int(item.get("Precision")), dset
    return data


def check_paraview_rules(xdmf: Path) -> list[dict]:
    """Check an XDMF file as ParaView's Xdmf3 and legacy readers read it; returns each frame's arrays.

    XDMF 3.0, one temporal collection of uniform grids with increasing times, no HyperSlab (the
    Xdmf3 reader's crash), a topology with NumberOfElements, NodesPerElement and a connectivity of
    that size pointing inside the geometry, XYZ geometry, and attributes whose size is their
    centre's count times their type's components.
    """
    root = ET.parse(xdmf).getroot()
    assert root.tag == "Xdmf" and root.get("Version") == "3.0"
    assert not [e for e in root.iter("DataItem") if e.get("ItemType") == "HyperSlab"]
    (domain,) = list(root)
    (collection,) = list(domain)
    assert collection.get("GridType") == "Collection" and collection.get("CollectionType") == "Temporal"
    frames, last = [], -np.inf
    for grid in collection:
        assert grid.tag == "Grid" and grid.get("GridType") == "Uniform"
        t = float(grid.find("Time").get("Value"))
        assert t > last
        last = t
        topo, geom = grid.find("Topology"), grid.find("Geometry")
        cells, per_cell = int(topo.get("NumberOfElements")), int(topo.get("NodesPerElement"))
        conn = read_item(topo.find("DataItem"), xdmf.parent)
        assert conn.shape == (cells, per_cell)
        assert geom.get("GeometryType") == "XYZ"
        points = read_item(geom.find("DataItem"), xdmf.parent)
        assert points.ndim == 2 and points.shape[1] == 3
        assert conn.min() >= 0 and conn.max() < len(points)
        arrays = {"time": t, "points": points, "connectivity": conn}
        for attr in grid.findall("Attribute"):
            data = read_item(attr.find("DataItem"), xdmf.parent)
            count = len(points) if attr.get("Center") == "Node" else cells
            assert data.size == count * COMPONENTS[attr.get("AttributeType")], attr.get("Name")
            arrays[attr.get("Name")] = data
        frames.append(arrays)
    return frames


def test_particles_sidecar_read_by_meshio(tmp_path):
    """Verify meshio's TimeSeriesReader reads run.xdmf: points, every frame's fields and the frame times."""
    path = tmp_path / "run.h5"
    write_run(path)
    with meshio.xdmf.TimeSeriesReader(path.with_suffix(".xdmf")) as reader:
        points, cells = reader.read_points_cells()
        np.testing.assert_array_equal(points, padded(make_fields(0)["x"]))
        assert [c.type for c in cells] == ["vertex"] and cells[0].data.shape == (N, 1)
        assert reader.num_steps == 3
        for k in range(3):
            t, point_data, cell_data = reader.read_data(k)
            expected = make_fields(k)
            assert t == pytest.approx(TIMES[k]) and cell_data == {}
            assert set(point_data) == set(expected)
            for name in ("x", "v", "stress", "F"):
                np.testing.assert_array_equal(point_data[name], padded(expected[name]), err_msg=name)
            for name in ("volume", "mass", "body"):
                np.testing.assert_array_equal(point_data[name], expected[name], err_msg=name)


def test_bodies_sidecar_read_by_meshio(tmp_path):
    """Verify run_bodies.xdmf: one closed polyline per body on its dilated outline, per-body data per frame."""
    path = tmp_path / "run.h5"
    write_body_run(path, particles=N, csv=False)
    geometry = make_geometry()
    with meshio.xdmf.TimeSeriesReader(tmp_path / "run_bodies.xdmf") as reader:
        points, cells = reader.read_points_cells()
        (block,) = cells
        assert block.type == "line" and block.data.shape[0] == M
        np.testing.assert_array_equal(block.data[:, 0], block.data[:, -1])  # closed
        for k in range(3):
            t, point_data, cell_data = reader.read_data(k)
            expected = make_body_fields(k)
            assert t == pytest.approx(TIMES[k]) and point_data == {}
            np.testing.assert_array_equal(cell_data["omega"][0], expected["omega"])
            np.testing.assert_array_equal(cell_data["force"][0], padded(expected["force"]))
            np.testing.assert_array_equal(cell_data["radius"][0], geometry["radius"])
            np.testing.assert_array_equal(cell_data["motion"][0], geometry["motion"])
    frames = check_paraview_rules(tmp_path / "run_bodies.xdmf")
    for k, frame in enumerate(frames):
        x = make_body_fields(k)["x"]
        ring = frame["points"][frame["connectivity"]]  # (M, K + 1, 3)
        assert np.all(ring[..., 2] == 0)
        # The disk (body 0): its circle's 32-gon (8 segments a quarter), with points added on its chords.
        r = np.linalg.norm(ring[0, :, :2] - x[0], axis=1)
        assert np.all(r <= 0.05 * (1 + 1e-12)) and np.all(r >= 0.05 * np.cos(np.pi / 32) * (1 - 1e-12))
        assert np.sum(np.isclose(r, 0.05, rtol=1e-12)) == 33  # 32 corners, the first twice
        # The triangle (sharp corners) keeps its three corners, rotated and moved with the body.
        angle = make_body_fields(k)["angle"][4]
        rot = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
        corners = x[4] + geometry["vertices"][11:14] @ rot.T
        for c in corners:
            assert np.min(np.linalg.norm(ring[4, :, :2] - c, axis=1)) < 1e-12


def test_sidecars_follow_paraview_rules(tmp_path):
    """Verify both sidecars meet ParaView's reading rules and list every flushed frame and no other."""
    path = tmp_path / "run.h5"
    write_body_run(path, particles=N, csv=False)
    particles = check_paraview_rules(path.with_suffix(".xdmf"))
    assert [f["time"] for f in particles] == pytest.approx(TIMES)
    for k, frame in enumerate(particles):
        np.testing.assert_array_equal(frame["points"], padded(make_fields(k)["x"]))
        np.testing.assert_array_equal(frame["connectivity"][:, 0], np.arange(N))
    assert len(check_paraview_rules(tmp_path / "run_bodies.xdmf")) == 3
    assert not list(tmp_path.glob("*.tmp"))


def test_sidecars_of_a_bodies_only_run_and_a_rerun(tmp_path):
    """Verify a bodies-only run writes run_bodies.xdmf and no run.xdmf, also over an older run of the name."""
    path = tmp_path / "run.h5"
    write_run(path)
    write_body_run(path, frames=2, csv=False)
    assert not path.with_suffix(".xdmf").exists()
    assert len(check_paraview_rules(tmp_path / "run_bodies.xdmf")) == 2


def test_other_field_shapes(tmp_path):
    """Verify a (3,) field is a Vector, a (3, 3) one a Tensor and a (4,) one four Scalars, as meshio reads them."""
    specs = {"x": ((2,), "float"), "w": ((3,), "float"), "T": ((3, 3), "float"), "q": ((4,), "float")}
    path = tmp_path / "run.h5"
    rng = np.random.default_rng(0)
    fields = {"x": rng.random((N, 2)), "w": rng.random((N, 3)), "T": rng.random((N, 3, 3)), "q": rng.random((N, 4))}
    from mpmdem.io import FrameWriter

    with FrameWriter(path, particle_count=N, attrs={"precision": "f64"}, field_specs=specs) as w:
        w.write_frame(0.5, fields, {})
    (frame,) = check_paraview_rules(path.with_suffix(".xdmf"))
    np.testing.assert_array_equal(frame["w"], fields["w"])
    np.testing.assert_array_equal(frame["T"], fields["T"].reshape(N, 9))
    for i in range(4):
        np.testing.assert_array_equal(frame[f"q_{i}"], fields["q"][:, i])


PVBATCH = textwrap.dedent(
    """
    import sys
    from paraview import servermanager as sm
    from paraview.simple import OpenDataFile, XDMFReader, Xdmf3ReaderS, Xdmf3ReaderT
    name = sys.argv[1]
    for make in (lambda: OpenDataFile(name), lambda: Xdmf3ReaderT(FileName=[name]),
                 lambda: Xdmf3ReaderS(FileName=[name]), lambda: XDMFReader(FileNames=name)):
        r = make()
        r.UpdatePipelineInformation()
        for t in r.TimestepValues:
            r.UpdatePipeline(t)
            d = sm.Fetch(r)
            print(r.GetXMLName(), t, d.GetNumberOfPoints(), d.GetNumberOfCells(),
                  d.GetPointData().GetNumberOfArrays() + d.GetCellData().GetNumberOfArrays())
    """
)


@pytest.mark.skipif(shutil.which("pvbatch") is None, reason="ParaView's pvbatch is not installed")
def test_paraview_opens_both_sidecars(tmp_path):
    """Verify ParaView's default (Xdmf3ReaderS), Xdmf3ReaderT and legacy XDMF readers read every frame."""
    path = tmp_path / "run.h5"
    write_body_run(path, particles=N, csv=False)
    script = tmp_path / "open.py"
    script.write_text(PVBATCH)
    for xdmf, points, cells, arrays in (("run.xdmf", N, N, 7), ("run_bodies.xdmf", None, M, 9)):
        proc = subprocess.run(["pvbatch", str(script), str(tmp_path / xdmf)], capture_output=True, text=True,
                              timeout=300)
        assert proc.returncode == 0, proc.stderr[-2000:]
        rows = [line.split() for line in proc.stdout.splitlines() if line.startswith("Xdmf")]
        assert [r[0] for r in rows] == ["Xdmf3ReaderS"] * 3 + ["Xdmf3ReaderT"] * 3 + ["Xdmf3ReaderS"] * 3 + [
            "XdmfReader"] * 3
        assert [float(r[1]) for r in rows] == pytest.approx(TIMES * 4)
        for r in rows:
            assert (points is None or int(r[2]) == points) and int(r[3]) == cells and int(r[4]) == arrays


def listed(xdmf: Path) -> int:
    """The number of frames a sidecar lists (0 when it does not exist)."""
    return len(ET.parse(xdmf).getroot().find("Domain/Grid").findall("Grid")) if xdmf.exists() else 0


def body_writer(path: Path, interval: float):
    """A FrameWriter of N particles and M bodies with the given sidecar_interval [s]."""
    from mpmdem.io import FrameWriter

    return FrameWriter(path, particle_count=N, attrs={}, body_count=M, body_geometry=make_geometry(),
                       sidecar_interval=interval)


def write_frame(w, k: int) -> None:
    """Frame k of the made-up particles and bodies at t = 0.1 k."""
    w.write_frame(0.1 * k, make_fields(k), {"e": float(k)}, body_fields=make_body_fields(k))


def test_sidecars_with_interval_zero_are_current_after_every_frame(tmp_path):
    """Verify sidecar_interval=0 rewrites both sidecars after each frame: they list every frame written."""
    path = tmp_path / "run.h5"
    w = body_writer(path, 0.0)
    for k in range(3):
        write_frame(w, k)
        assert listed(path.with_suffix(".xdmf")) == listed(tmp_path / "run_bodies.xdmf") == k + 1
    w.close()


def test_long_sidecar_interval_rewrites_at_first_frame_status_and_close(tmp_path):
    """Verify a sidecar_interval longer than the test keeps the sidecars at the first frame (a rewrite
    would list every frame), and set_status and close bring them up to every frame, valid for ParaView."""
    path = tmp_path / "run.h5"
    w = body_writer(path, 1e9)
    for k in range(3):
        write_frame(w, k)
        assert listed(path.with_suffix(".xdmf")) == listed(tmp_path / "run_bodies.xdmf") == 1
    w.set_status("interrupted")
    assert listed(path.with_suffix(".xdmf")) == listed(tmp_path / "run_bodies.xdmf") == 3
    write_frame(w, 3)
    assert listed(path.with_suffix(".xdmf")) == 3
    w.close()
    particles = check_paraview_rules(path.with_suffix(".xdmf"))
    assert [f["time"] for f in particles] == pytest.approx([0.0, 0.1, 0.2, 0.3])
    assert len(check_paraview_rules(tmp_path / "run_bodies.xdmf")) == 4
    assert not list(tmp_path.glob("*.tmp"))


def test_sidecar_interval_counts_wall_time_since_the_last_rewrite(tmp_path, monkeypatch):
    """Verify, on a made-up clock, that a frame rewrites the sidecars once sidecar_interval seconds passed
    since their last rewrite: interval 1 s, frames at clock 0, 0.5, 1.2, 1.7, 2.2 s → rewrites after
    frames 0, 2 and 4 (1.2 - 0 >= 1, 2.2 - 1.2 >= 1)."""
    import mpmdem.io.writer as writer_module

    clock = iter([0.0, 0.0, 0.5, 1.2, 1.2, 1.7, 2.2, 2.2])  # (a rewrite reads the clock again)
    monkeypatch.setattr(writer_module, "_clock", lambda: next(clock))
    path = tmp_path / "run.h5"
    w = body_writer(path, 1.0)
    seen = []
    for k in range(5):
        write_frame(w, k)
        seen.append(listed(path.with_suffix(".xdmf")))
    assert seen == [1, 1, 3, 3, 5]
    w.close()


@pytest.mark.parametrize("bad", [-1.0, float("nan"), float("inf"), "soon"])
def test_bad_sidecar_interval_is_an_input_error(tmp_path, bad):
    """Verify a negative, non-finite or non-numeric sidecar_interval is an InputError naming it, and no file
    is created."""
    from mpmdem.errors import InputError

    with pytest.raises(InputError, match="sidecar_interval"):
        body_writer(tmp_path / "run.h5", bad)
    assert not list(tmp_path.iterdir())


def test_closing_a_writer_without_frames_writes_no_sidecar(tmp_path):
    """Verify a writer closed before any frame leaves no sidecar (there is no frame to list)."""
    path = tmp_path / "run.h5"
    body_writer(path, 1.0).close()
    assert not path.with_suffix(".xdmf").exists() and not (tmp_path / "run_bodies.xdmf").exists()


def test_outlines_are_placed_from_the_stored_body_fields(tmp_path):
    """Each frame's /xdmf/bodies outline is the body-frame ring placed at the x and angle the file
    holds (f32 here, from f64 input): the writer hands the stored values, not the caller's, to
    ``XdmfSidecars.add_frame``, which places them as reading them back would."""
    from mpmdem.io.writer import FrameWriter
    from mpmdem.model.outlines import outline_rings, place_rings

    path = tmp_path / "run.h5"
    geometry = make_geometry()
    with FrameWriter(path, particle_count=0, attrs={"precision": "f32"}, body_count=M, body_geometry=geometry) as w:
        for k in range(3):
            w.write_frame(0.1 * k, {}, {"dt": 1e-3}, body_fields=make_body_fields(k))
    rings = outline_rings(geometry)
    with h5py.File(path, "r") as f:
        for k in range(3):
            x, angle = f["bodies/x"][k], f["bodies/angle"][k]
            assert x.dtype == np.float32 and not np.array_equal(x, make_body_fields(k)["x"])
            ring = place_rings(rings, x, angle).reshape(-1, 2)
            np.testing.assert_array_equal(f[f"xdmf/bodies/frame_{k:06d}/outline"][:, :2], ring)


def test_body_frames_are_copies_the_particles_views(tmp_path):
    """The outlined bodies' per-frame datasets are plain copies of their stored fields (a Vector padded
    with 0, as a view would read), the particles' frames virtual views of theirs."""
    path = tmp_path / "run.h5"
    write_body_run(path, particles=N, csv=False)
    with h5py.File(path, "r") as f:
        for k in range(3):
            frame = f[f"xdmf/bodies/frame_{k:06d}"]
            for name in ("x", "v", "force"):
                assert not frame[name].is_virtual
                np.testing.assert_array_equal(frame[name][...], padded(f["bodies"][name][k]), err_msg=name)
            for name in ("angle", "omega", "torque"):
                np.testing.assert_array_equal(frame[name][...], f["bodies"][name][k], err_msg=name)
            assert f[f"xdmf/particles/frame_{k:06d}/x"].is_virtual
