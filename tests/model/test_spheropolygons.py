"""Tests of mpmdem.model.spheropolygons: exact mass properties, constructors, frames and input errors."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from shapely.geometry.polygon import orient

from mpmdem.errors import InputError
from mpmdem.model.spheropolygons import (
    Spheropolygon,
    _convex_moments,
    _offset_moments,
    random_convex_polygon,
    regular_polygon,
    rod,
    rounded_rectangle,
    sphero_disk,
    spheropolygon,
    spheropolygon_from_file,
)

L_SHAPE = [(0.0, 0.0), (2.0, 0.0), (2.0, 1.0), (1.0, 1.0), (1.0, 3.0), (0.0, 3.0)]
HEXAGRAM = [((1.0 if k % 2 == 0 else 1.0 / math.sqrt(3.0)) * math.cos(k * math.pi / 6),
             (1.0 if k % 2 == 0 else 1.0 / math.sqrt(3.0)) * math.sin(k * math.pi / 6)) for k in range(12)]
# A square "C": its 0.2 m wide mouth closes for a > 0.1, its cavity stays a hole while a < 0.6.
C_SHAPE = [(1.0, 0.1), (1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0), (1.0, -0.1), (0.6, -0.1), (0.6, -0.6),
           (-0.6, -0.6), (-0.6, 0.6), (0.6, 0.6), (0.6, 0.1)]


def _ring_integrals(coords: np.ndarray) -> np.ndarray:
    """(A, ∫x dA, ∫y dA, ∫|r|² dA) of a closed ring (last = first) by the shoelace-type formulas."""
    p, q = coords[:-1], coords[1:]
    cr = p[:, 0] * q[:, 1] - p[:, 1] * q[:, 0]
    return np.array([cr.sum() / 2, (cr * (p[:, 0] + q[:, 0])).sum() / 6, (cr * (p[:, 1] + q[:, 1])).sum() / 6,
                     (cr * ((p * p).sum(1) + (p * q).sum(1) + (q * q).sum(1))).sum() / 12])


def _shapely_props(poly) -> tuple[float, np.ndarray, float]:
    """(area, centroid, polar second moment about the centroid) of a shapely polygon, holes subtracted."""
    poly = orient(poly, 1.0)  # exterior ccw, holes cw: their integrals come out negative
    tot = sum(_ring_integrals(np.asarray(r.coords)) for r in (poly.exterior, *poly.interiors))
    c = tot[1:3] / tot[0]
    return tot[0], c, tot[3] - tot[0] * (c @ c)


def _turning_angles(v: np.ndarray) -> np.ndarray:
    e = np.roll(v, -1, axis=0) - v
    ep = np.roll(e, 1, axis=0)
    return np.arctan2(ep[:, 0] * e[:, 1] - ep[:, 1] * e[:, 0], (ep * e).sum(1))


def _expect_input_error(name: str, fn, *args, **kwargs) -> InputError:
    with pytest.raises(InputError) as info:
        fn(*args, **kwargs)
    assert info.value.name == name and str(info.value).startswith(f"{name}=")
    return info.value


SHAPES = {
    "disk": lambda: sphero_disk(0.3),
    "rod": lambda: rod(1.0, 0.2),
    "rounded_rectangle": lambda: rounded_rectangle(2.0, 1.0, 0.2),
    "pentagon": lambda: regular_polygon(5, 1.0, 0.2, angle=0.3),
    **{f"random_convex_{s}": (lambda s=s: random_convex_polygon(np.random.default_rng(s), 3 + 2 * s, 0.5, 0.05))
       for s in range(5)},
    "L_small": lambda: spheropolygon(L_SHAPE, 0.1),
    "L_large": lambda: spheropolygon(L_SHAPE, 0.6),
    "hexagram_small": lambda: spheropolygon(HEXAGRAM, 0.02),
    "hexagram_large": lambda: spheropolygon(HEXAGRAM, 0.3),
    "C_open": lambda: spheropolygon(C_SHAPE, 0.05),
    "C_with_hole": lambda: spheropolygon(C_SHAPE, 0.15),
    "C_filled": lambda: spheropolygon(C_SHAPE, 0.7),
}


@pytest.mark.parametrize("name", list(SHAPES))
def test_mass_properties_match_shapely(name):
    """Verify area, centroid (at the body origin) and polar moment against shapely's buffer at 256 segments."""
    sp = SHAPES[name]()
    q = 256
    area, c, j = _shapely_props(sp.to_shapely(quad_segs=q))
    # shapely draws each arc as chords of angle <= δ = π/(2q) with their ends on the circle, so it lacks
    # at most a segment of area a²(δ - sin δ)/2 (≈ (δ²/6) × its sector, 6.3e-6 for q = 256) per chord.
    # The drawn arcs turn by at most Θ = Σ positive turning angles (2π for one or two vertices), in at
    # most Θ/δ + 2 per convex vertex chords. The missing area ΔA lies within R = bounding_radius of the
    # origin, so the centroid moves by at most ΔA·R/(A - ΔA) and ∫|r|² dA drops by at most ΔA·R².
    a, v = sp.radius, sp.vertices
    delta = math.pi / (2 * q)
    turns = np.full(1, 2 * math.pi) if len(v) <= 2 else np.clip(_turning_angles(v), 0.0, None)
    chords = turns.sum() / delta + 2 * np.count_nonzero(turns) + 2
    d_area = chords * a * a * (delta - math.sin(delta)) / 2
    r_b = sp.bounding_radius
    assert 0.0 <= sp.area - area <= d_area + 1e-13 * sp.area
    assert np.hypot(*c) <= d_area * r_b / (area - d_area) + 1e-13 * r_b
    assert abs(sp.second_moment - j) <= d_area * r_b**2 + 1e-12 * sp.second_moment
    # the bound is tight enough to matter: a few parts per million, not a loose percentage
    assert d_area <= 2e-5 * sp.area


