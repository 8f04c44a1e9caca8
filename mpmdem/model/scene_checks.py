"""The whole-scene checks of ``Scene`` (a mixin): no material point inside a rigid body, no rigid
bodies or grains starting inside each other beyond a tolerance, grains clear of fixed bodies. They run
in ``Scene.validate``, before any kernel; each raises InputError naming what is wrong."""

from __future__ import annotations

import math

import numpy as np
import shapely

from ..errors import InputError
from .grains import GrainSet
from .overlaps import depth_inside, overlap_pairs, overlap_tolerance
from .rigid_arrays import RigidArrays, stacked

__all__ = ["SceneChecks"]


class SceneChecks:
    """Methods of ``Scene`` that check the scene as a whole (see ``validate``)."""

    def _check_grains_clear(self, grains: GrainSet) -> None:
        """InputError when a new grain overlaps a body already in the scene (walls, fixed, free or
        kinematic bodies, earlier grains) by more than ``validate`` lets bodies start overlapping
        (``overlaps.overlap_tolerance``: a settled pack rests on its walls): the depth is a + the
        grain's sphero radius − the distance of the two cores (a polygon grain's own core)."""
        if not (self.rigid_bodies or self.grains):
            return
        arrays = self.body_arrays()
        cores = arrays.cores
        points = shapely.points(grains.position)
        reach = grains.bounding_radius
        i, j = shapely.STRtree(cores).query(points, predicate="dwithin", distance=reach + arrays.radius.max())
        if not len(i):
            return
        own = grains.rigid_arrays()
        grain_cores = own.take(np.unique(i)).cores if grains.local.shape[1] > 1 else None
        if grain_cores is None:  # disks: the core is the centre
            distance = shapely.distance(cores[j], points[i])
        else:
            distance = shapely.distance(cores[j], grain_cores[np.searchsorted(np.unique(i), i)])
        depth = arrays.radius[j] + grains.radius[i] - distance
        hit = depth > self._overlap_tolerance(stacked([arrays, own]), j, len(arrays) + i)
        if not hit.any():
            return
        bodies = np.unique(j[hit])
        first = int(bodies[0])
        raise InputError("region", f"{len(np.unique(i[hit]))} grains overlapping {self.body_name(first)!r}"
                         + (f" and {len(bodies) - 1} more bodies" if len(bodies) > 1 else ""),
                         "a region clear of the bodies already in the scene (walls, fixed bodies, earlier grains): "
                         "grains would start inside them; draw the region inside the walls")

    def validate(self, *, arrays: RigidArrays | None = None, particles: dict | None = None
                 ) -> list[tuple[str, str, float]]:
        """Checks that need the whole scene (bodies may be added in any order); ``finalize`` runs
        them before any kernel. Raises InputError. Returns ``initial_overlaps()``, computed on the
        way (the finished model hands them to the DEM stage). ``arrays`` (``body_arrays()``) and
        ``particles`` (``particles()``): what ``finalize`` built already, else built here.

        Material points must not start inside a rigid body (free, fixed, kinematic or a wall):
        a point is inside when its centre lies strictly inside the rounded body (core polygon
        dilated by the sphero radius a), deeper than a round-off tolerance of 1e-9 × the domain
        size. A point may touch a body or overlap it with its contact radius r_p (a point
        resting on a body does), but not sit in it. Points released later (``add_points``'
        release_time > 0) are checked against the fixed bodies only: the others will have moved.
        The error names the first rigid body (scene order) with points inside, how many, and
        the total.

        Rigid bodies must not start overlapping each other (pairs that can meet: one of them free)
        by more than ``overlaps.overlap_tolerance``: round-off plus the larger of 1 % of the smaller
        body's bounding radius and 3 × the overlap k_n gives under the weight of a column as tall as
        the domain (bodies built exactly touching, or resting as a settled pack leaves them, pass). The error
        names the deepest pair and its overlap; ``Scene(allow_initial_overlap=True)`` lets a
        deliberately pre-stressed pack through.
        """
        self._check_periodic_alone()
        arrays = self.body_arrays() if arrays is None else arrays
        overlaps = self._initial_overlaps(arrays)
        if not self.allow_initial_overlap:
            self._check_initial_overlaps(*overlaps)
        self._check_points_outside_bodies(arrays, particles)
        return self._named(*overlaps[:3])

    def _check_periodic_alone(self) -> None:
        """``validate``'s check that a periodic scene is MPM bodies alone or DEM bodies alone: the DEM
        stage knows the periodic image (``kernels.dem_period``), the coupling and the obstacle
        nodes do not."""
        found = [name for name, items in (("rigid bodies", self.rigid_bodies and self.bodies),
                                          ("grains", self.grains and self.bodies), ("obstacles", self.obstacles))
                 if items]
        if self.periodic_x and found:
            raise InputError("boundaries", "periodic", f"MPM bodies alone or rigid bodies and grains alone: periodic "
                             f"x has no {found[0]} beside material points (the coupling and obstacles know no "
                             "periodic image)")

    def _check_points_outside_bodies(self, arrays: RigidArrays, particles: dict | None = None) -> None:
        """``validate``'s check that no material point starts inside a rigid body (``particles``:
        ``particles()`` when the caller has them)."""
        if not (self.bodies and (self.rigid_bodies or self.grains)):
            return
        particles = self.particles() if particles is None else particles
        x, owner, released = particles["x"], particles["body"], particles["release"] > 0.0
        cores, radius = arrays.cores, arrays.radius
        points = shapely.points(x)
        # candidates: points within a of the core (closed); the exact depth below decides
        j, i = shapely.STRtree(points).query(cores, predicate="dwithin", distance=radius)
        if len(j) == 0:
            return
        keep = ~released[i] | arrays.fixed[j]
        j, i = j[keep], i[keep]
        depth = depth_inside(cores[j], radius[j], points[i])
        inside = depth > self._roundoff
        if not inside.any():
            return
        j, i = j[inside], i[inside]
        per_body = np.bincount(j, minlength=len(arrays))
        first = int(np.flatnonzero(per_body)[0])
        body_name, body_position = self.body_name(first), tuple(arrays.position[first].tolist())
        owners = np.unique(owner[i[j == first]])
        mpm = ("MPM body " if len(owners) == 1 else "MPM bodies ") + ", ".join(
            repr(self.bodies[k].name) for k in owners)
        count, total, hit = int(per_body[first]), len(np.unique(i)), int(np.count_nonzero(per_body))

        def n_points(n: int) -> str:
            return f"{n} point{'' if n == 1 else 's'}"

        raise InputError(f"rigid body {body_name!r}", body_position,
                         f"a body with no material point starting inside it; {n_points(count)} of {mpm} start "
                         f"inside it ({n_points(total)} start inside {hit} rigid bod{'y' if hit == 1 else 'ies'} in "
                         "all). Move the points or the bodies apart: points may touch a body (overlap it by up to "
                         "their contact radius), not start inside it")

    @property
    def _roundoff(self) -> float:
        """A length [m] below round-off of the scene's coordinates: 1e-9 × the domain size."""
        (x0, y0), (x1, y1) = self.domain
        return 1e-9 * max(x1 - x0, y1 - y0)

    def _initial_overlaps(self, arrays: RigidArrays) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(i, j, depth [m], allowed overlap [m]) of the pairs of rigid bodies (``arrays`` of
        ``rigid_bodies``) that can meet and start overlapping by more than
        ``overlaps.overlap_tolerance``, deepest first."""
        if self.contact is None:
            none = np.zeros(0, dtype=np.intp)
            return none, none, np.zeros(0), np.zeros(0)
        i, j, depth = overlap_pairs(arrays)
        tol = self._overlap_tolerance(arrays, i, j)
        deep = depth > tol
        return i[deep], j[deep], depth[deep], tol[deep]

    def _overlap_tolerance(self, arrays: RigidArrays, i: np.ndarray, j: np.ndarray) -> np.ndarray:
        """``overlaps.overlap_tolerance`` [m] of the pairs (i, j) of ``arrays`` in this scene: its
        round-off, its gravity and domain height along it, its k_n (none without a contact law)."""
        (x0, y0), (x1, y1) = self.domain
        gx, gy = self.gravity
        g = math.hypot(gx, gy)
        height = (abs(gx) * (x1 - x0) + abs(gy) * (y1 - y0)) / g if g > 0.0 else 0.0
        kn = self.contact.normal_stiffness if self.contact is not None else math.inf
        return overlap_tolerance(arrays, i, j, roundoff=self._roundoff, gravity=g, height=height, normal_stiffness=kn)

    def _named(self, i: np.ndarray, j: np.ndarray, depth: np.ndarray) -> list[tuple[str, str, float]]:
        """(body, body, depth [m]) of pairs of rigid bodies given by index."""
        return [(self.body_name(a), self.body_name(b), d) for a, b, d in zip(i.tolist(), j.tolist(), depth.tolist(),
                                                                              strict=True)]

    def initial_overlaps(self) -> list[tuple[str, str, float]]:
        """(body, body, depth [m]) of every pair of rigid bodies that can meet and start overlapping
        by more than they may (``validate``), deepest first."""
        return self._named(*self._initial_overlaps(self.body_arrays())[:3])

    def _check_initial_overlaps(self, i: np.ndarray, j: np.ndarray, depth: np.ndarray, tol: np.ndarray) -> None:
        """InputError naming the deepest of the pairs (``_initial_overlaps``) that start too deep."""
        if not len(i):
            return
        a, b = self.body_name(int(i[0])), self.body_name(int(j[0]))
        more = f" ({len(i)} pairs overlap in all)" if len(i) > 1 else ""
        raise InputError(f"rigid bodies {a!r} and {b!r}", f"overlapping by {float(depth[0]):.4g} m",
                         f"bodies that start apart or touching, overlapping by at most {float(tol[0]):.3g} m (the "
                         "larger of 1 % of the smaller body's size and 3 x the overlap under the weight of a column "
                         f"as tall as the domain){more}: the first steps would turn the overlap into speed. "
                         "Move them apart, or pass Scene(allow_initial_overlap=True) for a deliberately "
                         "pre-stressed pack")
