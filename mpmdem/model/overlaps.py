"""Host-side depths of overlap of rounded (spheropolygon) bodies at their initial pose [m]: points
inside bodies and body–body overlaps, checked by ``Scene.validate`` before any kernel runs."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

from .bodies import RigidBody
from .rigid_arrays import RigidArrays, rigid_arrays

__all__ = ["Overlap", "body_overlaps", "depth_inside", "overlap_pairs", "overlap_tolerance", "pairs_within"]

#: Allowed initial overlap of two bodies, as a fraction of the smaller one's bounding radius.
OVERLAP_FRACTION = 0.01
#: Contact forces in a resting pile spread to a few times their mean (force chains).
FORCE_CHAIN_FACTOR = 3.0


def depth_inside(cores: np.ndarray, radius: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Depth [m] of each point inside the rounded body (core dilated by ``radius`` [m]) it is paired
    with: radius − distance to the core outside it, radius + distance to the outline inside a
    polygon core; negative when the point lies outside. Arrays of equal length (shapely objects)."""
    dist = shapely.distance(cores, points)
    polygon = shapely.get_type_id(cores) == shapely.GeometryType.POLYGON
    inner = np.zeros(len(cores))
    sel = polygon & (dist == 0.0)
    inner[sel] = shapely.distance(shapely.boundary(cores[sel]), points[sel])
    return radius + np.where(dist > 0.0, -dist, inner)


@dataclass(frozen=True)
class Overlap:
    """Two rigid bodies (scene indices i < j) that overlap by ``depth`` [m] at the start."""

    i: int
    j: int
    depth: float


def overlap_tolerance(arrays: RigidArrays, i, j, *, roundoff: float, gravity: float, height: float,
                      normal_stiffness: float) -> np.ndarray:
    """The overlap [m] bodies i and j (indices, or arrays of them, into ``arrays``) may start with:
    ``roundoff`` [m] (bodies built exactly touching) plus the larger of
    - 1 % of the smaller bounding radius (core radius + sphero radius): DEM contact stiffnesses
      are usually chosen to keep overlaps below about that;
    - the overlap of a contact in a resting pile, as a settled pack leaves it: the weight of a
      column of the denser free body's material as tall as the domain along gravity (``height``
      [m], g = ``gravity`` [m/s²]) and as wide as the smaller body, over k_n
      (``normal_stiffness`` [N/m per m]), times 3 for force chains.
    Deeper is a loaded spring that the first steps turn into speed, not a resting contact. At least
    one body of each pair must be free (only such pairs meet)."""
    size = np.minimum(arrays.bounding_radius[i], arrays.bounding_radius[j])
    rho = np.maximum(np.where(arrays.free[i], arrays.density[i], -np.inf),
                     np.where(arrays.free[j], arrays.density[j], -np.inf))
    pile = FORCE_CHAIN_FACTOR * rho * gravity * height * 2.0 * size / normal_stiffness
    return roundoff + np.maximum(OVERLAP_FRACTION * size, pile)


def pairs_within(arrays: RigidArrays, reach: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(i, j, distance of the cores [m]) of the pairs of bodies i < j, at least one of them free,
    whose cores lie within ``reach[i]`` [m] of each other, in the order of
    ``STRtree.query(cores, predicate="dwithin", distance=reach)``: by i, then in the tree's order.

    Only pairs whose envelopes (body i's grown by reach[i], an STRtree query, which lists them in
    the tree's order whatever the query boxes) and bounding circles (core radii + reach[i], with a
    round-off margin) come that close are measured, once per pair: fewer distances than the query,
    which measures every pair its grown envelopes let through, both ways."""
    cores, free = arrays.cores, arrays.free
    x0, y0, x1, y1 = shapely.bounds(cores).T
    i, j = shapely.STRtree(cores).query(shapely.box(x0 - reach, y0 - reach, x1 + reach, y1 + reach))
    keep = (i < j) & (free[i] | free[j])
    i, j = i[keep], j[keep]
    p, r = arrays.position, arrays.core_radius
    gap = np.hypot(*(p[i] - p[j]).T) - (r[i] + r[j] + reach[i])
    margin = 1e-9 * (np.abs(p[i]).sum(1) + np.abs(p[j]).sum(1) + r[i] + r[j] + reach[i])
    keep = gap <= margin
    i, j = i[keep], j[keep]
    dist = shapely.distance(cores[i], cores[j])
    near = dist <= reach[i]
    return i[near], j[near], dist[near]


def overlap_pairs(arrays: RigidArrays) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(i, j, depth [m]) of every pair of bodies i < j that touch at their initial pose and can
    interact (at least one of them free: fixed and kinematic bodies never meet each other), deepest
    first. The depth is that of the DEM's contacts: a_i + a_j − the distance of the cores, or, when
    the cores cross, a_i + a_j + the deepest vertex of one core inside the other."""
    none = np.zeros(0, dtype=np.intp)
    if len(arrays) < 2:
        return none, none, np.zeros(0)
    cores, radius = arrays.cores, arrays.radius
    # body i touches no core farther than a_i + max a from its own
    i, j, dist = pairs_within(arrays, radius + radius.max())
    if len(i) == 0:
        return none, none, np.zeros(0)
    a = radius[i] + radius[j]
    depth = a - dist
    crossed = np.flatnonzero(depth >= a)
    if len(crossed):  # crossing cores: the deepest vertex of either one inside the other
        pair = np.concatenate([crossed, crossed])
        inner, outer = np.concatenate([i[crossed], j[crossed]]), np.concatenate([j[crossed], i[crossed]])
        v, which = arrays.world_vertices(inner)
        d = depth_inside(cores[outer[which]], a[pair[which]], shapely.points(v))
        np.maximum.at(depth, pair[which], d)
    order = np.argsort(-depth)
    order = order[depth[order] > 0.0]
    return i[order], j[order], depth[order]


def body_overlaps(bodies: list[RigidBody]) -> list[Overlap]:
    """Every pair of bodies that touch at their initial pose and can interact, with its depth of
    overlap [m], deepest first (``overlap_pairs``)."""
    i, j, depth = overlap_pairs(rigid_arrays(bodies))
    return [Overlap(a, b, d) for a, b, d in zip(i.tolist(), j.tolist(), depth.tolist(), strict=True)]