@pytest.mark.parametrize("name", [n for n in SHAPES if not n.startswith(("disk", "rod", "L", "hexagram", "C"))])
def test_boundary_integration_equals_pieces_on_convex_cores(name):
    """Verify the general (Green's theorem, trimmed offset) route equals the piecewise route on convex cores."""
    sp = SHAPES[name]()
    ref = _convex_moments(sp.vertices, sp.radius)
    got = _offset_moments(sp.vertices, sp.radius)
    scale = sp.bounding_radius
    np.testing.assert_allclose(got[[0, 3]], ref[[0, 3]], rtol=1e-12)
    np.testing.assert_allclose(got[1:3], ref[1:3], atol=1e-13 * sp.area * scale)


def _kite_reference(v: np.ndarray, a: float) -> tuple[float, np.ndarray, float]:
    """Exact properties of a non-convex core with a simple offset, built independently from pieces.

    Core + an a-wide rectangle outside every edge + a sector at every convex vertex, minus at every
    reflex vertex (turn -α) the doubly counted kite V, V + a n₁, X, V + a n₂ (area a² tan(α/2)), X being
    where the two offset lines cross.
    """
    v = np.asarray(v, dtype=np.float64)
    e = np.roll(v, -1, axis=0) - v
    d = e / np.hypot(*e.T)[:, None]
    nrm = np.column_stack([d[:, 1], -d[:, 0]])
    tot = _ring_integrals(np.vstack([v, v[:1]]))
    for i in range(len(v)):
        rect = np.array([v[i], v[i] + a * nrm[i], v[i] + e[i] + a * nrm[i], v[i] + e[i], v[i]])
        tot = tot + _ring_integrals(rect)
    for k, turn in enumerate(_turning_angles(v)):
        n1, n2 = nrm[k - 1], nrm[k]
        if turn > 0.0:  # sector about V_k from n1 over the turn, polar coordinates about V_k
            phi0, c = math.atan2(n1[1], n1[0]), v[k]
            m0 = a * a * turn / 2
            # ∫∫ (r cos φ, r sin φ) r dr dφ over r < a, φ0 < φ < φ0 + turn
            m1 = a**3 / 3 * np.array([math.sin(phi0 + turn) - math.sin(phi0), math.cos(phi0) - math.cos(phi0 + turn)])
            tot = tot + [m0, c[0] * m0 + m1[0], c[1] * m0 + m1[1], a**4 * turn / 4 + 2 * c @ m1 + c @ c * m0]
        elif turn < 0.0:
            x = v[k] + a * (n1 + n2) / (1.0 + n1 @ n2)
            kite = _ring_integrals(np.array([v[k], v[k] + a * n1, x, v[k] + a * n2, v[k]]))
            assert kite[0] == pytest.approx(a * a * math.tan(-turn / 2) * np.sign(kite[0]), rel=1e-12)
            tot = tot - kite * np.sign(kite[0])
    c = tot[1:3] / tot[0]
    return tot[0], c, tot[3] - tot[0] * (c @ c)


