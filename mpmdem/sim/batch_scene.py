"""Batched scenes: N independent scenes that share every kernel-specialising choice, tiled along x
in one grid so that one simulation (one set of launches per step) advances them all.

World w is its scene translated by X_w along x (a whole number of cells; world 0 at X_0 = 0),
each tile followed by a margin of empty cells wide enough that no stencil or contact reaches from
one world into the next (``margin_cells``). Its points, rigid bodies, grains, obstacles and mass
probes move with it; its points come in the combined scene contiguously and in their own order,
and likewise its rigid bodies and its grains. ``WorldLayout`` keeps where each world went, so
that outputs can be split per world (``mpmdem.sim.batch_run``).

Walls between the tiles (``walled``: worlds with a grid, all as many cells wide). Each tile is its
world's lone grid (ghost nodes, domain, ghost nodes) and empty rows up to the tile's width, and the
left and right walls of every world act on its own tile (``WallTiles``, ``kernels/tiles.py``): a
world's material may lie against its walls as it does alone, and its wall images and clamps are
those of its lone run. Worlds of different widths have no walls between their tiles (a grid obstacle
is not the same condition as a domain side): they stay independent only while their material stays
inside their own domain, so a world whose points reach past its left or right side is failed and
named by the batched run (run it alone), and points may not start near a wall. Top and bottom are
shared: every world must have the same y range.
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass

import numpy as np
import shapely.affinity

from ..errors import InputError
from ..kernels.grid import WORK_SLOTS
from ..model.boundaries import WallTiles
from ..model.config import SolverConfig
from ..model.scene import MPMBody, Obstacle, Scene
from ..model.shapes import SeededPoints, Shape
from .mpm_state import GHOST_NODES

__all__ = ["World", "WorldLayout", "batch_key", "batch_refusal", "combine_scenes", "group_key", "margin_cells",
           "side_refusal", "tile_offsets", "walled"]

#: empty cells between two tiles beyond the contact reach: the widest stencil (cubic B-spline,
#: 4 nodes) plus the ghost layers a point on a side may touch (``mpm_state.GHOST_NODES``)
STENCIL_CELLS = 4


@dataclass(frozen=True)
class World:
    """Where one world of a batch went in the combined scene.

    Attributes:
        index: its place in the batch (0 first).
        scene: its own Scene (untranslated): what its outputs describe.
        offset: X_w [m], its translation along x.
        points: its points in the combined scene's point order (a slice).
        bodies: indices of its DEM bodies in the combined scene's body order (rigid bodies, then grains).
        tile: its tile (walled tiles, ``WallTiles``), None without walls between the tiles.
    """

    index: int
    scene: Scene
    offset: float
    points: slice
    bodies: np.ndarray
    tile: int | None = None

    @property
    def domain(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """Its domain in the combined scene's coordinates [m]."""
        (x0, y0), (x1, y1) = self.scene.domain
        return (x0 + self.offset, y0), (x1 + self.offset, y1)


@dataclass(frozen=True)
class WorldLayout:
    """The worlds of a batch, in order, the margin between their tiles [cells], and whether each
    tile has its world's walls (``walled``)."""

    worlds: tuple[World, ...]
    margin: int
    walls: bool = False

    def world_of_point(self, p: int) -> int:
        """The world of point p (combined scene order)."""
        for w in self.worlds:
            if w.points.start <= p < w.points.stop:
                return w.index
        raise IndexError(p)

    def world_of_body(self, k: int) -> int:
        """The world of DEM body k (combined scene order)."""
        for w in self.worlds:
            if k in w.bodies:
                return w.index
        raise IndexError(k)


def _staged(scene: Scene) -> bool:
    return any(b.release_times is not None and (np.asarray(b.release_times) > 0.0).any() for b in scene.bodies)


