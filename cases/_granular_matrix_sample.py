"""The granular-matrix sample of cases/granular_matrix.py: a pentagon skeleton and the fines in its voids.

Skeleton: random convex pentagons (MPM-SDEM §7 builds its skeleton of random pentagons) on a hexagonal
lattice with random rotations. The lattice pitch is twice the largest bounding radius of the
generated pentagons, so no two pentagons can overlap at any rotation. The lattice fills the
container's width and stops at the highest row that fits under a target height. The lattice is
loose (void fraction ~0.46) and collapses under gravity by about a third of its height, so it is packed
first: a DEM-only run on the CPU (``settle``, the pentagons alone in the container under gravity)
lets it fall and come to rest; the fines are then seeded in the voids of the packed skeleton.
The same seed gives the same packed skeleton for every fines content (MPM-SDEM §7 keeps one
skeleton across its fines contents).

Fines: material points on the lattice of spacing s = h/2 (2 × 2 points per grid cell) over the
container, minus every point whose centre lies within r_p (1 + margin) of a pentagon, a wall or
the floor (so no point starts inside a body or in contact with one: ``Scene.validate`` refuses
the first, the second would start with a spring force). The fines content F is the fraction of
the void area A_v = W × H0 − Σ A_pentagon (the container's inner width W, the skeleton's top H0)
that the points cover (each point s²): F A_v / s² points. They are whole grid cells of candidate
points picked at random, so every height of the sample holds the same share of fines on average;
the clumps fall into the bottoms of their pores while the bar waits.

All lengths in m, areas in m² (per metre of thickness).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import Polygon

from mpmdem import ContactLaw, InputError, Scene, Simulation, random_convex_polygon, rounded_rectangle

#: points closer than r_p (1 + CLEARANCE) to a body are not seeded: no spring force at t = 0
CLEARANCE = 0.05
#: free space between the lattice's bounding circles and the walls, and between neighbours [m]
LATTICE_GAP = 1.0e-3


@dataclass
class Pentagon:
    """One skeleton pentagon: its shape (a Spheropolygon), centroid [m] and angle [rad]."""

    shape: object
    position: tuple[float, float]
    angle: float

    def core(self) -> Polygon:
        """The core polygon in world coordinates (shapely), for distance tests."""
        return Polygon(self.shape.world_vertices(self.position, self.angle))

    def top(self) -> float:
        """Highest point of the rounded pentagon [m]."""
        return float(self.shape.world_vertices(self.position, self.angle)[:, 1].max()) + self.shape.radius


def skeleton(rng: np.random.Generator, width: float, height: float, size: float, sphero: float,
             spread: float = 0.1) -> list[Pentagon]:
    """Pentagons of circumradius size × U(1 − spread, 1 + spread) [m], rounded by ``sphero`` [m], on a
    hexagonal lattice inside [0, width] × [0, height] [m]; rows alternate between n and n − 1 bodies."""
    if not (size > 0.0 and sphero >= 0.0 and 0.0 <= spread < 1.0):
        raise InputError("pentagon size", (size, sphero, spread), "size > 0, sphero radius >= 0, spread in [0, 1)")
    # a generous pool of shapes; the pitch follows the largest of the ones used
    reach = (1.0 + spread) * size + sphero
    cols = int((width - 2.0 * LATTICE_GAP) // (2.0 * reach + LATTICE_GAP))
    rows = int((height - 2.0 * reach - LATTICE_GAP) // (math.sqrt(3.0) * (reach + 0.5 * LATTICE_GAP))) + 1
    if cols < 2 or rows < 1:
        raise InputError("pentagon size", size, f"pentagons small enough for two in a row and one row in "
                         f"{width:g} × {height:g} m")
    shapes = [random_convex_polygon(rng, 5, size * rng.uniform(1.0 - spread, 1.0 + spread), radius=sphero)
              for _ in range(rows * cols)]
    r = max(s.bounding_radius for s in shapes)
    pitch = 2.0 * r + LATTICE_GAP
    cols = int((width - 2.0 * LATTICE_GAP - 2.0 * r) // pitch) + 1
    rise = 0.5 * math.sqrt(3.0) * pitch
    rows = int((height - 2.0 * r - LATTICE_GAP) // rise) + 1
    out = []
    k = 0
    for j in range(rows):
        n = cols if j % 2 == 0 else cols - 1
        x0 = 0.5 * width - 0.5 * (n - 1) * pitch
        y = LATTICE_GAP + r + j * rise
        for i in range(n):
            out.append(Pentagon(shapes[k], (x0 + i * pitch, y), float(rng.uniform(0.0, 2.0 * math.pi))))
            k += 1
    return out


def container(width: float, height: float, thickness: float, sphero: float) -> list[tuple]:
    """(name, Spheropolygon, centre) of the floor and the two side walls [m]: fixed rounded rectangles
    ``thickness`` thick whose inner faces are y = 0, x = 0 and x = width, the walls ``height`` high."""
    return [
        ("floor", rounded_rectangle(width + 2.0 * thickness, thickness, sphero), (0.5 * width, -0.5 * thickness)),
        ("wall_left", rounded_rectangle(thickness, height + thickness, sphero),
         (-0.5 * thickness, 0.5 * (height - thickness))),
        ("wall_right", rounded_rectangle(thickness, height + thickness, sphero),
         (width + 0.5 * thickness, 0.5 * (height - thickness))),
    ]


def settle(pentagons: list[Pentagon], walls: list[tuple], width: float, height: float, density: float,
           friction: float, contact: ContactLaw, gravity: float, duration: float,
           device: str = "cpu") -> tuple[list[Pentagon], float]:
    """The skeleton after ``duration`` [s] of falling under ``gravity`` [m/s²] in the container (DEM
    only, on the run's device, no output), at rest again: (the moved pentagons, kinetic / released potential energy at
    the end, a measure of how settled they are)."""
    scene = Scene(domain=((0.0, 0.0), (width, height)), gravity=(0.0, -gravity), contact=contact)
    for name, shape, pos in walls:
        scene.add_rigid_body(shape, density=density, position=pos, motion="fixed", friction=friction, name=name)
    for k, p in enumerate(pentagons):
        scene.add_rigid_body(p.shape, density=density, position=p.position, angle=p.angle, friction=friction,
                             name=f"pentagon{k}")
    sim = Simulation(scene, device=device)
    result = sim.run(duration, frames=1)
    d = result.diagnostics
    released = float(d["energy_gravity"][0] - d["energy_gravity"][-1])
    f = sim.body_fields()
    first = len(walls)
    moved = [Pentagon(p.shape, (float(f["x"][first + k, 0]), float(f["x"][first + k, 1])),
                      float(f["angle"][first + k])) for k, p in enumerate(pentagons)]
    return moved, float(d["energy_kinetic"][-1]) / max(released, 1e-300)


def deepest_overlap(shapes: list, positions: np.ndarray, angles: np.ndarray, moving: np.ndarray) -> float:
    """The largest overlap a_i + a_j − |core_i − core_j| [m] between two of the rounded bodies at these
    centroids [m] and angles [rad], at least one of them ``moving`` (the fixed walls meet at the
    corners by construction); 0 when none touch. The DEM stays meaningful while it is well below the
    sphero radius."""
    cores = [Polygon(s.world_vertices(x, a)) for s, x, a in zip(shapes, positions, angles, strict=True)]
    radius = np.array([s.radius for s in shapes])
    j, i = shapely.STRtree(cores).query(cores, predicate="dwithin", distance=2.0 * radius.max())
    sel = (i < j) & (moving[i] | moving[j])
    i, j = i[sel], j[sel]
    if len(i) == 0:
        return 0.0
    gap = shapely.distance(np.array(cores, dtype=object)[i], np.array(cores, dtype=object)[j])
    return float(max(0.0, (radius[i] + radius[j] - gap).max()))


def solid_area(pentagons: list[Pentagon]) -> float:
    """Σ area of the rounded pentagons [m²]."""
    return float(sum(p.shape.area for p in pentagons))


def void_area(pentagons: list[Pentagon], width: float) -> float:
    """A_v = width × H0 − Σ A_pentagon [m²], H0 the skeleton's top."""
    return width * max(p.top() for p in pentagons) - solid_area(pentagons)