@pytest.mark.parametrize("outline, a", [(L_SHAPE, 0.1), (L_SHAPE, 0.4), (HEXAGRAM, 0.02), (HEXAGRAM, 0.1)])
def test_non_convex_exact_against_kite_formula(outline, a):
    """Verify the non-convex route to round-off against an independent exact decomposition (simple offsets)."""
    sp = spheropolygon(outline, a)
    area, c, j = _kite_reference(np.asarray(outline) - sp.origin, a)
    assert not sp.convex
    assert sp.area == pytest.approx(area, rel=1e-12)
    assert np.hypot(*c) <= 1e-12 * sp.bounding_radius
    assert sp.second_moment == pytest.approx(j, rel=1e-12)


def test_merging_offsets_and_holes_are_exercised():
    """Verify the C-shape cases cover an open mouth, a closed mouth around a hole, and a filled cavity."""
    holes = [len(SHAPES[k]().to_shapely(64).interiors) for k in ("C_open", "C_with_hole", "C_filled")]
    assert holes == [0, 1, 0]


def test_l_shape_area_closed_form():
    """Verify A = A_P + a·perimeter + πa² + a² Σ_reflex (α/2 - tan(α/2)) for the L (one reflex vertex, α = π/2)."""
    a = 0.1
    assert spheropolygon(L_SHAPE, a).area == pytest.approx(4.0 + a * 10.0 + math.pi * a * a + a * a * (math.pi / 4 - 1),
                                                           rel=1e-13)


def test_disk_closed_form():
    """Verify a disk: m = ρπa², I = m a²/2, one vertex at the centre."""
    a, rho = 0.3, 2500.0
    sp = sphero_disk(a)
    m, inertia = sp.mass_properties(rho)
    assert m == pytest.approx(rho * math.pi * a * a, rel=1e-14)
    assert inertia == pytest.approx(m * a * a / 2, rel=1e-14)
    assert sp.vertices.tolist() == [[0.0, 0.0]] and sp.kind == "disk" and sp.convex
    assert sp.core_radius == 0.0 and sp.bounding_radius == a


def test_rod_closed_form():
    """Verify a stadium: rectangle 2a × L plus two half disks (centroid 4a/(3π) beyond the core ends)."""
    length, a = 1.5, 0.2
    sp = rod(length, a)
    rect_area = 2 * a * length
    half = math.pi * a * a / 2
    j_rect = rect_area * (length**2 + 4 * a * a) / 12
    # polar moment of a half disk about its centre πa⁴/4, first moment along the axis 2a³/3, shifted by L/2
    j_half = math.pi * a**4 / 4 + length * 2 * a**3 / 3 + (length / 2) ** 2 * half
    assert sp.area == pytest.approx(rect_area + 2 * half, rel=1e-14)
    assert sp.second_moment == pytest.approx(j_rect + 2 * j_half, rel=1e-14)
    np.testing.assert_array_equal(sp.vertices, [[-0.75, 0.0], [0.75, 0.0]])


