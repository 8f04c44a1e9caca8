"""Tests of mpmdem.model.shapes: shape constructors, membership and point seeding."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import shapely

from mpmdem.model.shapes import SeededPoints, disk, from_file, polygon, rectangle, seed_points


@pytest.mark.parametrize("n", [1, 2, 3, 4, 8])
@pytest.mark.parametrize("origin", [(0.0, 0.0), (-0.35, 0.15)])
def test_rectangle_aligned_volume_exact(n, origin):
    """Verify a cell-aligned rectangle's seeded volume equals its area and the point count is exact."""
    h = 0.05
    ox, oy = origin
    shape = rectangle(ox + 2 * h, oy + 4 * h, ox + 10 * h, oy + 7 * h)
    pts = seed_points(shape, cell_size=h, points_per_cell=n, origin=origin)
    assert isinstance(pts, SeededPoints)
    assert len(pts) == 8 * 3 * n * n
    assert pts.volumes.sum() == pytest.approx(shape.area, rel=1e-12)
    np.testing.assert_allclose(pts.volumes, (h / n) ** 2, rtol=1e-15)
    np.testing.assert_allclose(pts.half_sizes, h / (2 * n), rtol=1e-15)
    assert pts.positions.shape == (len(pts), 2) and pts.positions.dtype == np.float64


@pytest.mark.parametrize("center", [(0.5, 0.5), (0.5123, 0.4871)])
def test_disk_volume_approximates_area(center):
    """Verify the seeded volume of a disk (r = 0.2, h = 0.01, 2 ppc) approximates πr²."""
    r, h, n = 0.2, 0.01, 2
    s = h / n  # sub-cell width: each point stands for an s × s square
    pts = seed_points(disk(center, r), cell_size=h, points_per_cell=n)
    rel = abs(pts.volumes.sum() - math.pi * r**2) / (math.pi * r**2)
    # Rigorous bound: only sub-cells crossed by the circle can be misclassified, each by at most s².
    # A curve monotone in x and y crosses at most (Δx + Δy)/s + 1 cells; the 4 quarter-arcs give
    # Δx + Δy = 2r each, so |ΔA| ≤ (8r/s + 4)·s² and rel ≤ (8rs + 4s²)/(πr²) ≈ 6.4 % here.
    assert rel <= (8 * r * s + 4 * s**2) / (math.pi * r**2)
    # The errors of crossed sub-cells mostly cancel (Gauss circle problem: the count error grows
    # like R^θ, θ ≤ 2/3, R = r/s = 40, i.e. ~10 of ~5000 points); observed worst case over random
    # centres is 0.19 %, so 1 % (≈50 points) is a safe but meaningful bound.
    assert rel < 0.01


def test_disk_membership_is_exact_circle():
    """Verify disk membership uses |p - c| < r, not the inscribed 128-gon."""
    c, r = np.array([0.3, -0.1]), 0.2
    shape = disk(tuple(c), r, segments=128)
    # mid-way between two outline vertices, the 128-gon's chord lies r·(1 - cos(π/128)) ≈ 3e-4 r inside
    t = math.pi / 128
    p = c + r * (1 - 1e-5) * np.array([math.cos(t), math.sin(t)])
    q = c + r * (1 + 1e-5) * np.array([1.0, 0.0])
    assert not shape.polygon.contains(shapely.Point(p))
    assert shape.contains(np.array([p, q, c])).tolist() == [True, False, True]
    assert shape.bounds == pytest.approx((0.1, -0.3, 0.5, 0.1))


@pytest.mark.parametrize("n", [1, 2, 3, 5])
def test_points_on_subcell_centres(n):
    """Verify every seeded point is at origin + (i + (a + 0.5)/n)·h in x and y."""
    h, origin = 0.04, np.array([-0.3, 0.1])
    shape = polygon([(0.0, 0.2), (0.5, 0.25), (0.3, 0.6), (-0.1, 0.45)])
    pts = seed_points(shape, cell_size=h, points_per_cell=n, origin=tuple(origin))
    k = (pts.positions - origin) / h * n - 0.5  # sub-cell index i·n + a, must be an integer
    np.testing.assert_allclose(k, np.round(k), atol=1e-9)
    assert shape.contains(pts.positions).all()
    assert len(np.unique(np.round(k).astype(int), axis=0)) == len(pts)  # no duplicates


