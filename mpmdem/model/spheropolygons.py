"""Spheropolygons: the shapes of the rigid DEM bodies (SI units: metres, radians).

A spheropolygon is a core polygon P (vertices V_k) dilated by a disk of radius a >= 0, the Minkowski
sum P ⊕ D(a) of MPM-SDEM eq. 37. One vertex gives a disk, two a stadium (rod). The vertices are stored
in the body frame: counter-clockwise, about the centroid of the dilated shape (its centre of mass for
a uniform density).

Mass properties (area, centroid, polar second moment) are exact, not sampled:

* convex core: the dilated shape splits without overlap into the core, one a-wide rectangle outside
  each edge and a circular sector at each vertex whose opening is the turning angle there;
* non-convex core: the boundary of the dilated shape is made of the edges' outward offset segments
  and of arcs about the convex vertices, each trimmed where it comes closer than a to another edge.
  Green's theorem over these exact straight pieces and circular arcs gives the integrals; this holds
  for any a, also when offsets merge or enclose holes.

No Warp here: pure numpy + shapely (trimesh for files).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

import numpy as np
import shapely
from shapely.geometry import LineString, Point, Polygon
from shapely.validation import explain_validity

from ..checks import at_least, finite, positive
from ..errors import InputError

__all__ = [
    "Spheropolygon",
    "random_convex_polygon",
    "regular_polygon",
    "rod",
    "rounded_rectangle",
    "sphero_disk",
    "spheropolygon",
    "spheropolygon_from_file",
]

_KINDS = ("disk", "rod", "rectangle", "regular_polygon", "convex", "polygon", "file")
#: Relative tolerances: repeated vertices (of the outline's extent), collinear vertices (sine of the
#: turning angle), a body frame's centring (of the bounding radius).
_REPEAT_TOL = 1e-12
_COLLINEAR_TOL = 1e-12
_CENTRE_TOL = 1e-9


# ----------------------------------------------------------------------------------------------------
# Exact integrals. Each returns (A, Sx, Sy, J): area, first moments and polar second moment about the
# coordinate origin, as signed integrals (positive for counter-clockwise boundaries).
# ----------------------------------------------------------------------------------------------------


def _fan_segments(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Summed integrals over the signed triangles (0, p_i, q_i); p, q: (m, 2)."""
    cr = p[:, 0] * q[:, 1] - p[:, 1] * q[:, 0]
    area = 0.5 * cr.sum()
    sx = (cr * (p[:, 0] + q[:, 0])).sum() / 6.0
    sy = (cr * (p[:, 1] + q[:, 1])).sum() / 6.0
    jj = (cr * ((p * p).sum(1) + (p * q).sum(1) + (q * q).sum(1))).sum() / 12.0
    return np.array([area, sx, sy, jj])


def _polygon(v: np.ndarray) -> np.ndarray:
    """Integrals over a polygon (shoelace formulas); v: (n, 2), counter-clockwise for positive values."""
    return _fan_segments(v, np.roll(v, -1, axis=0))


