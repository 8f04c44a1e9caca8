"""Outlines of spheropolygon bodies in world coordinates: shapely shapes and fixed-size point rings [m]."""

from __future__ import annotations

import numpy as np

__all__ = ["body_outlines", "outline_rings", "place_rings"]


def body_outlines(geometry: dict, x: np.ndarray, angle: np.ndarray | None, quad_segs: int = 8) -> list:
    """Shapely outlines of spheropolygon bodies in world coordinates.

    Each body's core vertices (body frame) are rotated by its angle and translated to its centroid,
    then dilated by its radius: one vertex gives a disk, two a stadium, more a rounded polygon;
    radius 0 leaves the bare polygon (and nothing for one or two vertices).

    Args:
        geometry: ``RunFile.body_geometry()``: vertex_start, vertex_count, vertices [m], radius [m].
        x: Centroids, shape (M, 2) [m].
        angle: Rotations, shape (M,) [rad]; None for no rotation.
        quad_segs: Segments per quarter circle of the rounded corners.

    Returns:
        M shapely geometries (empty where the centroid or angle is not finite).
    """
    import shapely

    start = np.asarray(geometry["vertex_start"], dtype=np.int64)
    count = np.asarray(geometry["vertex_count"], dtype=np.int64)
    verts = np.asarray(geometry["vertices"], dtype=np.float64).reshape(-1, 2)
    radius = np.asarray(geometry["radius"], dtype=np.float64)
    m = len(count)
    x = np.asarray(x, dtype=np.float64).reshape(m, 2)
    theta = np.zeros(m) if angle is None else np.asarray(angle, dtype=np.float64).reshape(m)
    ok = np.isfinite(x).all(axis=1) & np.isfinite(theta)
    out = np.array([shapely.Polygon()] * m, dtype=object)
    # World coordinates of every core vertex, with its body index (sorted by body).
    body_of = np.repeat(np.arange(m), count)
    offset = np.arange(len(body_of)) - np.repeat(np.cumsum(count) - count, count)
    local = verts[np.repeat(start, count) + offset]
    c, s = np.cos(theta[body_of]), np.sin(theta[body_of])
    world = x[body_of] + np.stack([c * local[:, 0] - s * local[:, 1], s * local[:, 0] + c * local[:, 1]], axis=1)
    for kind in (1, 2, 3):
        sel = ok & ((count == kind) if kind < 3 else (count >= 3))
        if not sel.any():
            continue
        ids = np.flatnonzero(sel)
        vmask = sel[body_of]
        _, idx = np.unique(body_of[vmask], return_inverse=True)
        coords = world[vmask]
        if kind == 1:
            core = shapely.points(coords)
        elif kind == 2:
            core = shapely.linestrings(coords, indices=idx)
        else:
            core = shapely.polygons(shapely.linearrings(coords, indices=idx))
        a = radius[ids]
        dilated = np.where(a > 0, shapely.buffer(core, np.maximum(a, 0.0), quad_segs=quad_segs), core)
        if kind < 3:
            dilated = np.where(a > 0, dilated, shapely.Polygon())
        out[ids] = dilated
    return list(out)


def _subdivide(ring: np.ndarray, size: int) -> np.ndarray:
    """The closed ring (n, 2) with points added on its edges, in proportion to their length, to ``size`` points."""
    n = len(ring)
    extra = size - n
    if extra <= 0:
        return ring
    edge = np.roll(ring, -1, axis=0) - ring
    length = np.linalg.norm(edge, axis=1)
    share = extra * (length / length.sum() if length.sum() > 0 else np.full(n, 1.0 / n))
    per_edge = np.floor(share).astype(np.int64)
    per_edge[np.argsort(per_edge - share)[: extra - int(per_edge.sum())]] += 1
    pieces = []
    for p, e, c in zip(ring, edge, per_edge, strict=True):
        pieces.append(p + np.outer(np.arange(c + 1) / (c + 1), e))
    return np.concatenate(pieces)


def outline_rings(geometry: dict, quad_segs: int = 8) -> np.ndarray:
    """Every body's dilated outline in its body frame as a ring of the same number of points.

    The outline of ``body_outlines`` at the centroid, unrotated: its exterior's points
    counter-clockwise (the last not repeating the first); a body whose outline is empty (radius 0
    and one or two core vertices) gives its core vertices. Rings with fewer points than the
    longest get points added along their edges, so the shape is kept exactly.

    Args:
        geometry: ``RunFile.body_geometry()`` (vertex_start, vertex_count, vertices [m], radius [m]).
        quad_segs: Segments per quarter circle of the rounded corners.

    Returns:
        Array (M, K, 2) [m], K the most points of any outline.
    """
    m = len(geometry["vertex_count"])
    geoms = body_outlines(geometry, np.zeros((m, 2)), np.zeros(m), quad_segs=quad_segs)
    rings = []
    for i, g in enumerate(geoms):
        if g.is_empty:
            s = int(geometry["vertex_start"][i])
            ring = np.asarray(geometry["vertices"], dtype=np.float64)[s: s + int(geometry["vertex_count"][i])]
        else:
            polygon = max(getattr(g, "geoms", [g]), key=lambda p: p.area)
            ring = np.asarray(polygon.exterior.coords, dtype=np.float64)[:-1, :2]
        rings.append(ring)
    size = max((len(r) for r in rings), default=1)
    return np.stack([_subdivide(r, size) for r in rings]) if rings else np.zeros((0, 1, 2))


def place_rings(rings: np.ndarray, x: np.ndarray, angle: np.ndarray | None) -> np.ndarray:
    """Body-frame rings (M, K, 2) [m] rotated by ``angle`` (M,) [rad] and moved to the centroids ``x`` (M, 2) [m]."""
    m = len(rings)
    theta = np.zeros(m) if angle is None else np.asarray(angle, dtype=np.float64).reshape(m)
    c, s = np.cos(theta)[:, None], np.sin(theta)[:, None]
    x = np.asarray(x, dtype=np.float64).reshape(m, 1, 2)
    rx, ry = rings[..., 0], rings[..., 1]
    return np.stack([c * rx - s * ry, s * rx + c * ry], axis=-1) + x