def batch_key(scene: Scene, config: SolverConfig) -> str:
    """What the kernels of a run specialise on, and what the worlds of one grid must share, as a
    JSON string: two runs batch together only when their keys are equal. The solver config, the
    cell size, the y range, the four sides' conditions, gravity and its ramp, the contact laws,
    which stages run, staged (released) points, the material kinds and whether there are obstacles."""
    (_, y0), (_, y1) = scene.domain
    return json.dumps({
        "config": config.to_dict(), "cell_size": scene.cell_size, "y": [y0, y1],
        "boundaries": scene.to_dict()["boundaries"], "gravity": list(scene.gravity),
        "gravity_ramp": scene.gravity_ramp,
        "contact": scene.contact.to_dict() if scene.contact else None,
        "coupling_contact": scene.coupling_contact.to_dict() if scene.coupling_contact else None,
        "mpm": scene.has_mpm, "dem": scene.has_dem, "staged": _staged(scene),
        "material_kinds": sorted({b.material.kind_id for b in scene.bodies}),
        "obstacles": bool(scene.obstacles), "allow_initial_overlap": scene.allow_initial_overlap,
    }, sort_keys=True, default=str)


def walled(scenes: list[Scene]) -> bool:
    """Whether these worlds' tiles get their walls (the module docstring): every world has a grid,
    is not periodic in x, and is as many cells wide as the first."""
    if not all(s.has_mpm and s.cell_size and not s.periodic_x for s in scenes):
        return False
    return len({s.cell_counts[0] for s in scenes}) == 1


def side_refusal(scene: Scene, walls: bool = False) -> str | None:
    """Why this scene cannot be a world of a batch (None when it can): x periodic (tiles would join
    it to its neighbours), or, without walls between the tiles (``walls``), material points starting
    within ``STENCIL_CELLS`` cells of a left or right wall (the wall would not hold them)."""
    if scene.periodic_x:
        return "it is periodic in x (tiles along x would join it to its neighbours)"
    if walls or not scene.has_mpm or not scene.cell_size:
        return None
    (x0, _), (x1, _) = scene.domain
    reach = STENCIL_CELLS * scene.cell_size
    for body in scene.bodies:
        x = scene._seed(body).positions[:, 0]
        for side, near in (("left", x.min() - x0 < reach), ("right", x1 - x.max() < reach)):
            if near and scene.boundaries[side].kind != "free":
                return (f"its points start within {STENCIL_CELLS} cells of its {side} wall (a batch of worlds of "
                        "different widths has no walls between them)")
    return None


def group_key(scene: Scene, config: SolverConfig) -> str | None:
    """What a study groups runs by for batching (None: the run goes alone, ``side_refusal`` even with
    walls): ``batch_key``, and for a scene whose material starts near its left or right wall also its
    width in cells, so that it shares a grid only with worlds of its width (whose tiles get walls)."""
    if side_refusal(scene, walls=True):
        return None
    key = batch_key(scene, config)
    return key + f" | walled tiles of {scene.cell_counts[0]} cells" if side_refusal(scene) else key


def batch_refusal(scenes: list[Scene], configs: list[SolverConfig]) -> str | None:
    """Why these runs cannot share one grid (None when they can): a run that cannot be a world
    (``side_refusal``), or the first field of ``batch_key`` that differs from the first run's."""
    if not scenes:
        return "no runs to batch"
    walls = walled(scenes)
    for k, scene in enumerate(scenes):
        why = side_refusal(scene, walls)
        if why:
            return f"run {k} cannot be a world of a batch: {why}"
    first = json.loads(batch_key(scenes[0], configs[0]))
    for k, (scene, config) in enumerate(zip(scenes, configs, strict=True)):
        key = json.loads(batch_key(scene, config))
        for name, value in key.items():
            if value != first[name]:
                return (f"run {k} differs from run 0 in {name} ({value!r} against {first[name]!r}): "
                        "the kernels specialise on it, so these runs cannot share one grid")
    return None


def margin_cells(scenes: list[Scene], config: SolverConfig | None = None) -> int:
    """Empty cells between two tiles' sides: ``STENCIL_CELLS``, plus twice the widest contact reach
    of any world (its points' contact radii, its rigid bodies' and grains' bounding radii, and the
    point–body lists' Verlet skin, h/2 unless the config sets it), plus how far the rigid bodies
    reach past a left and a right side (``_overhang``; in cells), so that no contact list of one
    world lists a body or point of another."""
    h = scenes[0].cell_size
    if not h:
        return STENCIL_CELLS
    skin = (config.imp_skin if config is not None and config.imp_skin else 0.5 * h)
    return STENCIL_CELLS + math.ceil((2.0 * (_reach(scenes) + skin) + _overhang(scenes)) / h - 1e-9)


