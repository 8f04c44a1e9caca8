"""Grain sets: many free sphero-disks (or rounded random convex polygons) as numpy columns (SI units).

A grain is a free spheropolygon body of the DEM stage (MPM-SDEM §3: a core ⊕ a disk of radius a,
eq. 37; the contact law of eq. 39-43), like a ``RigidBody``, but a ``GrainSet`` keeps the n grains
of one ``Scene.add_grains`` call as arrays: positions, radii, core vertices, areas and second
moments, built in a few numpy expressions (10⁵ grains in well under a second, no Python call per
grain). The DEM stage reads them through ``GrainSet.rigid_arrays`` like the scene's rigid bodies.

Placement (``place_grains``): a hexagonal lattice of pitch 2 R_max (1 + GAP) over the region, R_max
the largest bounding radius a grain can have; the lattice points whose whole cell lies inside the
region are kept, and each grain moves from its point by a random offset of at most
pitch/2 − R_i, so no two grains overlap and none leaves the region. The pack is loose (a solid
fraction of about 0.9069 (r/R_max)², 0.6–0.7): ``mpmdem.sim.packing.settle`` pours it under gravity.
The sizes are uniform in r (1 ± polydispersity), ±15 % by default: a monodisperse 2D pack
crystallises into hexagonal order, a polydisperse one stays amorphous.

Masses are per unit thickness: ρ × area [kg/m].
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from ..checks import at_least, finite, positive
from ..errors import InputError
from .memory import available_host_memory
from .rigid_arrays import RigidArrays
from .spheropolygons import placed, random_convex_polygon

__all__ = ["GRAIN_SHAPES", "GrainSet", "place_grains"]

GRAIN_SHAPES = ("disk", "polygon")
#: Gap between the bounding circles of the largest grains on the lattice, as a fraction of R_max.
GAP = 0.02
#: Random convex cores drawn per polygon grain set; each grain takes one, scaled to its size.
POLYGON_TEMPLATES = 32
#: Host memory a grain takes while a scene is built and validated [B]: its columns (~200 B), its
#: shapely core and the overlap search over it (measured: 1e6 disks built and validated at a peak
#: of 1.6 GB, 1.6 kB a grain).
HOST_BYTES_PER_GRAIN = 2048


@dataclass(frozen=True, eq=False)
class GrainSet:
    """n free grains of one density and friction (``Scene.add_grains``).

    Attributes:
        name: label of the set; grain k is named "<name>[k]" in messages.
        shape: "disk" or "polygon".
        size: r [m], the mean equivalent radius (disk radius, or sqrt(area/π) of a polygon).
        polydispersity: half-width of the uniform size distribution, as a fraction of r.
        density: ρ [kg/m³] of every grain.
        friction: Coulomb μ of every grain.
        position: (n, 2) centroids [m].
        angle: (n,) orientations [rad] (0 for disks).
        radius: (n,) sphero radii a [m] (the disk radius of a disk).
        local: (n, k, 2) core vertices in the grain frames [m] (k = 1, the origin, for disks).
        area: (n,) areas of the rounded grains [m²].
        second_moment: (n,) polar second moments of area about the centroids [m⁴].
        core_radius: (n,) max_k |V_k| [m] (0 for disks).
        velocity: (vx, vy) initial velocity of every grain [m/s].
    """

    name: str
    shape: str
    size: float
    polydispersity: float
    density: float
    friction: float
    position: np.ndarray
    angle: np.ndarray
    radius: np.ndarray
    local: np.ndarray
    area: np.ndarray
    second_moment: np.ndarray
    core_radius: np.ndarray
    velocity: tuple[float, float] = (0.0, 0.0)

    def __len__(self) -> int:
        return len(self.radius)

    @property
    def bounding_radius(self) -> np.ndarray:
        """(n,) core radius + a [m]: the circle about each centroid holding the grain."""
        return self.core_radius + self.radius

    @property
    def mass(self) -> np.ndarray:
        """(n,) masses per unit thickness ρA [kg/m]."""
        return self.density * self.area

    @property
    def total_area(self) -> float:
        """Σ area of the grains [m²]."""
        return float(self.area.sum())

    def rigid_arrays(self) -> RigidArrays:
        """The grains as the DEM stage's body columns (``rigid_arrays.RigidArrays``), all free."""
        n, k = self.local.shape[:2]
        cos, sin = np.cos(self.angle), np.sin(self.angle)
        world = placed(self.local, cos, sin, self.position).reshape(n * k, 2)
        counts = np.full(n, k, dtype=np.intp)
        return RigidArrays(
            position=self.position, angle=self.angle, radius=self.radius, core_radius=self.core_radius,
            bounding_radius=self.bounding_radius, density=np.full(n, self.density), area=self.area,
            second_moment=self.second_moment, free=np.ones(n, bool), fixed=np.zeros(n, bool), counts=counts,
            starts=np.arange(n, dtype=np.intp) * k, local=self.local.reshape(n * k, 2), world=world,
            velocity=np.tile(np.asarray(self.velocity, dtype=np.float64), (n, 1)), angular_velocity=np.zeros(n),
            friction=np.full(n, self.friction), active=np.tile([0.0, math.inf], (n, 1)), grain=np.ones(n, bool))

    def to_dict(self) -> dict:
        """JSON-serialisable summary (the grains' columns go to the output file's body geometry)."""
        return {"name": self.name, "shape": self.shape, "count": len(self), "size": self.size,
                "polydispersity": self.polydispersity, "density": self.density, "friction": self.friction,
                "area": self.total_area, "velocity": list(self.velocity)}