def test_sharp_and_rounded_rectangle():
    """Verify a sharp rectangle's I = m(w² + h²)/12 and a rounded one's outer size and core."""
    w, h, rho = 2.0, 0.5, 1000.0
    m, inertia = rounded_rectangle(w, h).mass_properties(rho)
    assert m == pytest.approx(rho * w * h, rel=1e-14)
    assert inertia == pytest.approx(m * (w * w + h * h) / 12, rel=1e-14)
    sp = rounded_rectangle(w, h, 0.1)
    np.testing.assert_allclose(sp.to_shapely(64).bounds, (-1.0, -0.25, 1.0, 0.25), atol=1e-12)
    np.testing.assert_allclose(np.abs(sp.vertices), [[0.9, 0.15]] * 4, rtol=1e-15)
    assert sp.area == pytest.approx(w * h - (4 - math.pi) * 0.01, rel=1e-13)


def test_regular_polygon_vertices():
    """Verify a regular polygon's vertices lie on the circumcircle, counter-clockwise from ``angle``."""
    sp = regular_polygon(6, 0.5, 0.05, angle=0.25)
    np.testing.assert_allclose(np.hypot(*sp.vertices.T), 0.5, rtol=1e-14)
    assert math.atan2(sp.vertices[0, 1], sp.vertices[0, 0]) == pytest.approx(0.25)
    assert sp.convex and sp.origin == (0.0, 0.0)
    np.testing.assert_allclose(_turning_angles(sp.vertices), math.pi / 3, rtol=1e-12)


@pytest.mark.parametrize("seed", range(6))
def test_random_convex_polygon(seed):
    """Verify random polygons are convex, on their circle (about -origin), reproducible and seed-dependent."""
    sp = random_convex_polygon(np.random.default_rng(seed), 6, 0.02, radius=0.002, irregularity=0.9)
    assert sp.convex and sp.kind == "convex" and len(sp.vertices) == 6
    assert (_turning_angles(sp.vertices) > 0).all()
    np.testing.assert_allclose(np.hypot(*(sp.vertices + sp.origin).T), 0.02, rtol=1e-13)
    again = random_convex_polygon(np.random.default_rng(seed), 6, 0.02, radius=0.002, irregularity=0.9)
    np.testing.assert_array_equal(sp.vertices, again.vertices)
    other = random_convex_polygon(np.random.default_rng(seed + 100), 6, 0.02, radius=0.002, irregularity=0.9)
    assert not np.allclose(sp.vertices, other.vertices)


def test_outline_origin_orientation_and_collinear_rod():
    """Verify user outlines keep their placement in ``origin``, become ccw, and collinear ones become rods."""
    shift = np.array([3.0, -1.0])
    ccw = spheropolygon(np.asarray(L_SHAPE) + shift, 0.1)
    np.testing.assert_allclose(ccw.vertices + ccw.origin, np.asarray(L_SHAPE) + shift, atol=1e-14)
    cw = spheropolygon((np.asarray(L_SHAPE) + shift)[::-1], 0.1)
    assert cw.area == pytest.approx(ccw.area, rel=1e-14) and cw.origin == pytest.approx(ccw.origin, rel=1e-14)
    assert (_ring_integrals(np.vstack([cw.vertices, cw.vertices[:1]]))[0]) > 0
    closed = spheropolygon([*L_SHAPE, L_SHAPE[0]])
    assert len(closed.vertices) == 6 and closed.area == pytest.approx(4.0, rel=1e-14)
    line = spheropolygon([(0.0, 1.0), (2.0, 1.0), (1.0, 1.0)], 0.1)
    assert len(line.vertices) == 2 and line.area == pytest.approx(rod(2.0, 0.1).area, rel=1e-14)
    assert line.origin == pytest.approx((1.0, 1.0))
    point = spheropolygon([(0.5, 0.5)], 0.2)
    assert point.area == pytest.approx(sphero_disk(0.2).area) and point.origin == (0.5, 0.5)


