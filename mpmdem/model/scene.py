"""Scene: the domain, background grid, gravity, walls, MPM bodies and rigid DEM bodies (SI units).

2D plane strain: masses, forces and energies are per unit thickness (kg/m, N/m, J/m).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from ..errors import InputError
from .bodies import ContactLaw, RigidBody, make_rigid_body
from .boundaries import SIDES, Boundary, WallTiles, as_boundary, check_sides, check_walls_on_grid_lines
from .finished import Model, StageKinds, finalize
from .grains import GrainSet, as_region, place_grains
from .materials import Material
from .probes import MassProbe, make_mass_probe
from .rigid_arrays import RigidArrays, rigid_arrays, stacked
from .scene_checks import SceneChecks
from .shapes import SEEDINGS, SeededPoints, Shape, rectangle, seed_points
from .spheropolygons import Spheropolygon, rounded_rectangle

__all__ = ["SIDES", "Boundary", "MPMBody", "MassProbe", "Obstacle", "Scene"]

@dataclass(frozen=True)
class Obstacle:
    """A rigid region of fixed ("fixed") or roller ("slip") grid nodes (Scene.add_obstacle)."""

    shape: Shape
    kind: str = "fixed"


@dataclass(frozen=True)
class MPMBody:
    """A continuum body: a shape filled with material points."""

    name: str
    shape: Shape
    material: Material
    velocity: tuple[float, float] | Callable[[np.ndarray], np.ndarray]
    points_per_cell: int
    angular_velocity: float = 0.0
    points: SeededPoints | None = None  # explicit points (Scene.add_points) instead of a seeded shape
    release_times: np.ndarray | None = None  # [s] per point: when it enters the scene (add_points)
    contact_radius: float | None = None  # r_p of its points against rigid bodies [m] (MPM-SDEM eq. 45)
    seeding: str = "clipped"  # point volumes: "clipped" to the shape or "full" sub-cells (seed_points)

    def initial_velocity(self, x: np.ndarray, volumes: np.ndarray | None = None) -> np.ndarray:
        """Velocity [m/s] of points at positions x (N, 2): the field, or the rigid motion, turning
        about the points' centroid weighted by their volumes [m²] (their mass centroid: the
        outline points of a clipped seeding are lighter)."""
        if callable(self.velocity):
            return np.asarray(self.velocity(x), dtype=float).reshape(len(x), 2)
        v = np.tile(np.asarray(self.velocity, dtype=float), (len(x), 1))
        if self.angular_velocity != 0.0:
            r = x - np.average(x, axis=0, weights=volumes)
            v = v + self.angular_velocity * np.stack([-r[:, 1], r[:, 0]], 1)
        return v


@dataclass
class Scene(SceneChecks, StageKinds):
    """The domain, grid and bodies of one simulation.

    Args:
        domain: ((x0, y0), (x1, y1)) corners of the rectangular domain [m]. MPM points and free
            rigid bodies that leave it stop the run.
        cell_size: background grid spacing h [m] of the MPM stage (None for a DEM-only scene).
        gravity: body acceleration (gx, gy) [m/s²].
        boundaries: side ("left", "right", "bottom", "top") → Boundary or kind name, the grid
            conditions of the MPM stage; sides not given are "slip". Rigid bodies meet walls
            only as fixed bodies (``add_walls``). "periodic" on left and right makes x periodic
            (period x1 − x0, whole cells; MPM bodies only: no rigid bodies, grains or obstacles).
        gravity_ramp: gravity grows linearly from zero to its value over this time [s]
            (quasi-static loading; 0 applies it at once).
        contact: the DEM contact law (needed once there are rigid bodies).
        coupling_contact: the contact law between material points and rigid bodies (MPM-SDEM
            eq. 44-46); None uses ``contact``, as the paper does.
        allow_initial_overlap: let rigid bodies start overlapping each other (a deliberately
            pre-stressed pack); by default an overlap deeper than 1 % of the smaller body's size
            is an error (``validate``), since the first steps turn it into speed.
    """

    domain: tuple[tuple[float, float], tuple[float, float]]
    cell_size: float | None = None
    gravity: tuple[float, float] = (0.0, 0.0)
    boundaries: dict = field(default_factory=dict)
    gravity_ramp: float = 0.0
    contact: ContactLaw | None = None
    coupling_contact: ContactLaw | None = None
    allow_initial_overlap: bool = False
    bodies: list[MPMBody] = field(default_factory=list)
    rigid_bodies: list[RigidBody] = field(default_factory=list)
    obstacles: list[Obstacle] = field(default_factory=list)
    mass_probes: list[MassProbe] = field(default_factory=list)
    #: (material, rigid body name) → Coulomb μ of material points against that body
    coupling_friction: dict = field(default_factory=dict)
    #: free grains (``add_grains``): DEM bodies after ``rigid_bodies``, kept as arrays
    grains: list[GrainSet] = field(default_factory=list)
    #: the left and right walls repeated along x (a batch's combined scene, ``mpmdem.sim.batch_scene``)
    wall_tiles: WallTiles | None = None

    def __post_init__(self):
        try:
            (x0, y0), (x1, y1) = self.domain
            x0, y0, x1, y1 = (float(v) for v in (x0, y0, x1, y1))
        except (TypeError, ValueError):
            raise InputError("domain", self.domain, "((x0, y0), (x1, y1)) with x0 < x1, y0 < y1") from None
        if not all(math.isfinite(v) for v in (x0, y0, x1, y1)) or not (x0 < x1 and y0 < y1):
            raise InputError("domain", self.domain, "((x0, y0), (x1, y1)) with x0 < x1, y0 < y1")
        self.domain = ((x0, y0), (x1, y1))
        h = self.cell_size
        if h is not None:
            if not isinstance(h, (int, float)) or not math.isfinite(h) or h <= 0.0:
                raise InputError("cell_size", h, "a grid spacing h > 0 [m]")
            if h > min(x1 - x0, y1 - y0):
                raise InputError("cell_size", h, f"at most the smaller domain side, {min(x1 - x0, y1 - y0)} m")
            self.cell_size = float(h)
        for name in ("contact", "coupling_contact"):
            law = getattr(self, name)
            if law is not None and not isinstance(law, ContactLaw):
                raise InputError(name, law, "a ContactLaw(normal_stiffness, ...) or None")
        g = tuple(float(v) for v in np.asarray(self.gravity, dtype=float).ravel())
        if len(g) != 2 or not all(math.isfinite(v) for v in g):
            raise InputError("gravity", self.gravity, "a finite (gx, gy) [m/s^2]")
        self.gravity = g
        if not (isinstance(self.gravity_ramp, (int, float)) and math.isfinite(self.gravity_ramp)
                and self.gravity_ramp >= 0.0):
            raise InputError("gravity_ramp", self.gravity_ramp, "a duration >= 0 [s]")
        unknown = set(self.boundaries) - set(SIDES)
        if unknown:
            raise InputError("boundaries", sorted(unknown), f"sides among {', '.join(SIDES)}")
        self.boundaries = {s: as_boundary(s, self.boundaries.get(s, "slip")) for s in SIDES}
        check_sides(self.boundaries)
        if self.cell_size is not None:
            check_walls_on_grid_lines(self.domain, self.cell_size, self.boundaries)

    @property
    def cell_counts(self) -> tuple[int, int]:
        """Cells per direction; the grid covers the domain, rounded up to whole cells."""
        (x0, y0), (x1, y1) = self.domain
        h = self.cell_size
        return max(1, math.ceil((x1 - x0) / h - 1e-9)), max(1, math.ceil((y1 - y0) / h - 1e-9))

    def add_mpm_body(
        self,
        shape: Shape,
        material: Material,
        *,
        velocity: tuple[float, float] | Callable[[np.ndarray], np.ndarray] = (0.0, 0.0),
        angular_velocity: float = 0.0,
        points_per_cell: int = 2,
        contact_radius: float | None = None,
        seeding: str = "clipped",
        name: str | None = None,
    ) -> MPMBody:
        """Fill ``shape`` with points_per_cell² points per cell of ``material``.

        velocity [m/s] and angular_velocity [rad/s, about the body's centroid] set the initial
        rigid motion of the body; velocity may instead be a function of the positions (N, 2)
        returning the velocities (N, 2), for an initial velocity field. contact_radius: r_p [m]
        of the body's points against rigid bodies, inside h sqrt(1/n) < r_p < h (MPM-SDEM
        eq. 45, n points per cell); None picks the geometric middle h n^(-1/4). seeding: "clipped"
        (default: a point on the outline carries the part of its sub-cell inside the shape, so the
        body's mass is ρ × the shape's area at any resolution) or "full" (every point a whole
        sub-cell: the staircase outline's mass, as before 0.x; ``seed_points``).
        """
        if self.cell_size is None:
            raise InputError("cell_size", None, "a grid spacing h > 0 [m] in Scene(...) before adding MPM bodies")
        if not isinstance(material, Material):
            raise InputError("material", material,
                             "a LinearElastic, NeoHookean, MohrCoulomb, DruckerPrager or MuI material")
        if callable(velocity):
            vel = velocity
        else:
            vel = tuple(float(v) for v in np.asarray(velocity, dtype=float).ravel())
            if len(vel) != 2 or not all(math.isfinite(v) for v in vel):
                raise InputError("velocity", velocity, "a finite (vx, vy) [m/s] or a function of positions")
        if not math.isfinite(float(angular_velocity)):
            raise InputError("angular_velocity", angular_velocity, "a finite number [rad/s]")
        if not isinstance(points_per_cell, int) or not 1 <= points_per_cell <= 8:
            raise InputError("points_per_cell", points_per_cell, "an integer in 1..8 (points per cell per direction)")
        if seeding not in SEEDINGS:
            raise InputError("seeding", seeding, " or ".join(repr(k) for k in SEEDINGS))
        name = name or f"body{len(self.bodies)}"
        body = MPMBody(name, shape, material, vel, points_per_cell, float(angular_velocity), seeding=seeding)
        pts = self._seed(body)
        # n for eq. 45 is the seeding's points per cell, whatever the outline points' volumes
        body = self._with_contact_radius(body, contact_radius, np.array([(self.cell_size / points_per_cell) ** 2]))
        (x0, y0), (x1, y1) = self.domain
        x = pts.positions
        if callable(vel):
            try:
                v = body.initial_velocity(x)
            except Exception as e:  # a user function that fails is a bad input
                raise InputError("velocity", velocity, f"a function (N, 2) -> (N, 2); it raised {e!r}") from None
            if not np.isfinite(v).all():
                raise InputError("velocity", velocity, "a function returning finite velocities")
        if (x[:, 0] < x0).any() or (x[:, 0] > x1).any() or (x[:, 1] < y0).any() or (x[:, 1] > y1).any():
            raise InputError("shape", shape.to_dict(), f"a shape inside the domain {self.domain}")
        self.bodies.append(body)
        return body

    def add_rigid_body(
        self,
        shape: Spheropolygon,
        *,
        density: float,
        position: tuple[float, float] | None = None,
        angle: float = 0.0,
        velocity: tuple[float, float] = (0.0, 0.0),
        angular_velocity: float = 0.0,
        motion: Literal["free", "fixed", "kinematic"] = "free",
        friction: float = 0.5,
        active: tuple[float, float] = (0.0, math.inf),
        name: str | None = None,
    ) -> RigidBody:
        """Add a spheropolygon moved as a rigid body by the DEM stage.

        Args:
            shape: the spheropolygon (``sphero_disk``, ``rod``, ``rounded_rectangle``,
                ``regular_polygon``, ``random_convex_polygon``, ``spheropolygon``...).
            density: ρ [kg/m³].
            position: where the centroid goes [m]; None keeps the shape where it was drawn.
            angle: initial rotation [rad] about the centroid.
            velocity, angular_velocity: initial velocity [m/s] and angular velocity [rad/s]; for
                a kinematic body, the prescribed motion.
            motion: "free", "fixed" (never integrated: costs nothing per step) or "kinematic".
            friction: Coulomb μ >= 0 (a pair uses the smaller of its two values).
            active: (t_start, t_end) [s] during which a kinematic body moves.

        A free body must have its centroid inside the domain and must not be larger than it: its
        bounding box at the initial angle (core polygon + sphero radius) may be at most as wide
        and as tall as the domain. Fixed and kinematic bodies may extend past the domain (the
        walls of ``add_walls`` reach past its corners by their thickness, a floor may run under
        the whole domain, a peg may sit outside it), so they have no size limit.
        """
        name = name or f"rigid{len(self.rigid_bodies)}"
        body = make_rigid_body(shape, density=density, position=position, angle=angle, velocity=velocity,
                               angular_velocity=angular_velocity, motion=motion, friction=friction,
                               active=active, name=name)
        if motion == "free":
            (x0, y0), (x1, y1) = self.domain
            x, y = body.position
            if not (x0 <= x <= x1 and y0 <= y <= y1):
                raise InputError("position", body.position, f"a centroid inside the domain {self.domain}")
            dw, dh = x1 - x0, y1 - y0
            if 2.0 * body.shape.bounding_radius * (1.0 + 1e-12) > min(dw, dh):  # else it fits at any angle
                bw, bh = np.ptp(body.world_vertices(), axis=0) + 2.0 * body.shape.radius
                if bw > dw * (1.0 + 1e-9) or bh > dh * (1.0 + 1e-9):
                    raise InputError(f"rigid body {name!r} size", (float(f"{bw:.6g}"), float(f"{bh:.6g}")),
                                     f"a free body no larger than the domain, {dw:g} x {dh:g} m (the size is the "
                                     "bounding box width x height of the rounded body at its initial angle)")
        self.rigid_bodies.append(body)
        return body

    def add_walls(
        self,
        sides=("left", "right", "bottom"),
        *,
        thickness: float | None = None,
        friction: float = 0.5,
        density: float = 1000.0,
    ) -> list[RigidBody]:
        """Close sides of the domain for rigid bodies with fixed rectangular bodies just outside it.

        The walls' inner faces lie on the domain's sides; they extend a thickness past the
        corners so that corners are closed. thickness [m] defaults to a tenth of the smaller
        domain side. Returns the wall bodies (named "wall_<side>").
        """
        (x0, y0), (x1, y1) = self.domain
        w = 0.1 * min(x1 - x0, y1 - y0) if thickness is None else float(thickness)
        if not (math.isfinite(w) and w > 0.0):
            raise InputError("thickness", thickness, "a wall thickness > 0 [m]")
        unknown = [s for s in sides if s not in SIDES]
        if unknown or isinstance(sides, str):
            raise InputError("sides", sides, f"a sequence of sides among {', '.join(SIDES)}")
        lx, ly = x1 - x0 + 2 * w, y1 - y0 + 2 * w
        cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
        geometry = {
            "left": ((w, ly), (x0 - 0.5 * w, cy)),
            "right": ((w, ly), (x1 + 0.5 * w, cy)),
            "bottom": ((lx, w), (cx, y0 - 0.5 * w)),
            "top": ((lx, w), (cx, y1 + 0.5 * w)),
        }
        out = []
        for side in sides:
            (width, height), centre = geometry[side]
            out.append(self.add_rigid_body(rounded_rectangle(width, height), density=density, position=centre,
                                           motion="fixed", friction=friction, name=f"wall_{side}"))
        return out

    def add_obstacle(self, shape: Shape, kind: str = "fixed") -> Obstacle:
        """A rigid obstacle inside the grid, made of the grid nodes inside or on ``shape``.

        For steps, ledges and bins the material flows over or into (the planes of "Granular MPM"
        §4.2, which the paper also makes of grid boundary conditions). kind: "fixed" (the nodes
        do not move: no slip) or "slip" (a roller: no motion through the surface, free along it;
        the normal is that of the nearest edge). The force the material exerts on all obstacles
        together is reported per frame as force_obstacles_x/y [N/m]. Points must not be seeded
        inside an obstacle.
        """
        if kind not in ("fixed", "slip"):
            raise InputError("kind", kind, "'fixed' or 'slip'")
        if self.cell_size is None:
            raise InputError("cell_size", None, "a grid spacing h > 0 [m] in Scene(...) before adding obstacles")
        if not isinstance(shape, Shape):
            raise InputError("shape", shape, "a Shape (rectangle, disk, polygon) for the obstacle")
        (x0, y0), (x1, y1) = self.domain
        bx0, by0, bx1, by1 = shape.bounds
        if bx1 < x0 or bx0 > x1 or by1 < y0 or by0 > y1:
            raise InputError("shape", shape.to_dict(), f"an obstacle overlapping the domain {self.domain}")
        obstacle = Obstacle(shape, kind)
        self.obstacles.append(obstacle)
        return obstacle

    def add_grains(
        self,
        region,
        *,
        radius: float,
        shape: Literal["disk", "polygon"] = "disk",
        density: float,
        friction: float = 0.5,
        seed: int = 0,
        polydispersity: float = 0.15,
        sides: int = 5,
        rounding: float = 0.25,
        velocity: tuple[float, float] = (0.0, 0.0),
        name: str | None = None,
    ) -> GrainSet:
        """Fill ``region`` with free grains moved by the DEM stage (``mpmdem.model.grains``), kept as arrays.

        Args:
            region: a list of (x, y) vertices [m] or a shapely Polygon/MultiPolygon.
            radius: mean equivalent radius r [m] (a disk's radius; sqrt(area/π) of a polygon).
            shape: "disk" (sphero-disks) or "polygon" (random convex cores of ``sides`` vertices,
                rounded by ``rounding`` × their circumradius, at random angles).
            density: ρ [kg/m³] of the grains (mass per unit thickness ρ × area).
            friction: Coulomb μ >= 0 (a pair uses the smaller of its two values).
            seed: seed of the sizes, shapes and places.
            polydispersity: radii uniform in r (1 ± polydispersity), in [0, 0.5); ±15 % keeps a
                2D pack from crystallising.
            velocity: initial velocity of every grain [m/s].

        The grains sit on a jittered hexagonal lattice, apart (a loose pack: pour it with
        ``mpmdem.sim.packing.settle``). Raises InputError for a region holding no grain, one outside
        the domain, grains that would overlap a body already in the scene (a wall, a fixed body,
        grains of an earlier call), or more grains than this machine can build.
        """
        name = name or f"grains{len(self.grains)}"
        if name in {g.name for g in self.grains}:
            raise InputError("name", name, "a grain-set name not used by another set")
        grains = place_grains(region, radius=radius, shape=shape, density=density, friction=friction, seed=seed,
                              polydispersity=polydispersity, sides=sides, rounding=rounding, velocity=velocity,
                              name=name)
        bounds = tuple(round(v, 6) for v in as_region(region).bounds)
        return self.add_grain_set(grains, what=f"region (bounds {bounds})")

    def add_grain_set(self, grains: GrainSet, *, what: str = "grains") -> GrainSet:
        """Add grains placed elsewhere (``add_grains`` of another scene, or a ``mpmdem.sim.packing.settle``
        of one: a settled pack moved into the scene it will flow in). InputError when a grain
        reaches past the domain or overlaps a body already in the scene."""
        if not isinstance(grains, GrainSet):
            raise InputError("grains", grains, "a GrainSet (Scene.add_grains, mpmdem.sim.packing.settle)")
        if grains.name in {g.name for g in self.grains}:
            raise InputError("name", grains.name, "a grain-set name not used by another set")
        (x0, y0), (x1, y1) = self.domain
        x, reach = grains.position, grains.bounding_radius
        if self.periodic_x:  # (x periodic: a grain may straddle the seam, its centroid in [x0, x1))
            out = (x[:, 0] < x0) | (x[:, 0] >= x1) | (x[:, 1] - reach < y0) | (x[:, 1] + reach > y1)
        else:
            out = (x[:, 0] - reach < x0) | (x[:, 0] + reach > x1) | (x[:, 1] - reach < y0) | (x[:, 1] + reach > y1)
        if out.any():
            raise InputError(what.split(" ")[0], what, f"grains inside the domain {self.domain}: {int(out.sum())} "
                             f"of {len(grains)} grains would reach past it")
        self._check_grains_clear(grains)
        self.grains.append(grains)
        return grains

    def finalize(self) -> Model:
        """End the building: check the scene as a whole, seed its points and build its DEM bodies'
        columns once, and return the finished ``Model`` the stages take (``mpmdem.model.finished``)."""
        return finalize(self)

    def body_arrays(self) -> RigidArrays:
        """Columns of every DEM body: the rigid bodies (scene order), then each grain set's grains."""
        parts = [rigid_arrays(self.rigid_bodies)] + [g.rigid_arrays() for g in self.grains]
        return stacked(parts)

    @property
    def dem_body_count(self) -> int:
        """Rigid bodies plus grains."""
        return len(self.rigid_bodies) + sum(len(g) for g in self.grains)

    def body_name(self, k: int) -> str:
        """Name of DEM body k (``body_arrays`` order): a rigid body's name, or "<set>[i]" for grain i."""
        if k < len(self.rigid_bodies):
            return self.rigid_bodies[k].name
        k -= len(self.rigid_bodies)
        for g in self.grains:
            if k < len(g):
                return f"{g.name}[{k}]"
            k -= len(g)
        raise IndexError(k)

    def body_names(self) -> list[str]:
        """Names of every DEM body (``body_arrays`` order)."""
        return [b.name for b in self.rigid_bodies] + [f"{g.name}[{k}]" for g in self.grains for k in range(len(g))]

    def add_mass_probe(self, name: str, lo=(-math.inf, -math.inf), hi=(math.inf, math.inf)) -> MassProbe:
        """Measure the mass of the material points and free DEM bodies (grains included; a body by its
        centroid) inside the box lo ≤ x < hi [m] at every frame (``mass_<name>`` [kg/m] in the
        diagnostics; see ``mpmdem.model.probes.MassProbe``)."""
        probe = make_mass_probe(name, lo, hi, [p.name for p in self.mass_probes])
        self.mass_probes.append(probe)
        return probe

    def add_points(
        self,
        positions,
        material: Material,
        *,
        size: float,
        velocity=(0.0, 0.0),
        release_time=0.0,
        contact_radius: float | None = None,
        name: str | None = None,
    ) -> MPMBody:
        """Material points at given positions (N, 2) [m], each a square domain of edge ``size`` [m].

        For set-ups that place points one by one (the 1D disconnection example of "Granular MPM"
        §4.1). Mass = density × size² per point; GIMP half-lengths size/2. velocity: (vx, vy)
        [m/s] for all, or an (N, 2) array of per-point velocities. release_time: when the points
        enter the scene [s], one value or one per point (a feed, like the silo filling of
        "Granular MPM" §4.3); until then they take no part, are left out of the diagnostics and
        written as NaN. The energy they bring is booked as the work term ``work_inflow``.
        contact_radius: r_p against rigid bodies, as in ``add_mpm_body``.
        """
        if self.cell_size is None:
            raise InputError("cell_size", None, "a grid spacing h > 0 [m] in Scene(...) before adding MPM bodies")
        if not isinstance(material, Material):
            raise InputError("material", material,
                             "a LinearElastic, NeoHookean, MohrCoulomb, DruckerPrager or MuI material")
        x = np.asarray(positions, dtype=float)
        if x.ndim != 2 or x.shape[1] != 2 or len(x) == 0 or not np.isfinite(x).all():
            raise InputError("positions", positions, "a finite (N, 2) array of point positions [m], N >= 1")
        size = float(size)
        if not (math.isfinite(size) and 0.0 < size <= 2.0 * self.cell_size):
            raise InputError("size", size, f"an edge length in (0, 2h = {2.0 * self.cell_size}] [m]")
        v = np.asarray(velocity, dtype=float)
        if v.shape == (2,):
            v = np.tile(v, (len(x), 1))
        if v.shape != x.shape or not np.isfinite(v).all():
            raise InputError("velocity", velocity, f"a finite (vx, vy) or an array of shape {x.shape} [m/s]")
        (x0, y0), (x1, y1) = self.domain
        if (x[:, 0] < x0).any() or (x[:, 0] > x1).any() or (x[:, 1] < y0).any() or (x[:, 1] > y1).any():
            raise InputError("positions", positions, f"points inside the domain {self.domain}")
        n = len(x)
        try:
            rel = np.broadcast_to(np.asarray(release_time, dtype=float), (n,)).copy()
        except (TypeError, ValueError):
            rel = None
        if rel is None or rel.shape != (n,) or not np.isfinite(rel).all() or (rel < 0.0).any():
            raise InputError("release_time", release_time, f"a time >= 0 [s], or {n} of them (one per point)")
        pts = SeededPoints(x.copy(), np.full(n, size * size), np.full((n, 2), 0.5 * size))
        lo, hi = x.min(axis=0) - 0.5 * size, x.max(axis=0) + 0.5 * size
        vel = v.copy()
        body = MPMBody(name or f"body{len(self.bodies)}", rectangle(lo[0], lo[1], hi[0], hi[1]), material,
                       lambda _x, _v=vel: _v, max(1, round(self.cell_size / size)), 0.0, pts, rel.copy())
        body = self._with_contact_radius(body, contact_radius, pts.volumes)
        self.bodies.append(body)
        return body

    def contact_radius_interval(self, volumes: np.ndarray) -> tuple[float, float]:
        """(h sqrt(1/n), h) [m]: MPM-SDEM eq. 45's open interval for the contact radius r_p of
        points of these volumes [m²], with n = h² / mean volume the points per cell."""
        h = self.cell_size
        n = h * h / float(np.mean(volumes))
        return h / math.sqrt(n), h

    def _with_contact_radius(self, body: MPMBody, r_p, volumes: np.ndarray) -> MPMBody:
        lo, hi = self.contact_radius_interval(volumes)
        if r_p is None:
            return dataclasses.replace(body, contact_radius=math.sqrt(lo * hi))
        try:
            r = float(r_p)
        except (TypeError, ValueError):
            r = math.nan
        if not (lo < r < hi):
            raise InputError("contact_radius", r_p, f"a radius in the open interval ({lo:.6g}, {hi:.6g}) m, "
                             "h sqrt(1/n) < r_p < h (MPM-SDEM eq. 45, h the cell size, n points per cell)")
        return dataclasses.replace(body, contact_radius=r)

    def set_coupling_friction(self, material: Material, rigid_body: RigidBody | str, friction: float) -> None:
        """Coulomb μ between the points of ``material`` and one rigid body (default: the body's
        own ``friction``)."""
        if not isinstance(material, Material):
            raise InputError("material", material, "a material of this scene's MPM bodies")
        name = rigid_body if isinstance(rigid_body, str) else getattr(rigid_body, "name", None)
        names = [b.name for b in self.rigid_bodies]
        if name not in names:
            raise InputError("rigid_body", rigid_body, f"one of this scene's rigid bodies {names}")
        try:
            mu = float(friction)
        except (TypeError, ValueError):
            mu = math.nan
        if not (math.isfinite(mu) and mu >= 0.0):
            raise InputError("friction", friction, "a Coulomb coefficient >= 0")
        self.coupling_friction[(material, name)] = mu

    def _seed(self, body: MPMBody):
        if body.points is not None:
            return body.points
        return seed_points(body.shape, cell_size=self.cell_size, points_per_cell=body.points_per_cell,
                           origin=self.domain[0], seeding=body.seeding)

    def particles(self) -> dict[str, np.ndarray]:
        """Host arrays of every material point, body after body (float64)."""
        if not self.bodies:
            raise InputError("bodies", [], "at least one body (Scene.add_mpm_body)")
        parts = []
        for k, b in enumerate(self.bodies):
            pts = self._seed(b)
            n = len(pts.volumes)
            x = pts.positions
            v = b.initial_velocity(x, pts.volumes)
            parts.append(dict(
                x=x, v=v, vol=pts.volumes, half=pts.half_sizes,
                mass=pts.volumes * b.material.density,
                body=np.full(n, k, np.int32),
                release=b.release_times if b.release_times is not None else np.zeros(n),
                contact_radius=np.full(n, b.contact_radius if b.contact_radius is not None else 0.0),
            ))
        return {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}

    def materials(self) -> list[Material]:
        """Distinct materials, in body order; a point's material index refers to this list."""
        out: list[Material] = []
        for b in self.bodies:
            if b.material not in out:
                out.append(b.material)
        return out

    def to_dict(self) -> dict:
        """JSON-serialisable description stored with every output file."""
        return {
            "domain": self.domain,
            "cell_size": self.cell_size,
            "gravity": self.gravity,
            "gravity_ramp": self.gravity_ramp,
            "contact": self.contact.to_dict() if self.contact is not None else None,
            "coupling_contact": self.coupling_contact.to_dict() if self.coupling_contact is not None else None,
            "coupling_friction": [[m.to_dict(), name, mu] for (m, name), mu in self.coupling_friction.items()],
            **({"allow_initial_overlap": True} if self.allow_initial_overlap else {}),
            "rigid_bodies": [b.to_dict() for b in self.rigid_bodies],
            **({"grains": [g.to_dict() for g in self.grains]} if self.grains else {}),
            "boundaries": {s: {"kind": b.kind, "friction": b.friction,
                               **({"velocity": b.velocity} if b.velocity else {})} for s, b in self.boundaries.items()},
            "obstacles": [{"kind": o.kind, "shape": o.shape.to_dict()} for o in self.obstacles],
            **({"mass_probes": [{"name": p.name, "lo": p.lo, "hi": p.hi} for p in self.mass_probes]}
               if self.mass_probes else {}),
            "bodies": [
                {"name": b.name, "shape": b.shape.to_dict(), "material": b.material.to_dict(),
                 "velocity": getattr(b.velocity, "__name__", "field") if callable(b.velocity) else b.velocity,
                 "angular_velocity": b.angular_velocity,
                 "points_per_cell": b.points_per_cell, "contact_radius": b.contact_radius, "seeding": b.seeding}
                for b in self.bodies
            ],
        }
