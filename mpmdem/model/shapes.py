"""Host-side geometry of MPM bodies and seeding of material points (SI units: metres).

Shapes are shapely polygons; a disk also keeps its exact centre and radius so that seeding tests
``|p - c| < r`` rather than the polygonal approximation. No Warp here: pure numpy + shapely.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np
import shapely
from shapely import affinity
from shapely.geometry import Polygon
from shapely.geometry.polygon import orient
from shapely.validation import explain_validity

from ..checks import finite
from ..errors import InputError

__all__ = ["SEEDINGS", "SeededPoints", "Shape", "disk", "from_file", "polygon", "rectangle", "seed_points"]

#: Point volumes of ``seed_points``: "clipped" (each point the part of its sub-cell inside the shape,
#: so the volumes sum to the shape's area) or "full" (every point a whole sub-cell, the staircase).
SEEDINGS = ("clipped", "full")

#: Sub-grid points evaluated per chunk while seeding (bounds memory for large bodies).
_CHUNK = 1 << 22


@dataclass(frozen=True)
class Shape:
    """A 2D region filled with material points.

    Attributes:
        polygon: the outline [m] (for a disk, an inscribed regular polygon used for display only).
        kind: "rectangle", "disk", "polygon" or "file".
        params: the constructor's parameters, as (name, value) pairs of JSON-serialisable values.
    """

    polygon: Polygon
    kind: str = "polygon"
    params: tuple[tuple[str, object], ...] = ()

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) [m]; exact for a disk."""
        if self.kind == "disk":
            (cx, cy), r = self._circle()
            return cx - r, cy - r, cx + r, cy + r
        return tuple(float(b) for b in self.polygon.bounds)

    @property
    def area(self) -> float:
        """Area [m²]; exact (πr²) for a disk."""
        return math.pi * self._circle()[1] ** 2 if self.kind == "disk" else float(self.polygon.area)

    def contains(self, points: np.ndarray) -> np.ndarray:
        """Which points lie strictly inside the shape.

        Args:
            points: (N, 2) coordinates [m].

        Returns:
            (N,) bool array; for a disk the exact test ``|p - c| < r``.
        """
        p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        if self.kind == "disk":
            (cx, cy), r = self._circle()
            return (p[:, 0] - cx) ** 2 + (p[:, 1] - cy) ** 2 < r * r
        return shapely.contains_xy(self.polygon, p[:, 0], p[:, 1])

    def to_dict(self) -> dict:
        """JSON-serialisable description: kind, parameters and the outline's vertices [m]."""
        d: dict = {"kind": self.kind, **{k: list(v) if isinstance(v, tuple) else v for k, v in self.params}}
        if self.kind in ("polygon", "file"):
            d["vertices"] = [list(c) for c in self.polygon.exterior.coords[:-1]]
            if self.polygon.interiors:
                d["holes"] = [[list(c) for c in ring.coords[:-1]] for ring in self.polygon.interiors]
        return d

    def _circle(self) -> tuple[tuple[float, float], float]:
        p = dict(self.params)
        return tuple(p["center"]), p["radius"]


def _summary(arr: np.ndarray) -> str:
    pts = [tuple(float(c) for c in row) for row in arr[:4]]
    return f"{len(arr)} vertices {pts}{' ...' if len(arr) > 4 else ''}"


def rectangle(x0: float, y0: float, x1: float, y1: float) -> Shape:
    """Axis-aligned rectangle from its lower-left (x0, y0) to its upper-right (x1, y1) corner [m]."""
    x0, y0, x1, y1 = (finite(n, v) for n, v in zip(("x0", "y0", "x1", "y1"), (x0, y0, x1, y1), strict=False))
    if not x1 > x0:
        raise InputError("x1", x1, f"greater than x0={x0} (upper-right corner) [m]")
    if not y1 > y0:
        raise InputError("y1", y1, f"greater than y0={y0} (upper-right corner) [m]")
    return Shape(shapely.box(x0, y0, x1, y1), "rectangle", (("corners", (x0, y0, x1, y1)),))