@pytest.mark.parametrize(
    "shape",
    [
        disk((0.5, 0.5), 0.2),
        rectangle(0.1013, 0.2013, 0.4987, 0.3987),
        polygon([(0.3 + 0.17 * math.cos(a), 0.2 + 0.17 * math.sin(a))
                 for a in np.arange(6) * math.pi / 3 + 0.1]),
    ],
    ids=["disk", "rectangle", "hexagon"],
)
def test_centroid_of_symmetric_shape(shape):
    """Verify a point-symmetric shape centred on a sub-grid symmetry point seeds points with its centroid."""
    pts = seed_points(shape, cell_size=0.01, points_per_cell=2)
    centroid = np.array(shape.polygon.centroid.coords[0])
    np.testing.assert_allclose(pts.positions.mean(axis=0), centroid, atol=1e-12)


@pytest.mark.parametrize(
    ("make", "name"),
    [
        (lambda: polygon([(0, 0), (1, 1)]), "vertices"),
        (lambda: polygon([(0, 0), (1, 1), (1, 0), (0, 1)]), "vertices"),  # bowtie
        (lambda: polygon([(0, 0), (1, 0), (2, 0)]), "vertices"),  # zero area
        (lambda: seed_points(rectangle(0, 0, 1, 1), cell_size=0.1, points_per_cell=0), "points_per_cell"),
        (lambda: seed_points(rectangle(0, 0, 1, 1), cell_size=0.1, points_per_cell=9), "points_per_cell"),
        (lambda: seed_points(rectangle(0, 0, 1, 1), cell_size=0.1, points_per_cell=2.0), "points_per_cell"),
        (lambda: seed_points(rectangle(0, 0, 1, 1), cell_size=-1, points_per_cell=2), "cell_size"),
        (lambda: seed_points(disk((0.5, 0.5), 1e-4), cell_size=0.1, points_per_cell=2), "shape"),
        (lambda: rectangle(1, 0, 0, 1), "x1"),
        (lambda: disk((0, 0), -1.0), "radius"),
    ],
    ids=["2-vertices", "bowtie", "zero-area", "ppc-0", "ppc-9", "ppc-float", "cell-size", "tiny",
         "rect-inverted", "radius"],
)
def test_bad_inputs_raise(make, name):
    """Verify invalid parameters raise ValueError naming the parameter."""
    with pytest.raises(ValueError, match=name):
        make()


def test_to_dict_is_json():
    """Verify to_dict of every kind of shape is JSON-serialisable and carries its parameters."""
    d = json.loads(json.dumps(disk((1.0, 2.0), 0.3).to_dict()))
    assert d == {"kind": "disk", "center": [1.0, 2.0], "radius": 0.3, "segments": 128}
    assert json.loads(json.dumps(rectangle(0, 0, 1, 2).to_dict()))["corners"] == [0, 0, 1, 2]
    d = json.loads(json.dumps(polygon([(0, 0), (1, 0), (0, 1)]).to_dict()))
    assert d["kind"] == "polygon" and len(d["vertices"]) == 3


def _write_svg(path, d):
    path.write_text(f'<svg xmlns="http://www.w3.org/2000/svg" width="10" height="10"><path d="{d}"/></svg>')
    return path


