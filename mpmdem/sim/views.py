"""What the coupled stage sees of the MPM and DEM stages: frozen views naming exactly the arrays
and sizes it reads or writes (``mpmdem.sim.coupling``).

The MPM stage builds its ``PointsView`` and ``GridView`` once (``MPMSolver.points_view``,
``grid_view``); the ``BodiesView`` of the DEM stage is built once from it by the coupled stage
(``coupling.bodies_view``), which keeps this module free of the stages' imports. The views
hold the stages' device arrays and structs themselves (never copies), allocated once and never
replaced, so a view stays valid for the run; the coupling calls the stages only for their steps and
their status and output.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import warp as wp

from ..kernels.types import ScalarTypes
from ..model.rigid_arrays import RigidArrays

__all__ = ["BodiesView", "GridView", "PointsView"]


@dataclass(frozen=True)
class PointsView:
    """The material points as the coupling sees them (device order).

    Attributes:
        struct: the ``Particles`` struct the coupling kernels take (``P``): they read x, v, mass,
            the release times of staged points, and add the contact force to ``fcont``.
        count: number of points.
        mass: [kg/m] each point's mass (the contact step bound takes the smallest).
        vol: [m²] each point's volume at the start (the bins' capacity takes the smallest).
        fcont: [N/m] each point's contact force (written by the IMP force kernel; checkpointed).
        contact_radius: [m] host copy of each point's contact radius.
        contact_at: [m] where each point's contact force acts (the "grid" scheme spreads it from
            there; one element outside coupled scenes).
        staged: some points are released later (the kernels' ``staged`` variant).
        types: the Warp scalar and vector types of the precision.
    """

    struct: object
    count: int
    mass: wp.array
    vol: wp.array
    fcont: wp.array
    contact_radius: np.ndarray
    contact_at: wp.array
    staged: bool
    types: ScalarTypes


@dataclass(frozen=True)
class GridView:
    """The MPM background grid as the coupling sees it.

    Attributes:
        struct: the ``Grid`` struct (``G``): Liu et al.'s exchange reads and corrects its nodal
            velocities.
        domain: the ``Domain`` struct (``D``): origin, cell size, layers.
        shape: (rows, columns) of the nodes of one layer.
        origin: [m] the grid's origin (``Domain.origin``).
        cell_size: [m] h.
    """

    struct: object
    domain: object
    shape: tuple[int, int]
    origin: object
    cell_size: float


@dataclass(frozen=True)
class BodiesView:
    """The rigid bodies as the coupling sees them (the DEM stage's order, ``order``).

    Attributes:
        struct: the ``Bodies`` struct (``B``): poses and velocities read, loads (the reactions of
            the point contacts) added.
        world: [m] every body's vertices in world coordinates (refreshed by the DEM stage).
        count: number of bodies.
        moving: bodies that move (free or kinematic; they come first in ``order``).
        free: free bodies.
        order: the scene's body index of each device slot.
        columns: the host columns of the bodies (outlines, radii, friction; ``RigidArrays``), in the
            scene's order.
    """

    struct: object
    world: wp.array
    count: int
    moving: int
    free: int
    order: np.ndarray
    columns: RigidArrays