def _sectors(c: np.ndarray, a: float, phi0: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Summed integrals over circular sectors of radius a about c (m, 2), from angle phi0 over theta."""
    area = 0.5 * a * a * theta
    mid = phi0 + 0.5 * theta
    # first moment about the centre: area × (4 a sin(θ/2) / (3θ)) along the bisector
    m1 = (2.0 / 3.0) * a**3 * np.sin(0.5 * theta)
    fx, fy = m1 * np.cos(mid), m1 * np.sin(mid)
    sx = c[:, 0] * area + fx
    sy = c[:, 1] * area + fy
    # polar moment a⁴θ/4 about the centre, moved to the origin (exact parallel-axis with the first moment)
    jj = 0.25 * a**4 * theta + 2.0 * (c[:, 0] * fx + c[:, 1] * fy) + (c * c).sum(1) * area
    return np.array([area.sum(), sx.sum(), sy.sum(), jj.sum()])


def _arcs(c: np.ndarray, a: float, phi0: np.ndarray, phi1: np.ndarray) -> np.ndarray:
    """Green's-theorem line integrals along counter-clockwise arcs (centre c, radius a, phi0 → phi1).

    The fan over an arc from start s to end e equals the fan over s → c → e plus the sector.
    """
    s = c + a * np.column_stack([np.cos(phi0), np.sin(phi0)])
    e = c + a * np.column_stack([np.cos(phi1), np.sin(phi1)])
    return _fan_segments(s, c) + _fan_segments(c, e) + _sectors(c, a, phi0, phi1 - phi0)


def _frame(v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Edge vectors, lengths, unit directions and outward (right-hand) unit normals of a ccw polygon."""
    e = np.roll(v, -1, axis=0) - v
    length = np.hypot(e[:, 0], e[:, 1])
    d = e / length[:, None]
    return e, length, d, np.column_stack([d[:, 1], -d[:, 0]])


def _turning(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cross products of consecutive edge directions (sine of the turn) and turning angles at the vertices."""
    dp = np.roll(d, 1, axis=0)  # edge arriving at vertex k
    cr = dp[:, 0] * d[:, 1] - dp[:, 1] * d[:, 0]
    dot = (dp * d).sum(1)
    return cr, np.arctan2(cr, dot)


def _is_convex(v: np.ndarray) -> bool:
    if len(v) < 3:
        return True
    return bool((_turning(_frame(v)[2])[0] >= -_COLLINEAR_TOL).all())


def _convex_moments(v: np.ndarray, a: float) -> np.ndarray:
    """Integrals over the dilated shape of a convex core (also one or two vertices): core + strips + sectors."""
    n = len(v)
    total = _polygon(v) if n >= 3 else np.zeros(4)
    if a == 0.0:
        return total
    if n == 1:
        return total + _sectors(v, a, np.zeros(1), np.array([2.0 * math.pi]))
    _, _, d, nrm = _frame(v)
    vn = np.roll(v, -1, axis=0)
    # rectangle outside each edge, counter-clockwise: V_i, V_i + a n_i, V_i+1 + a n_i, V_i+1
    rect = np.stack([v, v + a * nrm, vn + a * nrm, vn], axis=1)
    total = total + _fan_segments(rect.reshape(-1, 2), np.roll(rect, -1, axis=1).reshape(-1, 2))
    theta = np.full(n, math.pi) if n == 2 else _turning(d)[1]
    nprev = np.roll(nrm, 1, axis=0)
    return total + _sectors(v, a, np.arctan2(nprev[:, 1], nprev[:, 0]), theta)


def _dist_to_edges(x: np.ndarray, p: np.ndarray, d: np.ndarray, length: np.ndarray) -> np.ndarray:
    """Distances (m, k) from points x (m, 2) to the segments p_j + s d_j, s ∈ [0, length_j]."""
    rel = x[:, None, :] - p[None, :, :]
    s = np.clip(np.einsum("mkc,kc->mk", rel, d), 0.0, length[None, :])
    return np.hypot(rel[..., 0] - s * d[None, :, 0], rel[..., 1] - s * d[None, :, 1])


def _segment_roots(start: np.ndarray, e: np.ndarray, p: np.ndarray, q: np.ndarray, d: np.ndarray,
                   nrm: np.ndarray, length: np.ndarray, a: float) -> np.ndarray:
    """Parameters t of start + t e where it crosses the boundary pieces of the edges' a-capsules."""
    ts = []
    ee = e @ e
    for c in (p, q):  # circles of radius a about the edge ends
        w = start - c
        b = w @ e
        disc = b * b - ee * ((w * w).sum(1) - a * a)
        sq = np.sqrt(disc[disc > 0.0])
        ts += [(-b[disc > 0.0] - sq) / ee, (-b[disc > 0.0] + sq) / ee]
    base_n, base_d = ((start - p) * nrm).sum(1), ((start - p) * d).sum(1)
    den_n, den_d = nrm @ e, d @ e
    for base, den, levels in ((base_n, den_n, (a, -a)), (base_d, den_d, (0.0, length))):
        ok = np.abs(den) > 1e-300
        for lev in levels:
            lev = np.broadcast_to(lev, base.shape)
            ts.append((lev[ok] - base[ok]) / den[ok])
    return np.concatenate(ts) if ts else np.empty(0)


def _arc_roots(c: np.ndarray, a: float, p: np.ndarray, q: np.ndarray, d: np.ndarray, nrm: np.ndarray,
               length: np.ndarray) -> np.ndarray:
    """Angles φ of c + a(cos φ, sin φ) where it crosses the boundary pieces of the edges' a-capsules."""
    phis = []
    for end in (p, q):  # |c + a u - end| = a  ⇔  u·(c - end) = -|c - end|²/(2a)
        w = c - end
        r = np.hypot(w[:, 0], w[:, 1])
        ok = (r > 0.0) & (r < 2.0 * a)
        psi = np.arctan2(-w[ok, 1], -w[ok, 0])
        beta = np.arccos(r[ok] / (2.0 * a))
        phis += [psi - beta, psi + beta]
    for v, levels in ((nrm, (a, -a)), (d, (0.0, length))):  # lines (x - p)·v = level
        psi = np.arctan2(v[:, 1], v[:, 0])
        base = ((c - p) * v).sum(1)
        for lev in levels:
            s = (lev - base) / a
            ok = np.abs(s) <= 1.0
            beta = np.arccos(s[ok])
            phis += [psi[ok] - beta, psi[ok] + beta]
    return np.concatenate(phis)


def _offset_moments(v: np.ndarray, a: float) -> np.ndarray:
    """Integrals over the dilated shape of any simple ccw core, by Green's theorem over its exact boundary.

    The boundary is the set of points at distance exactly a outside P: pieces of the outward offset
    segments of the edges and of the arcs about the convex vertices (a reflex vertex has none). Each
    candidate piece is split at its crossings with every nearby edge's a-capsule, and a sub-piece is
    kept where its midpoint is not closer than a to another edge. Kept pieces, traversed with the shape
    on their left, are integrated exactly (holes included).
    """
    n = len(v)
    if a == 0.0:
        return _polygon(v)
    _, length, d, nrm = _frame(v)
    vn = np.roll(v, -1, axis=0)
    size = float(np.ptp(v, axis=0).max())
    tol = 1e-9 * a + 1e-12 * size
    lo, hi = np.minimum(v, vn), np.maximum(v, vn)  # edge bounding boxes
    cr, theta = _turning(d)
    seg_p, seg_q, arc_c, arc_0, arc_1 = [], [], [], [], []

    def near(box_lo: np.ndarray, box_hi: np.ndarray, skip: tuple[int, ...]) -> np.ndarray:
        m = ((lo <= box_hi + a) & (hi >= box_lo - a)).all(1)
        m[list(skip)] = False
        return np.flatnonzero(m)

    def kept(params: np.ndarray, points, j: np.ndarray) -> np.ndarray:
        mid = 0.5 * (params[:-1] + params[1:])
        if len(j) == 0:
            return np.ones(len(mid), dtype=bool)
        dist = _dist_to_edges(points(mid), v[j], d[j], length[j])
        return dist.min(1) >= a - tol

    for i in range(n):  # offset segments
        start, e = v[i] + a * nrm[i], vn[i] - v[i]
        j = near(np.minimum(start, start + e), np.maximum(start, start + e), (i,))
        t = _segment_roots(start, e, v[j], vn[j], d[j], nrm[j], length[j], a)
        t = np.unique(np.concatenate([[0.0, 1.0], t[(t > 0.0) & (t < 1.0)]]))
        keep = kept(t, lambda s, start=start, e=e: start + s[:, None] * e, j)
        seg_p.append(start + t[:-1][keep, None] * e)
        seg_q.append(start + t[1:][keep, None] * e)
    for k in np.flatnonzero(cr > 0.0):  # arcs about the convex vertices
        c = v[k]
        phi0 = math.atan2(nrm[k - 1, 1], nrm[k - 1, 0])
        j = near(c - a, c + a, ((k - 1) % n, k))
        phi = (_arc_roots(c[None, :], a, v[j], vn[j], d[j], nrm[j], length[j]) - phi0) % (2.0 * math.pi)
        phi = np.unique(np.concatenate([[0.0, theta[k]], phi[(phi > 0.0) & (phi < theta[k])]])) + phi0
        keep = kept(phi, lambda f, c=c: c + a * np.column_stack([np.cos(f), np.sin(f)]), j)
        arc_c.append(np.repeat(c[None, :], keep.sum(), axis=0))
        arc_0.append(phi[:-1][keep])
        arc_1.append(phi[1:][keep])
    total = _fan_segments(np.concatenate(seg_p), np.concatenate(seg_q))
    if arc_c:
        total = total + _arcs(np.concatenate(arc_c), a, np.concatenate(arc_0), np.concatenate(arc_1))
    return total


def _mass_moments(v: np.ndarray, a: float) -> tuple[float, np.ndarray, float]:
    """(area [m²], centroid (2,) [m], polar second moment about the centroid [m⁴]) of the dilated shape."""
    ref = v.mean(axis=0)
    w = v - ref  # integrate near the shape for accuracy
    area, sx, sy, jj = _convex_moments(w, a) if _is_convex(w) else _offset_moments(w, a)
    c = np.array([sx, sy]) / area
    return float(area), ref + c, float(jj - area * (c @ c))


def placed(points: np.ndarray, cos, sin, position) -> np.ndarray:
    """Body-frame points (..., k, 2) [m] turned about the body origin by the angle whose cosine and
    sine are ``cos``, ``sin`` (shape (...)), then moved to ``position`` (..., 2) [m]: (..., k, 2) [m].
    One shape's vertices (``Spheropolygon.world_vertices``) or many bodies' at once, the same floats."""
    c, s = np.asarray(cos)[..., None], np.asarray(sin)[..., None]
    p = np.asarray(position)
    x, y = points[..., 0], points[..., 1]
    turned_x = c * x - s * y + p[..., 0, None]
    out = np.empty((*turned_x.shape, 2))
    out[..., 0] = turned_x
    out[..., 1] = s * x + c * y + p[..., 1, None]
    return out


# ----------------------------------------------------------------------------------------------------
# The shape
# ----------------------------------------------------------------------------------------------------


def _positive(name: str, value: object, unit: str = "[m]") -> float:
    return positive(name, value, f"a finite positive number {unit}")


def _sphero_radius(value: object) -> float:
    return at_least("radius", value, 0.0, "a finite sphero radius >= 0 [m]")


def _integer(name: str, value: object, minimum: int) -> int:
    if not isinstance(value, (int, np.integer)) or isinstance(value, bool) or value < minimum:
        raise InputError(name, value, f"an integer >= {minimum}")
    return int(value)


def _summary(arr: np.ndarray) -> str:
    pts = [tuple(float(c) for c in row) for row in arr[:4]]
    return f"{len(arr)} vertices {pts}{' ...' if len(arr) > 4 else ''}"


def _as_vertices(vertices: object) -> np.ndarray:
    try:
        v = np.array(vertices, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError("vertices", vertices, f"an (n, 2) array of finite (x, y) [m] ({exc})") from exc
    if v.ndim != 2 or v.shape[1] != 2 or len(v) == 0 or not np.isfinite(v).all():
        raise InputError("vertices", vertices, "an (n, 2) array of finite (x, y) [m] with n >= 1")
    return v


@dataclass(frozen=True, eq=False)
class Spheropolygon:
    """A core polygon dilated by a disk of radius ``radius`` (MPM-SDEM eq. 37), in its body frame.

    Attributes:
        vertices: (n, 2) core vertices [m], counter-clockwise, about the dilated shape's centroid.
        radius: sphero radius a >= 0 [m] (> 0 for one or two vertices).
        origin: where the body frame's origin lay in the coordinates the outline was given in [m].
        kind: "disk", "rod", "rectangle", "regular_polygon", "convex", "polygon" or "file".
        params: the constructor's parameters, as (name, value) pairs of JSON-serialisable values.
        area: exact area of the dilated shape [m²].
        core_radius: max_k |V_k| [m], the circle about the centroid holding the core polygon.
        second_moment: exact polar second moment of area ∫|r|² dA about the centroid [m⁴].
        convex: whether the core polygon is convex.

    Use the constructors (``sphero_disk``, ``rod``, ``rounded_rectangle``, ``regular_polygon``,
    ``random_convex_polygon``, ``spheropolygon``, ``spheropolygon_from_file``); building one directly
    checks that ``vertices`` are counter-clockwise and centred.
    """

    vertices: np.ndarray
    radius: float
    origin: tuple[float, float] = (0.0, 0.0)
    kind: str = "polygon"
    params: tuple[tuple[str, object], ...] = ()
    area: float = field(init=False)
    core_radius: float = field(init=False)
    second_moment: float = field(init=False)
    convex: bool = field(init=False)

    def __post_init__(self) -> None:
        v = _as_vertices(self.vertices)
        a = _sphero_radius(self.radius)
        o = np.asarray(self.origin, dtype=np.float64).ravel()
        if o.shape != (2,) or not np.isfinite(o).all():
            raise InputError("origin", self.origin, "a finite (x, y) [m]")
        if self.kind not in _KINDS:
            raise InputError("kind", self.kind, f"one of {_KINDS}")
        _check_repeats(v, "vertices", _summary(v))
        if len(v) <= 2 and a == 0.0:
            raise InputError("radius", self.radius, f"> 0 [m] for a core of {len(v)} vertices (else zero area)")
        if len(v) >= 3:
            poly = Polygon(v)
            if not poly.is_valid or poly.area <= 0.0 or not shapely.is_ccw(poly.exterior):
                raise InputError("vertices", _summary(v), "a simple counter-clockwise outline of non-zero area "
                                 "(use spheropolygon() to normalise an outline)")
        area, centroid, second = _mass_moments(v, a)
        scale = float(np.hypot(v[:, 0], v[:, 1]).max()) + a
        if np.hypot(*centroid) > _CENTRE_TOL * scale:
            raise InputError("vertices", _summary(v), f"body-frame vertices about the dilated centroid (it is at "
                             f"{tuple(centroid.tolist())}; use spheropolygon() to centre an outline)")
        v.setflags(write=False)
        object.__setattr__(self, "vertices", v)
        object.__setattr__(self, "radius", a)
        object.__setattr__(self, "origin", (float(o[0]), float(o[1])))
        object.__setattr__(self, "params", tuple((str(k), val) for k, val in self.params))
        object.__setattr__(self, "area", area)
        object.__setattr__(self, "core_radius", float(np.hypot(v[:, 0], v[:, 1]).max()))
        object.__setattr__(self, "second_moment", second)
        object.__setattr__(self, "convex", _is_convex(v))

    @property
    def bounding_radius(self) -> float:
        """core_radius + a [m]: the circle about the centroid holding the whole dilated shape."""
        return self.core_radius + self.radius

    def mass_properties(self, density: float) -> tuple[float, float]:
        """(mass per unit thickness ρA [kg/m], moment of inertia about the centroid ρJ [kg·m²/m]) for ρ [kg/m³]."""
        rho = _positive("density", density, "[kg/m³]")
        return rho * self.area, rho * self.second_moment

    def to_shapely(self, quad_segs: int = 32) -> Polygon:
        """The dilated outline in the body frame [m], arcs drawn with ``quad_segs`` segments per quarter circle."""
        q = _integer("quad_segs", quad_segs, 1)
        v, a = self.vertices, self.radius
        core = Point(v[0]) if len(v) == 1 else LineString(v) if len(v) == 2 else Polygon(v)
        return core if a == 0.0 else core.buffer(a, quad_segs=q)

    def world_vertices(self, position, angle: float) -> np.ndarray:
        """(n, 2) core vertices [m] rotated by ``angle`` [rad] about the centroid, then moved to ``position`` [m]."""
        p = np.asarray(position, dtype=np.float64).ravel()
        if p.shape != (2,) or not np.isfinite(p).all():
            raise InputError("position", position, "a finite (x, y) [m]")
        th = finite("angle", angle, "a finite angle [rad]")
        return placed(self.vertices, math.cos(th), math.sin(th), p)

    def to_dict(self) -> dict:
        """JSON-serialisable description: kind, params, radius [m], body-frame vertices [m] and origin [m]."""
        return {
            "kind": self.kind,
            "params": {k: list(val) if isinstance(val, tuple) else val for k, val in self.params},
            "radius": self.radius,
            "vertices": self.vertices.tolist(),
            "origin": list(self.origin),
        }


# ----------------------------------------------------------------------------------------------------
# Constructors
# ----------------------------------------------------------------------------------------------------


def _centred(v: np.ndarray, a: float, kind: str, params: tuple) -> Spheropolygon:
    """The shape with vertices moved to the dilated centroid; origin = that centroid in v's coordinates."""
    centroid = _mass_moments(v, a)[1]
    return Spheropolygon(v - centroid, a, (float(centroid[0]), float(centroid[1])), kind, params)


def sphero_disk(radius: float) -> Spheropolygon:
    """Disk of radius ``radius`` [m] > 0: one core vertex at the origin."""
    a = _positive("radius", radius)
    return Spheropolygon(np.zeros((1, 2)), a, (0.0, 0.0), "disk", (("radius", a),))


def rod(length: float, radius: float) -> Spheropolygon:
    """Stadium: core segment of ``length`` [m] > 0 along x, dilated by ``radius`` [m] > 0."""
    ln = _positive("length", length)
    a = _positive("radius", radius)
    v = np.array([[-0.5 * ln, 0.0], [0.5 * ln, 0.0]])
    return Spheropolygon(v, a, (0.0, 0.0), "rod", (("length", ln), ("radius", a)))


def rounded_rectangle(width: float, height: float, radius: float = 0.0) -> Spheropolygon:
    """Rectangle of outer size ``width`` × ``height`` [m] with corners rounded by ``radius`` [m].

    The core is (width - 2a) × (height - 2a) with a = radius, 0 <= 2a < min(width, height); a = 0 gives
    a sharp rectangle.
    """
    w = _positive("width", width)
    h = _positive("height", height)
    a = _sphero_radius(radius)
    if not 2.0 * a < min(w, h):
        raise InputError("radius", radius, f"a sphero radius with 0 <= 2*radius < min(width, height) = {min(w, h)} [m]")
    cw, ch = 0.5 * w - a, 0.5 * h - a
    v = np.array([[-cw, -ch], [cw, -ch], [cw, ch], [-cw, ch]])
    return Spheropolygon(v, a, (0.0, 0.0), "rectangle", (("width", w), ("height", h), ("radius", a)))


def regular_polygon(sides: int, circumradius: float, radius: float = 0.0, angle: float = 0.0) -> Spheropolygon:
    """Regular core polygon of ``sides`` >= 3 vertices on a circle of ``circumradius`` [m] about the origin,
    the first at ``angle`` [rad], dilated by ``radius`` [m] >= 0."""
    n = _integer("sides", sides, 3)
    r = _positive("circumradius", circumradius)
    a = _sphero_radius(radius)
    th = finite("angle", angle, "a finite angle [rad]")
    t = th + 2.0 * math.pi * np.arange(n) / n
    v = r * np.column_stack([np.cos(t), np.sin(t)])  # centred by symmetry
    params = (("sides", n), ("circumradius", r), ("radius", a), ("angle", th))
    return Spheropolygon(v, a, (0.0, 0.0), "regular_polygon", params)


def random_convex_polygon(rng: np.random.Generator, sides: int, circumradius: float, radius: float = 0.0,
                          irregularity: float = 0.3) -> Spheropolygon:
    """Random convex core of ``sides`` >= 3 vertices on a circle of ``circumradius`` [m], dilated by ``radius`` [m].

    Vertex k lies at angle φ + 2π(k + δ_k)/sides with a random rotation φ and jitters δ_k uniform in
    ±irregularity/2, irregularity in [0, 1): the angles stay in order, so the polygon is convex.
    ``origin`` is the dilated centroid relative to the circle's centre.
    """
    if not isinstance(rng, np.random.Generator):
        raise InputError("rng", rng, "a numpy.random.Generator (np.random.default_rng(seed))")
    n = _integer("sides", sides, 3)
    r = _positive("circumradius", circumradius)
    a = _sphero_radius(radius)
    irr = finite("irregularity", irregularity, "a number in [0, 1)")
    if not 0.0 <= irr < 1.0:
        raise InputError("irregularity", irregularity, "a number in [0, 1)")
    t = rng.uniform(0.0, 2.0 * math.pi) + 2.0 * math.pi * (np.arange(n) + irr * rng.uniform(-0.5, 0.5, n)) / n
    v = r * np.column_stack([np.cos(t), np.sin(t)])
    return _centred(v, a, "convex", (("sides", n), ("circumradius", r), ("radius", a), ("irregularity", irr)))


def _check_repeats(v: np.ndarray, name: str, value: object) -> None:
    n = len(v)
    if n >= 2:
        step = np.hypot(*(np.roll(v, -1, axis=0) - v).T)
        bad = step <= _REPEAT_TOL * float(np.ptp(v, axis=0).max())
        if bad.any():
            k = int(np.argmax(bad))
            raise InputError(name, value, f"an outline without repeated consecutive vertices (vertex {k} = vertex "
                             f"{(k + 1) % n})")


def _normalised(v: np.ndarray, a: float, name: str, value: object) -> np.ndarray:
    """Checked, counter-clockwise core vertices (collinear ones with a > 0 reduced to the segment's ends)."""
    n = len(v)
    size = float(np.ptp(v, axis=0).max())
    _check_repeats(v, name, value)
    if n <= 2:
        if a == 0.0:
            raise InputError("radius", a, f"> 0 [m] for a core of {n} vertices (else the shape has zero area)")
        return v
    poly = Polygon(v)
    if not poly.convex_hull.area > _COLLINEAR_TOL * size * size:
        if a == 0.0:
            raise InputError(name, value, "an outline enclosing a non-zero area (these vertices are collinear), "
                             "or radius > 0")
        u = v[np.argmax(np.hypot(*(v - v[0]).T))] - v[0]  # the segment's direction
        s = (v - v[0]) @ u
        return v[[np.argmin(s), np.argmax(s)]]
    if not poly.is_valid:
        raise InputError(name, value, f"a simple, non-self-intersecting outline ({explain_validity(poly)})")
    return v if shapely.is_ccw(poly.exterior) else v[::-1].copy()


def spheropolygon(vertices, radius: float = 0.0) -> Spheropolygon:
    """Spheropolygon of a simple core outline (convex or not) [(x, y), ...] (in m), dilated by ``radius`` [m].

    Either orientation; a closing repeat of the first vertex is dropped. One vertex (a disk) or two (a
    rod) need radius > 0; collinear vertices with radius > 0 become the rod of their segment. ``origin``
    is the dilated centroid in the given coordinates, so the body sits where it was drawn when placed there.
    """
    a = _sphero_radius(radius)
    v = _as_vertices(vertices)
    if len(v) >= 4 and np.array_equal(v[0], v[-1]):
        v = v[:-1]
    v = _normalised(v, a, "vertices", _summary(v))
    return _centred(v, a, "polygon", (("radius", a),))


def _drop_collinear(v: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    """Vertices without those lying on the straight line through their neighbours (turn below ``tol`` rad)."""
    while len(v) > 3:
        e = np.roll(v, -1, axis=0) - v
        ep = np.roll(e, 1, axis=0)
        cr = ep[:, 0] * e[:, 1] - ep[:, 1] * e[:, 0]
        flat = (np.abs(cr) <= tol * np.hypot(*ep.T) * np.hypot(*e.T)) & ((ep * e).sum(1) > 0.0)
        flat &= ~np.roll(flat, 1)  # never two neighbours in one pass
        if not flat.any():
            break
        if len(v) - flat.sum() < 3:
            flat[np.flatnonzero(flat)[len(v) - 3:]] = False
        v = v[~flat]
    return v


def spheropolygon_from_file(path: str | os.PathLike, *, radius: float = 0.0, scale: float = 1.0) -> Spheropolygon:
    """Spheropolygon of the largest closed outline in an SVG or DXF file (holes ignored), dilated by ``radius`` [m].

    The outline is read as ``mpmdem.model.shapes.from_file`` reads it (coordinates as stored, times ``scale``
    [m per file unit]); repeated and collinear points are dropped. ``origin`` is the dilated centroid
    in the file's (scaled) coordinates.
    """
    from .shapes import from_file

    a = _sphero_radius(radius)
    outline = from_file(path, scale=scale).polygon  # checks path and scale, ccw
    v = np.asarray(outline.exterior.coords, dtype=np.float64)[:-1]
    size = float(np.ptp(v, axis=0).max())
    v = v[np.hypot(*(np.roll(v, -1, axis=0) - v).T) > _REPEAT_TOL * size]
    v = _normalised(_drop_collinear(v), a, "path", os.fspath(path))
    params = (("path", os.fspath(path)), ("scale", float(scale)), ("radius", a))
    return _centred(v, a, "file", params)