def as_region(region) -> BaseGeometry:
    """A shapely polygon (or multipolygon) of positive area from a vertex list (N, 2) [m] or a
    shapely geometry; InputError otherwise."""
    allowed = "a polygon: a list of (x, y) vertices [m] or a shapely Polygon/MultiPolygon of positive area"
    if isinstance(region, BaseGeometry):
        geom = region
    else:
        try:
            v = np.asarray(region, dtype=float)
        except (TypeError, ValueError):
            raise InputError("region", region, allowed) from None
        if v.ndim != 2 or v.shape[1] != 2 or len(v) < 3 or not np.isfinite(v).all():
            raise InputError("region", region, allowed)
        geom = shapely.Polygon(v)
    if geom.geom_type not in ("Polygon", "MultiPolygon") or geom.is_empty or not geom.is_valid or geom.area <= 0.0:
        raise InputError("region", region, allowed)
    return geom


def _templates(rng: np.random.Generator, sides: int, rounding: float):
    """POLYGON_TEMPLATES random convex cores (``random_convex_polygon``, circumradius 1, sphero radius
    ``rounding``) as (vertices (T, sides, 2), sphero radius (T,), area (T,), second moment (T,),
    core radius (T,)), each scaled to unit equivalent radius sqrt(area/π) = 1."""
    shapes = [random_convex_polygon(rng, sides, 1.0, radius=rounding) for _ in range(POLYGON_TEMPLATES)]
    area = np.array([s.area for s in shapes])
    scale = 1.0 / np.sqrt(area / math.pi)
    return (np.stack([s.vertices for s in shapes]) * scale[:, None, None], rounding * scale, area * scale**2,
            np.array([s.second_moment for s in shapes]) * scale**4, np.array([s.core_radius for s in shapes]) * scale)


