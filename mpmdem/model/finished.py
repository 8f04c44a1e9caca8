"""Model: the finished, frozen description of one run that the stages take (``Scene.finalize``).

``Scene`` is the builder: bodies, grains, walls and probes are added in any order and each is
checked as it comes. ``finalize`` ends the building once: it runs the whole-scene checks
(``Scene.validate``), seeds the material points and builds the DEM bodies' columns
(``rigid_arrays.RigidArrays``), each exactly once, and returns a ``Model`` holding them with
everything else the stages read (domain, grid, gravity, walls, contact laws, materials, probes).
The MPM, DEM and coupled stages read the Model only, never the Scene: what they build from is
fixed when the run is set up, and a scene changed afterwards does not reach a stage built before.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import MappingProxyType
from typing import TYPE_CHECKING

from ..errors import InputError
from .rigid_arrays import RigidArrays

if TYPE_CHECKING:
    from .bodies import ContactLaw, RigidBody
    from .boundaries import WallTiles
    from .grains import GrainSet
    from .materials import Material
    from .probes import MassProbe

__all__ = ["Model", "StageKinds", "finalize"]


class StageKinds:
    """What a ``Scene`` and its ``Model`` both answer: which stages run, and whether x is periodic."""

    @property
    def periodic_x(self) -> bool:
        """Whether x is periodic (left and right sides "periodic"): the MPM grid wraps around."""
        return self.boundaries["left"].kind == "periodic"

    @property
    def has_mpm(self) -> bool:
        """Whether there are material points (the MPM stage runs)."""
        return bool(self.bodies)

    @property
    def has_dem(self) -> bool:
        """Whether there are rigid bodies or grains (the DEM stage runs)."""
        return bool(self.rigid_bodies or self.grains)


@dataclass(frozen=True, eq=False)
class Model(StageKinds):
    """What the stages of one run take: a finished scene, its points seeded and its DEM bodies laid
    out once (SI units; made by ``finalize``, not by hand).

    Attributes:
        domain: ((x0, y0), (x1, y1)) [m]; cell_size: h [m] (None without material points);
        cell_counts: cells per direction (None without a grid).
        gravity [m/s²], gravity_ramp [s], boundaries (side → Boundary), contact and
        coupling_contact (the DEM and the point–body contact laws), coupling_friction
        ((material, rigid body name) → μ).
        bodies, rigid_bodies, grains, obstacles, mass_probes: the scene's, in its order.
        materials: the distinct materials of the MPM bodies, in body order (a point's material index).
        particles: host arrays of every material point, body after body (``Scene.particles``; None
            without material points).
        arrays: the columns of every DEM body, rigid bodies then grains (``Scene.body_arrays``).
        body_names: the DEM bodies' names in ``arrays`` order.
        initial_overlaps: (body, body, depth [m]) of the pairs let start overlapping.
        wall_tiles: the left and right walls repeated along x (``boundaries.WallTiles``), or None.
    """

    domain: tuple[tuple[float, float], tuple[float, float]]
    cell_size: float | None
    cell_counts: tuple[int, int] | None
    gravity: tuple[float, float]
    gravity_ramp: float
    boundaries: MappingProxyType
    contact: ContactLaw | None
    coupling_contact: ContactLaw | None
    coupling_friction: MappingProxyType
    bodies: tuple  # of scene.MPMBody
    rigid_bodies: tuple[RigidBody, ...]
    grains: tuple[GrainSet, ...]
    obstacles: tuple  # of scene.Obstacle
    mass_probes: tuple[MassProbe, ...]
    materials: tuple[Material, ...]
    particles: MappingProxyType | None
    arrays: RigidArrays
    body_names: tuple[str, ...]
    initial_overlaps: tuple[tuple[str, str, float], ...]
    wall_tiles: WallTiles | None = None

    def body_arrays(self) -> RigidArrays:
        """The DEM bodies' columns, built once by ``finalize`` (``Scene.body_arrays``' name)."""
        return self.arrays


def finalize(scene) -> Model:
    """Check ``scene`` (a ``Scene``: this module sits below it and names none of its types) as a
    whole (``Scene.validate``), seed its points and build its DEM bodies' columns, once each, and
    return the finished ``Model``. Raises InputError before any kernel."""
    if not (scene.has_mpm or scene.has_dem):
        raise InputError("bodies", [], "at least one body (Scene.add_mpm_body or Scene.add_rigid_body)")
    particles = scene.particles() if scene.has_mpm else None
    arrays = scene.body_arrays()
    overlaps = scene.validate(arrays=arrays, particles=particles)
    for host in (particles or {}).values():
        host.flags.writeable = False
    return Model(
        domain=scene.domain, cell_size=scene.cell_size,
        cell_counts=scene.cell_counts if scene.cell_size is not None else None,
        gravity=scene.gravity, gravity_ramp=scene.gravity_ramp, boundaries=MappingProxyType(dict(scene.boundaries)),
        contact=scene.contact, coupling_contact=scene.coupling_contact,
        coupling_friction=MappingProxyType(dict(scene.coupling_friction)),
        bodies=tuple(scene.bodies), rigid_bodies=tuple(scene.rigid_bodies), grains=tuple(scene.grains),
        obstacles=tuple(scene.obstacles), mass_probes=tuple(scene.mass_probes), materials=tuple(scene.materials()),
        particles=MappingProxyType(particles) if particles is not None else None, arrays=arrays,
        body_names=tuple(scene.body_names()), initial_overlaps=tuple(overlaps), wall_tiles=scene.wall_tiles)
