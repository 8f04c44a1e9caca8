"""Numpy columns of a list of rigid bodies at their initial pose (SI units).

The scene checks (``Scene.validate``, ``overlaps``) and the DEM upload read every body's core
vertices, radii and densities; for 10⁵–10⁶ bodies one Python call per body dominates the set-up.
``rigid_arrays`` reads each body's attributes once, computes the per-shape values once per distinct
shape (bodies often share a few shapes) and places every body's core vertices in one numpy
expression, the same floats as ``RigidBody.world_vertices`` (``spheropolygons.placed``).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import shapely

from .bodies import RigidBody
from .spheropolygons import placed

__all__ = ["RigidArrays", "ragged_rows", "rigid_arrays", "stacked"]


def ragged_rows(starts: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Rows starts[k], starts[k] + 1, ..., starts[k] + counts[k] − 1 of every k, one after the other."""
    counts = np.asarray(counts, dtype=np.intp)
    total = int(counts.sum())
    first = np.cumsum(counts) - counts  # where each run begins in the output
    return np.repeat(np.asarray(starts, dtype=np.intp) - first, counts) + np.arange(total)


@dataclass(frozen=True, eq=False)
class RigidArrays:
    """Per-body columns of n rigid bodies (list order) and their core vertices, body after body.

    Attributes:
        position: (n, 2) centroids [m].
        angle: (n,) initial angles [rad].
        radius: (n,) sphero radii a [m].
        core_radius: (n,) core radii max_k |V_k| [m].
        bounding_radius: (n,) core radius + a [m].
        density: (n,) ρ [kg/m³].
        area: (n,) areas of the rounded shapes [m²].
        second_moment: (n,) polar second moments of area about the centroid [m⁴].
        free, fixed: (n,) motion masks.
        counts: (n,) core vertices per body.
        starts: (n,) row of each body's first vertex in ``local`` and ``world``.
        local: (V, 2) core vertices in the body frames [m].
        world: (V, 2) core vertices at the initial position and angle [m].
        velocity: (n, 2) initial (free) or prescribed (kinematic) velocities [m/s].
        angular_velocity: (n,) initial or prescribed angular velocities [rad/s].
        friction: (n,) Coulomb coefficients μ.
        active: (n, 2) (t_start, t_end) [s] of the kinematic bodies' motion.
        grain: (n,) whether the body is a grain of a grain set (``Scene.add_grains``).
    """

    position: np.ndarray
    angle: np.ndarray
    radius: np.ndarray
    core_radius: np.ndarray
    bounding_radius: np.ndarray
    density: np.ndarray
    area: np.ndarray
    second_moment: np.ndarray
    free: np.ndarray
    fixed: np.ndarray
    counts: np.ndarray
    starts: np.ndarray
    local: np.ndarray
    world: np.ndarray
    velocity: np.ndarray
    angular_velocity: np.ndarray
    friction: np.ndarray
    active: np.ndarray
    grain: np.ndarray

    def __len__(self) -> int:
        return len(self.counts)

    @property
    def mass(self) -> np.ndarray:
        """(n,) masses per unit thickness ρA [kg/m] (``Spheropolygon.mass_properties``)."""
        return self.density * self.area

    @property
    def inertia(self) -> np.ndarray:
        """(n,) moments of inertia about the centroids per unit thickness ρJ [kg m²/m]."""
        return self.density * self.second_moment

    def take(self, index: np.ndarray) -> RigidArrays:
        """The columns of bodies ``index``, in that order (their vertices too)."""
        index = np.asarray(index, dtype=np.intp)
        counts = self.counts[index]
        rows = ragged_rows(self.starts[index], counts)
        return RigidArrays(
            position=self.position[index], angle=self.angle[index], radius=self.radius[index],
            core_radius=self.core_radius[index], bounding_radius=self.bounding_radius[index],
            density=self.density[index], area=self.area[index], second_moment=self.second_moment[index],
            free=self.free[index], fixed=self.fixed[index], counts=counts, starts=np.cumsum(counts) - counts,
            local=self.local[rows], world=self.world[rows], velocity=self.velocity[index],
            angular_velocity=self.angular_velocity[index], friction=self.friction[index], active=self.active[index],
            grain=self.grain[index])

    def world_vertices(self, index: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(core vertices [m] of bodies ``index``, one body after the other; for each vertex, its
        position in ``index``)."""
        index = np.asarray(index, dtype=np.intp)
        which = np.repeat(np.arange(len(index)), self.counts[index])
        return self.world[ragged_rows(self.starts[index], self.counts[index])], which

    @cached_property
    def cores(self) -> np.ndarray:
        """(n,) shapely cores at the initial pose [m]: a point (one vertex), a segment (two) or a
        polygon, as ``Spheropolygon.to_shapely`` builds it before dilating."""
        cores = np.empty(len(self), dtype=object)
        for k in np.unique(self.counts):
            sel = np.flatnonzero(self.counts == k)
            v = self.world[self.starts[sel, None] + np.arange(k)]
            cores[sel] = (shapely.points(v[:, 0]) if k == 1 else shapely.linestrings(v) if k == 2
                          else shapely.polygons(v))
        return cores


def rigid_arrays(bodies: list[RigidBody]) -> RigidArrays:
    """The columns of ``bodies``: per-shape values once per distinct shape object, every body's
    world vertices in one expression (``spheropolygons.placed``)."""
    index: dict = {}
    shape_of = np.array([index.setdefault(b.shape, len(index)) for b in bodies], dtype=np.intp)
    shapes = list(index)
    n_vertices = np.array([len(s.vertices) for s in shapes], dtype=np.intp)
    shape_starts = np.cumsum(n_vertices) - n_vertices
    shape_vertices = np.concatenate([s.vertices for s in shapes]) if shapes else np.zeros((0, 2))

    def per_shape(values) -> np.ndarray:
        return np.array(values, dtype=np.float64)[shape_of]

    counts = n_vertices[shape_of]
    starts = np.cumsum(counts) - counts
    owner = np.repeat(np.arange(len(bodies)), counts)
    local = shape_vertices[ragged_rows(shape_starts[shape_of], counts)]
    position = np.array([b.position for b in bodies], dtype=np.float64).reshape(-1, 2)
    angle = np.array([b.angle for b in bodies], dtype=np.float64)
    cos = np.array([math.cos(t) for t in angle.tolist()])
    sin = np.array([math.sin(t) for t in angle.tolist()])
    world = placed(local[:, None, :], cos[owner], sin[owner], position[owner])[:, 0]
    motion = np.array([b.motion for b in bodies], dtype=object)
    return RigidArrays(
        position=position, angle=angle, radius=per_shape([s.radius for s in shapes]),
        core_radius=per_shape([s.core_radius for s in shapes]),
        bounding_radius=per_shape([s.bounding_radius for s in shapes]),
        density=np.array([b.density for b in bodies], dtype=np.float64),
        area=per_shape([s.area for s in shapes]), second_moment=per_shape([s.second_moment for s in shapes]),
        free=motion == "free", fixed=motion == "fixed", counts=counts, starts=starts, local=local, world=world,
        velocity=np.array([b.velocity for b in bodies], dtype=np.float64).reshape(-1, 2),
        angular_velocity=np.array([b.angular_velocity for b in bodies], dtype=np.float64),
        friction=np.array([b.friction for b in bodies], dtype=np.float64),
        active=np.array([b.active for b in bodies], dtype=np.float64).reshape(-1, 2),
        grain=np.zeros(len(bodies), dtype=bool))


def stacked(parts: list[RigidArrays]) -> RigidArrays:
    """The columns of several sets of bodies, one set after the other (vertex rows renumbered)."""
    if len(parts) == 1:
        return parts[0]
    counts = np.concatenate([p.counts for p in parts])
    columns = {f.name: np.concatenate([getattr(p, f.name) for p in parts]) for f in dataclasses.fields(RigidArrays)
               if f.name not in ("counts", "starts")}
    return RigidArrays(counts=counts, starts=np.cumsum(counts) - counts, **columns)