def void_lattice(pentagons: list[Pentagon], width: float, top: float, cell: float, contact_radius: float) -> np.ndarray:
    """(N, 2) lattice points of spacing cell/2 in the container below ``top`` [m] whose centres lie
    farther than r_p (1 + CLEARANCE) from every pentagon, the walls (x = 0, width) and the floor (y = 0)."""
    s = 0.5 * cell
    keep = contact_radius * (1.0 + CLEARANCE)
    x = s * (np.arange(math.floor(width / s)) + 0.5)
    y = s * (np.arange(math.floor(top / s)) + 0.5)
    gx, gy = np.meshgrid(x, y, indexing="xy")
    pts = np.stack([gx.ravel(), gy.ravel()], axis=1)
    pts = pts[(pts[:, 0] > keep) & (pts[:, 0] < width - keep) & (pts[:, 1] > keep)]
    if not pentagons or len(pts) == 0:
        return pts
    cores = [p.core() for p in pentagons]
    radius = np.array([p.shape.radius for p in pentagons])
    points = shapely.points(pts)
    # pairs (pentagon j, point i) whose point centre lies within a_j + r_p (1 + CLEARANCE) of the core
    j, i = shapely.STRtree(points).query(cores, predicate="dwithin", distance=radius + keep)
    near = np.zeros(len(pts), bool)
    near[i] = True
    return pts[~near]


def pick_fines(candidates: np.ndarray, fines: float, voids: float, cell: float,
               rng: np.random.Generator) -> np.ndarray:
    """The fines' points: round(F A_v / s²) of the candidates (s = cell/2), taken a whole grid cell
    at a time in random cell order; InputError when the candidates cannot give that many."""
    s = 0.5 * cell
    need = int(round(fines * voids / (s * s)))
    if need > len(candidates):
        most = len(candidates) * s * s / voids
        raise InputError("--fines", fines, f"a fines content of at most {most:.3f} for this skeleton and grid (the "
                         f"points that fit in the voids clear of the pentagons cover {most:.1%} of the void area; "
                         "a finer --cell-size or larger --pentagon-size leaves more room)")
    if need == 0:
        return np.zeros((0, 2))
    ij = np.floor(candidates / cell).astype(np.int64)
    key = ij[:, 0] * 1_000_003 + ij[:, 1]
    cells, inverse = np.unique(key, return_inverse=True)
    rank = rng.permutation(len(cells))[inverse]  # each point gets its cell's random rank
    order = np.lexsort((np.arange(len(candidates)), rank))
    return candidates[np.sort(order[:need])]