def test_world_vertices():
    """Verify world vertices are the body-frame ones rotated about the centroid, then translated."""
    sp = rounded_rectangle(2.0, 1.0, 0.1)
    world = sp.world_vertices((1.0, 2.0), math.pi / 2)
    np.testing.assert_allclose(world, np.column_stack([1.0 - sp.vertices[:, 1], 2.0 + sp.vertices[:, 0]]), atol=1e-15)
    np.testing.assert_array_equal(sp.world_vertices(np.zeros(2), 0.0), sp.vertices)
    _expect_input_error("position", sp.world_vertices, (1.0, 2.0, 3.0), 0.0)
    _expect_input_error("position", sp.world_vertices, (1.0, math.nan), 0.0)
    _expect_input_error("angle", sp.world_vertices, (1.0, 2.0), math.inf)


@pytest.mark.parametrize("name", list(SHAPES))
def test_to_dict_and_bounding_radius(name):
    """Verify to_dict is JSON-serialisable and rebuilds the shape; bounding_radius holds the whole outline."""
    sp = SHAPES[name]()
    d = json.loads(json.dumps(sp.to_dict()))
    assert d["kind"] == sp.kind and d["radius"] == sp.radius and d["origin"] == list(sp.origin)
    back = Spheropolygon(np.array(d["vertices"]), d["radius"], tuple(d["origin"]), d["kind"],
                         tuple(d["params"].items()))
    assert back.area == sp.area and back.second_moment == sp.second_moment
    outline = np.asarray(sp.to_shapely(16).exterior.coords)
    assert np.hypot(*outline.T).max() <= sp.bounding_radius * (1 + 1e-12)
    assert sp.core_radius == pytest.approx(np.hypot(*sp.vertices.T).max())


def _write_svg(path, d):
    path.write_text(f'<svg xmlns="http://www.w3.org/2000/svg" width="10" height="10"><path d="{d}"/></svg>')
    return path


def test_from_file_svg(tmp_path):
    """Verify an SVG outline is scaled, cleared of collinear points and placed by ``origin``."""
    svg = _write_svg(tmp_path / "plate.svg", "M 0 0 L 4 0 L 8 0 L 8 2 L 0 2 Z M 20 20 L 21 20 L 21 21 Z")
    sp = spheropolygon_from_file(svg, radius=0.001, scale=0.01)
    assert sp.kind == "file" and len(sp.vertices) == 4
    assert sp.area == pytest.approx(rounded_rectangle(0.082, 0.022, 0.001).area, rel=1e-12)
    assert sp.origin == pytest.approx((0.04, 0.01), rel=1e-12)
    assert json.dumps(sp.to_dict())
    _expect_input_error("path", spheropolygon_from_file, tmp_path / "missing.svg")
    _expect_input_error("scale", spheropolygon_from_file, svg, scale=0.0)
    _expect_input_error("radius", spheropolygon_from_file, tmp_path / "missing.svg", radius=-1.0)