def disk(center: tuple[float, float] = (0.0, 0.0), radius: float = 1.0, segments: int = 128) -> Shape:
    """Disk of centre ``center`` [m] and radius ``radius`` [m].

    Seeding uses the exact circle; ``segments`` only sets the vertex count of the display outline.
    """
    c = np.asarray(center, dtype=np.float64).ravel()
    if c.shape != (2,) or not np.isfinite(c).all():
        raise InputError("center", center, "a finite (cx, cy) [m]")
    r = finite("radius", radius)
    if r <= 0.0:
        raise InputError("radius", radius, "a positive number [m]")
    if not isinstance(segments, (int, np.integer)) or isinstance(segments, bool) or segments < 8:
        raise InputError("segments", segments, "an integer >= 8")
    t = 2.0 * np.pi * np.arange(segments) / segments
    outline = Polygon(np.column_stack([c[0] + r * np.cos(t), c[1] + r * np.sin(t)]))
    params = (("center", (float(c[0]), float(c[1]))), ("radius", r), ("segments", int(segments)))
    return Shape(outline, "disk", params)


def _checked_polygon(poly: Polygon, name: str, value: object) -> Polygon:
    minx, miny, maxx, maxy = poly.bounds
    if not poly.convex_hull.area > 1e-12 * ((maxx - minx) ** 2 + (maxy - miny) ** 2):
        raise InputError(name, value, "an outline enclosing a non-zero area (these are collinear)")
    if not poly.is_valid:
        raise InputError(name, value, f"a simple, non-self-intersecting outline ({explain_validity(poly)})")
    return orient(poly)


def polygon(vertices) -> Shape:
    """Simple polygon from its vertices [(x, y), ...] (in m), in either orientation, unclosed or closed."""
    v = np.asarray(vertices, dtype=np.float64)
    if v.ndim != 2 or v.shape[1] != 2 or not np.isfinite(v).all():
        raise InputError("vertices", vertices, "a list of finite (x, y) pairs [m]")
    if len(v) > 1 and np.array_equal(v[0], v[-1]):
        v = v[:-1]
    if len(v) < 3:
        raise InputError("vertices", _summary(v), "at least 3 distinct vertices")
    return Shape(_checked_polygon(Polygon(v), "vertices", _summary(v)), "polygon")


#: What ``from_file`` needs beyond trimesh: the optional dependencies of the extra ``mpmdem[svg]``.
SVG_PACKAGES = ("lxml", "networkx", "rtree", "svg.path")


def from_file(path: str | os.PathLike, *, scale: float = 1.0) -> Shape:
    """Outline imported from an SVG or DXF file: the largest closed polygon, holes included.

    Coordinates are taken as stored in the file (no y flip for SVG) and multiplied by ``scale``
    [m per file unit]. Needs trimesh with lxml, svg.path (SVG), networkx and rtree: the extra
    ``pip install "mpmdem[svg]"``.

    Raises:
        ImportError: one of those packages is missing (the message names the extra).
    """
    import trimesh

    s = finite("scale", scale)
    if s <= 0.0:
        raise InputError("scale", scale, "a positive number [m per file unit]")
    if not os.path.isfile(path):
        raise InputError("path", str(path), "an existing SVG or DXF file")
    try:
        loaded = trimesh.load_path(os.fspath(path))
        polys = [p for p in loaded.polygons_full if p is not None and p.area > 0.0]
    except ImportError as exc:
        raise ImportError(f"from_file needs the optional packages {', '.join(SVG_PACKAGES)}: "
                          f'pip install "mpmdem[svg]" ({exc})') from exc
    except Exception as exc:  # trimesh raises assorted errors on unreadable files
        raise InputError("path", str(path), f"a readable SVG or DXF outline ({exc})") from exc
    if not polys:
        raise InputError("path", str(path), "a file containing at least one closed outline")
    poly = affinity.scale(max(polys, key=lambda p: p.area), s, s, origin=(0.0, 0.0))
    poly = _checked_polygon(poly, "path", str(path))
    return Shape(poly, "file", (("path", os.fspath(path)), ("scale", s)))