def place_grains(region, *, radius: float, shape: str = "disk", density: float, friction: float = 0.5,
                 seed: int = 0, polydispersity: float = 0.15, sides: int = 5, rounding: float = 0.25,
                 velocity=(0.0, 0.0), name: str = "grains") -> GrainSet:
    """Fill ``region`` (vertex list or shapely polygon [m]) with non-overlapping grains of mean
    equivalent radius ``radius`` [m] (see the module docstring for the placement).

    shape "disk": sphero-disks; "polygon": random convex cores of ``sides`` vertices rounded by
    ``rounding`` × their circumradius, at random angles, each of equivalent radius r_i.
    r_i is uniform in radius × (1 ± polydispersity). Raises InputError for a bad argument, a region
    that holds no grain, or more grains than this machine's memory can build."""
    geom = as_region(region)
    r = positive("radius", radius, "a grain radius > 0 [m]")
    if shape not in GRAIN_SHAPES:
        raise InputError("shape", shape, f"one of {', '.join(GRAIN_SHAPES)}")
    rho = positive("density", density, "a grain density > 0 [kg/m^3]")
    mu = at_least("friction", friction, 0.0, "a Coulomb coefficient >= 0")
    p = finite("polydispersity", polydispersity, "a fraction in [0, 0.5)")
    if not 0.0 <= p < 0.5:
        raise InputError("polydispersity", polydispersity, "a fraction in [0, 0.5) (grain radii r (1 ± p))")
    if not (isinstance(seed, (int, np.integer)) and not isinstance(seed, bool)):
        raise InputError("seed", seed, "an integer seed of the grains' sizes, shapes and places")
    if not (isinstance(sides, (int, np.integer)) and not isinstance(sides, bool) and 3 <= sides <= 16):
        raise InputError("sides", sides, "an integer in 3..16 (core vertices of a polygon grain)")
    rounding = finite("rounding", rounding, "a sphero radius in (0, 1] x the core's circumradius")
    if not 0.0 < rounding <= 1.0:
        raise InputError("rounding", rounding, "a sphero radius in (0, 1] x the core's circumradius")
    try:
        vel = tuple(float(v) for v in np.asarray(velocity, dtype=float).ravel())
    except (TypeError, ValueError):
        vel = ()
    if len(vel) != 2 or not all(math.isfinite(v) for v in vel):
        raise InputError("velocity", velocity, "a finite (vx, vy) [m/s]")
    rng = np.random.default_rng(int(seed))
    if shape == "polygon":
        t_vertices, t_a, t_area, t_second, t_core = _templates(rng, int(sides), rounding)
        reach = float((t_core + t_a).max())  # bounding radius of a grain of unit equivalent radius
    else:
        reach = 1.0
    r_max = r * (1.0 + p) * reach
    pitch = 2.0 * r_max * (1.0 + GAP)
    row = pitch * math.sqrt(3.0) / 2.0
    estimate = geom.area / (pitch * row)
    available = available_host_memory()
    if estimate * HOST_BYTES_PER_GRAIN > 0.5 * available:
        raise InputError("radius", radius, f"grains few enough to build on this machine: about {estimate:.3g} "
                         f"grains of {HOST_BYTES_PER_GRAIN} B fill the region, against half of the "
                         f"{available / 2**30:.3g} GiB of host memory available; take larger grains or a smaller "
                         "region")
    # hexagonal lattice points whose cell (a circle of pitch/2) lies inside the region
    inner = geom.buffer(-0.5 * pitch)
    x0, y0, x1, y1 = geom.bounds
    ys = y0 + 0.5 * pitch + row * np.arange(max(0, math.floor((y1 - y0 - pitch) / row + 1e-9)) + 1)
    xs = x0 + 0.5 * pitch + pitch * np.arange(max(0, math.floor((x1 - x0 - pitch) / pitch + 1e-9)) + 2)
    gx = xs[None, :] + 0.5 * pitch * (np.arange(len(ys)) % 2)[:, None]
    gy = np.broadcast_to(ys[:, None], gx.shape)
    gx, gy = gx.ravel(), gy.ravel()
    keep = shapely.contains_xy(inner, gx, gy) if not inner.is_empty else np.zeros(len(gx), bool)
    n = int(np.count_nonzero(keep))
    if n == 0:
        bounds = tuple(round(v, 6) for v in geom.bounds)
        raise InputError("region", f"{geom.geom_type} of area {geom.area:.4g} m^2, bounds {bounds}",
                         f"a region that holds at least one grain: a circle of diameter {pitch:.4g} m (2 x the largest "
                         f"grain's bounding radius {r_max:.4g} m, radius {r:g} m, polydispersity {p:g}) must fit in it")
    sizes = r * (1.0 + p * rng.uniform(-1.0, 1.0, n))
    if shape == "polygon":
        which = rng.integers(0, POLYGON_TEMPLATES, n)
        local = t_vertices[which] * sizes[:, None, None]
        a = t_a[which] * sizes
        area = t_area[which] * sizes**2
        second = t_second[which] * sizes**4
        core = t_core[which] * sizes
        angle = rng.uniform(0.0, 2.0 * math.pi, n)
    else:
        local = np.zeros((n, 1, 2))
        a = sizes
        # sphero_disk's own expressions, a²θ/2 and a⁴θ/4 with θ = 2π: the same floats as its bodies
        # (a⁴ by Python's pow: numpy's array power rounds some values an ulp apart; 1e6 in 0.1 s)
        area = 0.5 * sizes * sizes * (2.0 * math.pi)
        second = 0.25 * np.array([a**4 for a in sizes.tolist()]) * (2.0 * math.pi)
        core = np.zeros(n)
        angle = np.zeros(n)
    # a random offset of at most pitch/2 − R_i keeps grain i inside its lattice cell
    slack = np.maximum(0.5 * pitch - (core + a), 0.0) * np.sqrt(rng.uniform(0.0, 1.0, n))
    phi = rng.uniform(0.0, 2.0 * math.pi, n)
    position = np.column_stack([gx[keep] + slack * np.cos(phi), gy[keep] + slack * np.sin(phi)])
    return GrainSet(name, shape, r, p, rho, mu, position, angle, a, local, area, second, core, vel)