def test_from_file_svg(tmp_path):
    """Verify from_file reads an SVG square, scales it, and keeps the largest outline."""
    square = _write_svg(tmp_path / "square.svg", "M 0 0 L 1 0 L 1 1 L 0 1 Z")
    shape = from_file(square, scale=0.25)
    assert shape.area == pytest.approx(0.0625, rel=1e-12)
    assert shape.bounds == pytest.approx((0.0, 0.0, 0.25, 0.25))
    pts = seed_points(shape, cell_size=0.05, points_per_cell=2)
    assert pts.volumes.sum() == pytest.approx(0.0625, rel=1e-12)
    assert json.loads(json.dumps(shape.to_dict()))["kind"] == "file"

    two = _write_svg(tmp_path / "two.svg", "M 0 0 L 1 0 L 1 1 L 0 1 Z M 3 3 L 5 3 L 5 5 L 3 5 Z")
    assert from_file(two, scale=2.0).area == pytest.approx(16.0, rel=1e-12)

    with pytest.raises(ValueError, match="path"):
        from_file(_write_svg(tmp_path / "open.svg", "M 0 0 L 1 0"))
    with pytest.raises(ValueError, match="path"):
        from_file(tmp_path / "missing.svg")
    with pytest.raises(ValueError, match="scale"):
        from_file(square, scale=0.0)


def test_from_file_names_the_extra_when_a_package_is_missing(tmp_path, monkeypatch):
    """Verify a missing optional package of SVG import (here lxml) gives an ImportError that names the
    extra to install, ``mpmdem[svg]``."""
    svg_io = pytest.importorskip("trimesh.path.exchange.svg_io")
    from trimesh.exceptions import ExceptionWrapper

    # what trimesh binds when `from lxml import etree` fails at its import
    monkeypatch.setattr(svg_io, "etree", ExceptionWrapper(ModuleNotFoundError("No module named 'lxml'", name="lxml")))
    square = _write_svg(tmp_path / "square.svg", "M 0 0 L 1 0 L 1 1 L 0 1 Z")
    with pytest.raises(ImportError, match=r'pip install "mpmdem\[svg\]"') as info:
        from_file(square)
    assert "lxml" in str(info.value)


@pytest.mark.parametrize("h", [1.0 / 16, 0.025, 0.0125, 0.01])
@pytest.mark.parametrize(
    "shape",
    [
        disk((0.5123, 0.4871), 0.2),
        rectangle(0.1013, 0.2013, 0.4987, 0.3987),
        polygon([(0.0, 0.2), (0.5, 0.25), (0.3, 0.6), (-0.1, 0.45)]),
    ],
    ids=["disk", "rectangle", "quadrilateral"],
)
def test_clipped_seeding_volume_is_the_area(shape, h):
    """Verify the default seeding's volumes sum to the shape's area (πr² for a disk) to round-off at
    any resolution, and that "full" keeps whole sub-cells (the staircase area) at the same points."""
    clipped = seed_points(shape, cell_size=h, points_per_cell=2)
    full = seed_points(shape, cell_size=h, points_per_cell=2, seeding="full")
    assert clipped.volumes.sum() == pytest.approx(shape.area, rel=1e-13)
    np.testing.assert_array_equal(clipped.positions, full.positions)
    np.testing.assert_allclose(full.volumes, (h / 2) ** 2, rtol=1e-15)
    # a point whose centre is inside keeps at least a quarter of its sub-cell (a straight outline
    # through the centre leaves half); the slivers lumped onto it add at most a few sub-cells
    assert clipped.volumes.min() > 0.25 * (h / 2) ** 2
    assert clipped.volumes.max() < 4.0 * (h / 2) ** 2


def test_clipped_seeding_inside_is_whole_sub_cells():
    """Verify points away from the outline keep their whole sub-cell, (h/n)², under clipping."""
    h, n = 0.02, 2
    shape = disk((0.5, 0.5), 0.2)
    pts = seed_points(shape, cell_size=h, points_per_cell=n)
    deep = np.hypot(*(pts.positions - 0.5).T) < 0.2 - h
    assert deep.sum() > 0.8 * len(pts)
    np.testing.assert_allclose(pts.volumes[deep], (h / n) ** 2, rtol=1e-12)


def test_seeding_bad_value_is_an_input_error():
    """Verify an unknown seeding names the parameter and the choices."""
    with pytest.raises(ValueError, match="seeding.*clipped"):
        seed_points(rectangle(0, 0, 1, 1), cell_size=0.1, points_per_cell=2, seeding="exact")