@dataclass
class SeededPoints:
    """Material points of one body.

    Attributes:
        positions: (N, 2) coordinates [m], float64.
        volumes: (N,) initial volumes (areas per unit thickness) [m²]: (h/n)², or less (more) for
            points on the outline with the "clipped" seeding (``seed_points``).
        half_sizes: (N, 2) GIMP half-lengths [m], each h/(2n).
    """

    positions: np.ndarray
    volumes: np.ndarray
    half_sizes: np.ndarray

    def __len__(self) -> int:
        return len(self.volumes)


def _circle_cap(x0, x1, h, r):
    """Area [m²] of the disk |p| < r above the line y = h >= 0, between x = x0 and x1 (x0 <= x1)."""
    s = np.sqrt(np.maximum(r * r - h * h, 0.0))

    def g(x):  # ∫ (sqrt(r² - x²) - h) dx
        root = np.sqrt(np.maximum(r * r - x * x, 0.0))
        return 0.5 * (x * root + r * r * np.arcsin(np.clip(x / r, -1.0, 1.0))) - h * x

    return g(np.clip(x1, -s, s)) - g(np.clip(x0, -s, s))


def _circle_box_area(lo: np.ndarray, hi: np.ndarray, r: float) -> np.ndarray:
    """Exact area [m²] of the disk |p| < r inside each box lo < p < hi ((N, 2) corners [m])."""
    x0, x1 = lo[:, 0], hi[:, 0]

    def above(y):  # area of the disk above y, between x0 and x1 (the disk is symmetric in y)
        strip = 2.0 * _circle_cap(x0, x1, 0.0, r)
        return np.where(y >= 0.0, _circle_cap(x0, x1, np.abs(y), r), strip - _circle_cap(x0, x1, np.abs(y), r))

    return above(lo[:, 1]) - above(hi[:, 1])


def _clipped_areas(shape: Shape, centres: np.ndarray, s: float) -> np.ndarray:
    """Area [m²] of each square sub-cell of edge s centred at ``centres`` (N, 2) inside the shape;
    exact for a disk (the circle, not its outline polygon) and to round-off for polygons."""
    if shape.kind == "disk":
        c, r = shape._circle()
        return _circle_box_area(centres - c - 0.5 * s, centres - c + 0.5 * s, r)
    boxes = shapely.box(centres[:, 0] - 0.5 * s, centres[:, 1] - 0.5 * s, centres[:, 0] + 0.5 * s,
                        centres[:, 1] + 0.5 * s)
    return shapely.area(shapely.intersection(boxes, shape.polygon))


def _cut(shape: Shape, p: np.ndarray, s: float) -> np.ndarray:
    """Which sub-cells of edge s centred at p (N, 2) the outline may cross (closer than s/√2)."""
    reach = s * (0.5 * math.sqrt(2.0) + 1e-9)
    if shape.kind == "disk":
        c, r = shape._circle()
        return np.abs(np.hypot(p[:, 0] - c[0], p[:, 1] - c[1]) - r) < reach
    return shapely.dwithin(shape.polygon.boundary, shapely.points(p), reach)