def _overhang(scenes: list[Scene]) -> float:
    """How far [m] the rigid bodies at their start reach past their world's right side, at most,
    plus the same past a left side (a flume's floor slab or outer wall)."""
    left = right = 0.0
    for s in scenes:
        (x0, _), (x1, _) = s.domain
        for b in s.rigid_bodies:
            c, si = math.cos(b.angle), math.sin(b.angle)
            x = b.position[0] + c * b.shape.vertices[:, 0] - si * b.shape.vertices[:, 1]
            left = max(left, x0 - (float(x.min()) - b.shape.radius))
            right = max(right, float(x.max()) + b.shape.radius - x1)
    return left + right


def _reach(scenes: list[Scene]) -> float:
    """The widest contact reach [m] of any world: contact radii of points, bounding radii of the
    bodies that move (free or kinematic) and of grains."""
    reach = 0.0
    for s in scenes:
        reach = max([reach] + [b.contact_radius or 0.0 for b in s.bodies]
                    + [b.shape.bounding_radius for b in s.rigid_bodies if b.motion != "fixed"]
                    + [float(g.bounding_radius.max()) for g in s.grains if len(g)])
    return reach


def _shape(shape: Shape, dx: float) -> Shape:
    """``shape`` moved dx [m] along x: its outline and the parameters that hold positions (a disk's
    centre, which obstacles and seeding read; a rectangle's corners)."""
    moved = {"center": lambda c: (c[0] + dx, c[1]), "corners": lambda c: (c[0] + dx, c[1], c[2] + dx, c[3])}
    params = tuple((k, moved[k](v) if k in moved else v) for k, v in shape.params)
    return dataclasses.replace(shape, polygon=shapely.affinity.translate(shape.polygon, xoff=dx), params=params)


def _body(scene: Scene, b: MPMBody, dx: float, k: int) -> MPMBody:
    """The MPM body as explicit points translated by dx (seeded in its own scene, so world 0's
    points are bit for bit the lone run's)."""
    pts = scene._seed(b)
    x = pts.positions + np.array([dx, 0.0]) if dx else pts.positions
    velocity = b.velocity
    if callable(velocity) and dx:
        velocity = (lambda f: (lambda x: f(x - np.array([dx, 0.0]))))(velocity)
    return dataclasses.replace(b, name=f"w{k}_{b.name}", shape=_shape(b.shape, dx), velocity=velocity,
                               points=SeededPoints(x, pts.volumes, pts.half_sizes))


def tile_rows(scenes: list[Scene], margin: int) -> int:
    """Node rows of one walled tile (``walled``): the first world's lone grid, with its walls
    ``margin`` cells from the next tile's, at least the ghost nodes of both apart."""
    return scenes[0].cell_counts[0] + max(margin, 2 * GHOST_NODES + 1)


def tile_offsets(scenes: list[Scene], margin: int) -> list[float]:
    """X_w [m] of each world: world 0 at 0, each next one with its left side ``margin`` cells past
    the previous tile's right side, on a grid line of the combined grid (DEM-only scenes, without
    a grid: ``margin`` × the widest reach of a body apart). Walled tiles (``walled``): world w's
    left side w tiles (``tile_rows``) right of world 0's."""
    h = scenes[0].cell_size
    (x0, _), _ = scenes[0].domain
    if walled(scenes):
        rows = tile_rows(scenes, margin)
        return [float(x0 - s.domain[0][0] + k * rows * h) for k, s in enumerate(scenes)]
    offsets, right = [], x0
    for k, scene in enumerate(scenes):
        (a, _), (b, _) = scene.domain
        if k == 0:
            dx = 0.0
        elif h:
            dx = x0 - a + math.ceil((right + margin * h - x0) / h - 1e-9) * h
        else:
            dx = right + margin * _reach(scenes) - a
        offsets.append(float(dx))
        right = b + dx
    return offsets


