"""Host-side depths of overlap of rounded (spheropolygon) bodies at their initial pose [m]: points
inside bodies and body–body overlaps, checked by ``Scene.validate`` before any kernel runs."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import LineString, Point, Polygon

from .bodies import RigidBody

__all__ = ["Overlap", "body_overlaps", "core_geometry", "depth_inside", "overlap_tolerance"]

#: Allowed initial overlap of two bodies, as a fraction of the smaller one's bounding radius.
OVERLAP_FRACTION = 0.01
#: Contact forces in a resting pile spread to a few times their mean (force chains).
FORCE_CHAIN_FACTOR = 3.0


def core_geometry(body: RigidBody):
    """Shapely core of a rigid body at its initial position and angle (world frame) [m]: a point,
    a segment or a polygon, as ``Spheropolygon.to_shapely`` builds it before dilating."""
    v = body.world_vertices()
    return Point(v[0]) if len(v) == 1 else LineString(v) if len(v) == 2 else Polygon(v)


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


def overlap_tolerance(first: RigidBody, second: RigidBody, *, roundoff: float, gravity: float, height: float,
                      normal_stiffness: float) -> float:
    """The overlap [m] two bodies may start with: ``roundoff`` [m] (bodies built exactly touching)
    plus the larger of
    - 1 % of the smaller bounding radius (core radius + sphero radius): DEM contact stiffnesses
      are usually chosen to keep overlaps below about that;
    - the overlap of a contact in a resting pile, as a settled pack leaves it: the weight of a
      column of the denser free body's material as tall as the domain along gravity (``height``
      [m], g = ``gravity`` [m/s²]) and as wide as the smaller body, over k_n
      (``normal_stiffness`` [N/m per m]), times 3 for force chains.
    Deeper is a loaded spring that the first steps turn into speed, not a resting contact."""
    size = min(first.shape.bounding_radius, second.shape.bounding_radius)
    rho = max(b.density for b in (first, second) if b.motion == "free")
    pile = FORCE_CHAIN_FACTOR * rho * gravity * height * 2.0 * size / normal_stiffness
    return roundoff + max(OVERLAP_FRACTION * size, pile)


def body_overlaps(bodies: list[RigidBody]) -> list[Overlap]:
    """Every pair of bodies that touch at their initial pose and can interact (at least one of them
    free: fixed and kinematic bodies never meet each other), with its depth of overlap [m], deepest
    first. The depth is that of the DEM's contacts: a_i + a_j − the distance of the cores, or, when
    the cores cross, a_i + a_j + the deepest vertex of one core inside the other."""
    if len(bodies) < 2:
        return []
    cores = np.array([core_geometry(b) for b in bodies], dtype=object)
    radius = np.array([b.shape.radius for b in bodies])
    free = np.array([b.motion == "free" for b in bodies])
    i, j = shapely.STRtree(cores).query(cores, predicate="dwithin", distance=radius + radius.max())
    keep = (i < j) & (free[i] | free[j])
    i, j = i[keep], j[keep]
    if len(i) == 0:
        return []
    a = radius[i] + radius[j]
    depth = a - shapely.distance(cores[i], cores[j])
    crossed = np.flatnonzero(depth >= a)
    for k in crossed:  # crossing cores: the deepest vertex of either one inside the other
        for p, q in ((i[k], j[k]), (j[k], i[k])):
            v = shapely.points(bodies[p].world_vertices())
            d = depth_inside(np.full(len(v), cores[q], dtype=object), np.full(len(v), a[k]), v)
            depth[k] = max(depth[k], float(d.max()))
    order = np.argsort(-depth)
    return [Overlap(int(i[k]), int(j[k]), float(depth[k])) for k in order if depth[k] > 0.0]