def seed_points(
    shape: Shape, *, cell_size: float, points_per_cell: int, origin: tuple[float, float] = (0.0, 0.0),
    seeding: str = "clipped",
) -> SeededPoints:
    """Fill ``shape`` with points at the sub-cell centres of the background grid.

    Grid nodes are at origin + (i h, j h); every cell holds n × n points at
    x = origin_x + (i + (a + 0.5)/n) h, a = 0..n-1 (same in y). A point is kept where
    ``shape.contains`` holds. Only the cells covering the shape's bounds are visited.

    Volumes: with ``seeding="clipped"`` (default) a point's volume is the area of its sub-cell
    inside the shape, and a sub-cell the outline crosses whose centre lies outside (so it has no
    point) gives its part inside to the nearest point: the volumes sum to the shape's area to
    round-off (exact circle for a disk), so mass, weight and energy are the shape's at any
    resolution. ``"full"`` gives every point its whole sub-cell, (h/n)² (the staircase outline:
    the total is off by up to a sub-cell per boundary cell, +1 % for a disk of 20 cells radius).

    Args:
        shape: the region to fill.
        cell_size: grid spacing h [m], > 0.
        points_per_cell: n, points per cell per direction, an integer in 1..8.
        origin: grid node (0, 0) [m].
        seeding: "clipped" or "full" (the volumes, above).

    Returns:
        The seeded points with their volumes [m²] and half-lengths h/(2n) [m] (the GIMP domain
        stays the whole sub-cell).
    """
    h = finite("cell_size", cell_size)
    if h <= 0.0:
        raise InputError("cell_size", cell_size, "a positive grid spacing [m]")
    n = points_per_cell
    if not isinstance(n, (int, np.integer)) or isinstance(n, bool) or not 1 <= n <= 8:
        raise InputError("points_per_cell", n, "an integer in 1..8 (points per cell per direction)")
    if seeding not in SEEDINGS:
        raise InputError("seeding", seeding, " or ".join(repr(k) for k in SEEDINGS))
    o = np.asarray(origin, dtype=np.float64).ravel()
    if o.shape != (2,) or not np.isfinite(o).all():
        raise InputError("origin", origin, "a finite (x, y) [m]")
    s = h / n
    sub = (np.arange(n) + 0.5) / n
    axes = []
    for lo, hi, o_k in ((shape.bounds[0], shape.bounds[2], o[0]), (shape.bounds[1], shape.bounds[3], o[1])):
        cells = np.arange(math.floor((lo - o_k) / h), math.ceil((hi - o_k) / h))
        axes.append(o_k + (cells[:, None] + sub[None, :]).ravel() * h)
    xs, ys = axes
    rows = max(1, _CHUNK // max(1, len(xs)))
    kept, vols, orphans, orphan_areas = [], [], [], []
    for j in range(0, len(ys), rows):
        gx, gy = np.meshgrid(xs, ys[j:j + rows])
        p = np.column_stack([gx.ravel(), gy.ravel()])
        inside = shape.contains(p)
        vol = np.full(len(p), s * s)
        if seeding == "clipped":
            cut = _cut(shape, p, s)
            area = _clipped_areas(shape, p[cut], s)
            # round-off of an outline along sub-cell edges: whole or empty sub-cells stay exact
            area[area > s * s * (1.0 - 1e-12)] = s * s
            area[area < s * s * 1e-12] = 0.0
            vol[cut] = area
            lost = cut & ~inside & (vol > 0.0)
            orphans.append(p[lost])
            orphan_areas.append(vol[lost])
        kept.append(p[inside])
        vols.append(vol[inside])
    pos = np.concatenate(kept) if kept else np.empty((0, 2))
    if len(pos) == 0:
        raise InputError("shape", shape.to_dict(), "a shape holding at least one sub-cell centre "
                         f"(shape smaller than a sub-cell of {s:g} m)")
    volumes = np.concatenate(vols)
    if orphans and sum(len(q) for q in orphans):
        q = np.concatenate(orphans)
        _, nearest = shapely.STRtree(shapely.points(pos)).query_nearest(shapely.points(q), all_matches=False)
        np.add.at(volumes, nearest, np.concatenate(orphan_areas))
    m = len(pos)
    return SeededPoints(pos, volumes, np.full((m, 2), 0.5 * s))