def combine_scenes(scenes: list[Scene], configs: list[SolverConfig], *,
                   offsets: list[float] | None = None) -> tuple[Scene, WorldLayout]:
    """One Scene holding every world, tiled along x (at ``offsets`` [m], default ``tile_offsets``),
    and its layout. InputError, naming the difference, when the runs do not share what the kernels
    specialise on (``batch_refusal``)."""
    reason = batch_refusal(scenes, configs)
    if reason:
        raise InputError("batch", f"{len(scenes)} runs", f"runs that can share one grid: {reason}")
    first = scenes[0]
    h = first.cell_size
    margin = margin_cells(scenes, configs[0])
    offsets = tile_offsets(scenes, margin) if offsets is None else list(offsets)
    (x0, y0), (_, y1) = first.domain
    right = max(s.domain[1][0] + dx for s, dx in zip(scenes, offsets, strict=True))
    tiles, slots = None, [None] * len(scenes)
    if walled(scenes):
        tiles, slots = _wall_tiles(scenes, offsets, tile_rows(scenes, margin))
        right = x0 + ((tiles.count - 1) * tiles.rows + tiles.cells) * h
    elif h:  # (a wall side must lie on a grid line)
        right = x0 + math.ceil((right - x0) / h - 1e-9) * h
    combined = Scene(domain=((x0, y0), (right, y1)), cell_size=h, gravity=first.gravity,
                     boundaries=dict(first.boundaries), gravity_ramp=first.gravity_ramp,
                     contact=first.contact, coupling_contact=first.coupling_contact,
                     allow_initial_overlap=first.allow_initial_overlap, wall_tiles=tiles)
    worlds, grain_sets, n_points, n_rigid = [], [], 0, 0
    for k, (scene, dx) in enumerate(zip(scenes, offsets, strict=True)):
        bodies = [_body(scene, body, dx, k) for body in scene.bodies]
        combined.bodies.extend(bodies)
        n_new = sum(len(body.points.volumes) for body in bodies)
        rigid = [dataclasses.replace(r, name=f"w{k}_{r.name}", position=(r.position[0] + dx, r.position[1]))
                 for r in scene.rigid_bodies]
        combined.rigid_bodies.extend(rigid)
        for (mat, name), mu in scene.coupling_friction.items():
            combined.coupling_friction[(mat, f"w{k}_{name}")] = mu
        combined.obstacles.extend(Obstacle(_shape(o.shape, dx), o.kind) for o in scene.obstacles)
        grain_sets += [(k, dataclasses.replace(g, name=f"w{k}_{g.name}", position=g.position + np.array([dx, 0.0])))
                       for g in scene.grains]
        worlds.append([k, scene, dx, slice(n_points, n_points + n_new), list(range(n_rigid, n_rigid + len(rigid)))])
        n_points += n_new
        n_rigid += len(rigid)
    start = n_rigid
    for k, g in grain_sets:  # grains after every rigid body, as a scene holds them
        combined.grains.append(g)
        worlds[k][4].extend(range(start, start + len(g)))
        start += len(g)
    layout = WorldLayout(tuple(World(k, s, dx, pts, np.array(bodies, dtype=np.int64), slots[k])
                               for k, s, dx, pts, bodies in worlds), margin, walls=tiles is not None)
    return combined, layout


def _wall_tiles(scenes: list[Scene], offsets: list[float], rows: int) -> tuple[WallTiles, list[int]]:
    """The walled tiles of worlds at ``offsets`` [m], and each world's tile: each world's left side on
    the left wall of a tile of ``rows`` node rows (tiles may stay empty: a batch started again
    without a failed world keeps the others where they were), in increasing order, at most
    ``kernels.grid.WORK_SLOTS`` tiles (the works' slots are shared by the tiles). InputError otherwise."""
    h = scenes[0].cell_size
    (x0, _), _ = scenes[0].domain
    slots = []
    for k, (s, dx) in enumerate(zip(scenes, offsets, strict=True)):
        at = (s.domain[0][0] + dx - x0) / (rows * h)
        if abs(at - round(at)) > 1e-9 * max(1.0, at) or round(at) < 0 or (slots and round(at) <= slots[-1]):
            raise InputError("offsets", offsets, f"world {k}'s left side on a tile's left wall, a whole number of "
                             f"tiles ({rows} cells of {h:g} m) right of world 0's, one world a tile, in order")
        slots.append(round(at))
    if slots[-1] + 1 > WORK_SLOTS:
        raise InputError("batch", f"{slots[-1] + 1} tiles", f"at most {WORK_SLOTS} tiles (worlds) in one grid")
    return WallTiles(count=slots[-1] + 1, rows=rows, cells=scenes[0].cell_counts[0]), slots