@pytest.mark.parametrize("name, fn, args, kwargs", [
    ("vertices", spheropolygon, ([],), {}),
    ("vertices", spheropolygon, ([[0, 0, 0], [1, 0, 0], [0, 1, 0]],), {}),
    ("vertices", spheropolygon, ([(0, 0), (1, 0), (0, math.nan)],), {}),
    ("vertices", spheropolygon, ([[0, 0], [1, 0], [0]],), {}),
    ("vertices", spheropolygon, ([(0, 0), (1, 0), (1, 0), (0, 1)],), {}),  # repeated consecutive vertex
    ("vertices", spheropolygon, ([(0, 0), (1, 0), (0, 0)],), {"radius": 0.1}),  # repeated (wrap-around)
    ("vertices", spheropolygon, ([(0, 0), (1, 0), (2, 0)],), {}),  # collinear with a = 0: zero area
    ("radius", spheropolygon, ([(0, 0)],), {}),  # a point with a = 0
    ("radius", spheropolygon, ([(0, 0), (1, 0)],), {}),  # a segment with a = 0
    ("radius", spheropolygon, (L_SHAPE,), {"radius": -0.1}),
    ("radius", spheropolygon, (L_SHAPE,), {"radius": math.nan}),
    ("radius", sphero_disk, (0.0,), {}),
    ("radius", sphero_disk, (math.inf,), {}),
    ("length", rod, (0.0, 0.1), {}),
    ("radius", rod, (1.0, 0.0), {}),
    ("width", rounded_rectangle, (-1.0, 1.0), {}),
    ("height", rounded_rectangle, (1.0, math.nan), {}),
    ("radius", rounded_rectangle, (1.0, 0.4), {"radius": 0.2}),  # 2a = min(width, height): no core
    ("radius", rounded_rectangle, (1.0, 0.4), {"radius": -0.01}),
    ("sides", regular_polygon, (2, 1.0), {}),
    ("sides", regular_polygon, (3.0, 1.0), {}),
    ("sides", regular_polygon, (True, 1.0), {}),
    ("circumradius", regular_polygon, (5, 0.0), {}),
    ("angle", regular_polygon, (5, 1.0), {"angle": math.nan}),
    ("rng", random_convex_polygon, (42, 5, 1.0), {}),
    ("sides", random_convex_polygon, (np.random.default_rng(0), 1, 1.0), {}),
    ("circumradius", random_convex_polygon, (np.random.default_rng(0), 5, -1.0), {}),
    ("radius", random_convex_polygon, (np.random.default_rng(0), 5, 1.0, -0.1), {}),
    ("irregularity", random_convex_polygon, (np.random.default_rng(0), 5, 1.0), {"irregularity": 1.0}),
    ("irregularity", random_convex_polygon, (np.random.default_rng(0), 5, 1.0), {"irregularity": -0.1}),
])
def test_input_errors(name, fn, args, kwargs):
    """Verify every invalid input raises InputError naming the parameter."""
    _expect_input_error(name, fn, *args, **kwargs)


def test_self_intersecting_outline_explained():
    """Verify a bow-tie is refused with shapely's explanation of where it crosses itself."""
    err = _expect_input_error("vertices", spheropolygon, [(0, 0), (1, 1), (1, 0), (0, 1)], 0.1)
    assert "self-intersect" in str(err).lower()


def test_method_and_direct_construction_errors():
    """Verify method arguments are checked and direct construction needs centred ccw vertices."""
    sp = regular_polygon(4, 1.0, 0.1)
    _expect_input_error("density", sp.mass_properties, 0.0)
    _expect_input_error("density", sp.mass_properties, math.nan)
    _expect_input_error("quad_segs", sp.to_shapely, 0)
    _expect_input_error("vertices", Spheropolygon, sp.vertices + 0.1, 0.1)  # not about the centroid
    _expect_input_error("vertices", Spheropolygon, sp.vertices[::-1], 0.1)  # clockwise
    _expect_input_error("radius", Spheropolygon, np.zeros((1, 2)), 0.0)
    _expect_input_error("vertices", Spheropolygon, np.zeros((2, 2)), 0.1)  # repeated vertex
    _expect_input_error("kind", Spheropolygon, sp.vertices, 0.1, (0.0, 0.0), "blob")
    _expect_input_error("origin", Spheropolygon, sp.vertices, 0.1, (0.0, math.nan))
    with pytest.raises(AttributeError):
        sp.radius = 2.0  # frozen
    with pytest.raises(ValueError):
        sp.vertices[0, 0] = 1.0  # read-only
