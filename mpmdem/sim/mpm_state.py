"""Device arrays of the MPM stage: the material points, the background grid and its domain.

Built once from the scene's seeded points (in device order, ``mpmdem.sim.cell_sort.device_order``);
arrays a variant does not use get a placeholder of one element so every kernel takes the same
structs. The granular arrays are in ``mpmdem.sim.granular_state``.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from ..kernels import granular as granular_kernels
from ..kernels import transfer as transfer_kernels
from ..kernels.shape_functions import SUPPORT_NODES
from ..kernels.state import make_state_structs
from ..kernels.types import scalar_types
from ..model.config import SolverConfig
from ..model.finished import Model
from ..model.scene import Scene
from .obstacles import solid_nodes

__all__ = ["GHOST_NODES", "POINT_FIELDS", "STATE_FIELDS", "initial_dt_bound", "make_domain", "make_grid", "make_points",
           "wall_band"]

#: Ghost node layers around the domain, enough for the widest stencil (4 nodes) of a point that
#: sits on, or slightly beyond, the domain boundary.
GHOST_NODES = 3

#: Point arrays that change during a run (what a checkpoint must hold).
STATE_FIELDS = ("x", "v", "C", "F", "stress", "szz", "vol", "strain_energy", "mass", "vol0", "half0", "material",
                "pid")

#: Point arrays a re-sort permutes (``mpmdem.sim.cell_sort``).
POINT_FIELDS = ("x", "v", "C", "F", "stress", "szz", "mass", "vol", "vol0", "half0", "material", "strain_energy",
                "pid")


def _float_type(config: SolverConfig):
    return np.float32 if config.precision == "f32" else np.float64


def make_points(scene: Model, config: SolverConfig, host: dict, order: np.ndarray, mat_index: np.ndarray, *,
                staged: bool, coupled: bool, device):
    """The ``Particles`` struct of the points ``host`` (the model's ``particles``, in device order)."""
    t = scalar_types(config.precision)
    T = _float_type(config)
    n = len(host["mass"])
    Particles = make_state_structs(config.precision)[0]
    eye = np.tile(np.eye(2), (n, 1, 1))
    points = Particles()
    points.x = wp.array(host["x"].astype(T), dtype=t.vec2, device=device)
    points.v = wp.array(host["v"].astype(T), dtype=t.vec2, device=device)
    # APIC/TPIC start from the initial rigid rotation's velocity gradient (zero if none)
    C0 = np.zeros((n, 2, 2))
    for k, b in enumerate(scene.bodies):
        C0[host["body"] == k] = np.array([[0.0, -b.angular_velocity], [b.angular_velocity, 0.0]])
    points.C = wp.array(C0.astype(T), dtype=t.mat22, device=device)
    points.F = wp.array(eye.astype(T), dtype=t.mat22, device=device)
    points.stress = wp.zeros(n, dtype=t.mat22, device=device)
    points.szz = wp.zeros(n, dtype=t.scalar, device=device)
    points.comp = wp.zeros(n if config.granular else 1, dtype=wp.int32, device=device)
    # the grid layer of each stencil node, kept by the step's claiming P2G (kernels/transfer.py)
    nodes = transfer_kernels.CORNERS.get(config.shape, 1) * SUPPORT_NODES[config.shape] ** 2
    points.slots = wp.zeros((n, granular_kernels.slot_words(nodes)) if config.granular else (1, 1), dtype=wp.int32,
                            device=device)
    points.release = wp.array(host["release"] if staged else np.zeros(1), dtype=wp.float64, device=device)
    points.mass = wp.array(host["mass"].astype(T), dtype=t.scalar, device=device)
    points.vol = wp.array(host["vol"].astype(T), dtype=t.scalar, device=device)
    points.vol0 = wp.array(host["vol"].astype(T), dtype=t.scalar, device=device)
    points.half0 = wp.array(host["half"].astype(T), dtype=t.vec2, device=device)
    points.material = wp.array(mat_index, dtype=wp.int32, device=device)
    points.strain_energy = wp.zeros(n, dtype=t.scalar, device=device)
    xpic = config.scheme.xpic
    points.tmp = wp.zeros(n if xpic else 1, dtype=t.vec2, device=device)
    points.pid = wp.array(order.astype(np.int32), dtype=wp.int32, device=device)
    points.fcont = wp.zeros(n if coupled else 1, dtype=t.vec2, device=device)
    return points


def make_grid(scene: Model, config: SolverConfig, layers: int, *, device):
    """The ``Grid`` struct (``layers`` copies of the nodes in granular mode, else one) and its
    shape (layers × rows, columns)."""
    t = scalar_types(config.precision)
    T = _float_type(config)
    Grid = make_state_structs(config.precision)[1]
    nx, ny = scene.cell_counts
    g = GHOST_NODES
    rows = nx + 1 + 2 * g
    shape = (layers * rows, ny + 1 + 2 * g)
    grid = Grid()
    grid.owner = wp.full(shape if config.granular else (1, 1), -1, dtype=wp.int32, device=device)
    runs = (rows, -(-shape[1] // granular_kernels.COPY_RUN)) if config.granular else (1, 1)
    grid.depth = wp.zeros(runs, dtype=wp.int32, device=device)
    solid, normal = solid_nodes(scene, rows, shape[1], GHOST_NODES)
    grid.solid = wp.array(solid, dtype=wp.int32, device=device)
    grid.solid_normal = wp.array(normal.astype(T), dtype=t.vec2, device=device)
    grid.mass = wp.zeros(shape, dtype=t.scalar, device=device)
    grid.mom = wp.zeros(shape, dtype=t.vec2, device=device)
    grid.force = wp.zeros(shape, dtype=t.vec2, device=device)
    grid.v = wp.zeros(shape, dtype=t.vec2, device=device)
    grid.vt = wp.zeros(shape, dtype=t.vec2, device=device)
    grid.vm = wp.zeros(shape if config.update in ("MUSL", "USAVG") else (1, 1), dtype=t.vec2, device=device)
    xpic = config.scheme.xpic
    for name in ("vs", "vk", "pk"):
        setattr(grid, name, wp.zeros(shape if xpic else (1, 1), dtype=t.vec2, device=device))
    return grid, shape


def make_domain(scene: Model, config: SolverConfig, layers: int, min_mass: float):
    """The ``Domain`` struct: grid placement, walls, gravity, damping (``min_mass`` [kg/m]: the
    lightest point, which sets the mass below which a node counts as empty)."""
    t = scalar_types(config.precision)
    Domain = make_state_structs(config.precision)[2]
    nx, ny = scene.cell_counts
    g = GHOST_NODES
    h = scene.cell_size
    (x0, y0), _ = scene.domain
    # tiles (a batch's worlds, kernels/tiles.py): the walls of tile 0, repeated every tile
    tiles = scene.wall_tiles
    wall_cells = tiles.cells if tiles is not None else nx
    domain = Domain()
    domain.origin = t.vec2(x0 - g * h, y0 - g * h)
    domain.h = t.scalar(h)
    domain.inv_h = t.scalar(1.0 / h)
    domain.lo = t.vec2(x0, y0)
    domain.hi = t.vec2(x0 + wall_cells * h, y0 + ny * h)
    domain.node_lo = wp.vec2i(g, g)
    domain.node_hi = wp.vec2i(g + wall_cells, g + ny)
    bcs = [scene.boundaries[s] for s in ("left", "right", "bottom", "top")]
    domain.bc_kind = wp.vec4i(*[b.kind_id for b in bcs])
    domain.bc_mu = t.vec4(*[b.friction for b in bcs])
    domain.bc_speed = t.vec4(*[b.velocity for b in bcs])
    domain.gravity = t.vec2(*scene.gravity)
    domain.gravity_ramp = float(scene.gravity_ramp)
    domain.mass_eps = t.scalar(1.0e-12 * min_mass)
    domain.damping = t.scalar(config.damping)
    domain.layer_rows = nx + 1 + 2 * g
    domain.layers = layers
    domain.tile_rows = tiles.rows if tiles is not None else domain.layer_rows
    return domain


def wall_band(rows: int, cols: int, ghosts: int = GHOST_NODES, tile_rows: int | None = None,
              tile_end: int | None = None) -> np.ndarray:
    """(K, 2) int32: the nodes (i, j) of a layer of ``rows`` × ``cols`` nodes within 2 ``ghosts``
    nodes of its edge, each once: the ghost nodes and the interior nodes they mirror, the only
    nodes the wall images (kernels/wall_images.py: fold_ghosts, mirror_ghosts) touch. Those kernels run
    over this band instead of the whole grid (at 1M points on an H100 they cost 23 µs a step over
    the grid, mostly threads that return at once). Tiles (``WallTiles``, kernels/tiles.py): along x
    the edges of every tile of ``tile_rows`` rows, whose lone grid ends at row ``tile_end``."""
    i, j = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
    w = 2 * ghosts
    il = i % tile_rows if tile_rows else i
    last = (tile_end if tile_rows else rows) - 1
    near = (il <= w) | ((il >= last - w) & (il <= last)) | (j <= w) | (j >= cols - 1 - w)
    return np.stack([i[near], j[near]], axis=1).astype(np.int32)


def initial_dt_bound(scene: Scene | Model, particles: dict | None = None) -> float:
    """Courant bound h / max_p(c_p + |v_p|) [s] of the initial state (κ = 1) of a scene or a finished
    model (``particles``: its ``particles()`` when the caller has them)."""
    if particles is None:
        particles = scene.particles if isinstance(scene, Model) else scene.particles()
    speeds = []
    for k, b in enumerate(scene.bodies):
        sel = particles["body"] == k
        vmax = float(np.linalg.norm(particles["v"][sel], axis=1).max())
        speeds.append(b.material.wave_speed + vmax)
    return scene.cell_size / max(speeds)
