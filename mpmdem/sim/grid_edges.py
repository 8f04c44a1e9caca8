"""The launches that complete the MPM grid at the domain's edges, after each P2G and each grid update.

* Wall images (``kernels/wall_images.py``): what points put on the ghost nodes beyond a fixed or
  slip wall is folded onto their interior mirrors, and the ghosts take the mirrors' velocities,
  reflected (about the wall's velocity for a moving wall, ``Boundary.velocity``).
* Periodic x (``kernels/periodic.py``): the ghost columns are folded onto the interior columns they
  are images of, and take their velocities back, before the wall images of the bottom and top.

``MPMSolver._build`` asks for them by the fields a P2G scattered (``fold``) and the velocities a grid
update wrote (``mirrored``); where it fuses a fold into the grid update or the mirror into G2P it
reads the ``WallFold`` roles ``fold`` returns and ``mirror_in_g2p``.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from ..kernels import periodic as periodic_kernels
from ..kernels import wall_images as wall_image_kernels
from ..model.config import SolverConfig
from ..model.finished import Model
from .launch_plan import Launch
from .mpm_roles import WallFold
from .mpm_state import GHOST_NODES, wall_band

__all__ = ["GridEdges"]


class GridEdges:
    """The edge launches of one MPM stage (``fold``, ``mirrored``) and the choices they imply.

    Args:
        scene, config: the finished scene and the stage's config.
        grid_dim: (rows, columns) of the nodes of one grid layer.
        G, D, clock: the stage's ``Grid`` and ``Domain`` structs and its clock array.
        device: the Warp device.
        mirror_in_g2p: G2P may read the wall images itself (where the scene has walls and nothing
            keeps the edge launches apart).

    Attributes:
        periodic: x is periodic (``Scene.periodic_x``).
        moving: ``{"moving": True}`` where a fixed wall moves (the kernels' ``moving`` variant),
            else empty: keyword arguments for the grid and wall-image factories.
        unfused: the edge launches stay launches of their own (no fusion into the grid update
            or G2P): periodic scenes and scenes with moving walls.
        mirror_walls: a side is a wall (not free, not periodic): the wall images run.
        wall_band: the nodes near the grid's edge that the wall-image kernels run over.
    """

    def __init__(self, scene: Model, config: SolverConfig, grid_dim: tuple[int, int], *, G, D, clock: wp.array,
                 device, mirror_in_g2p: bool):
        c, s = config, config.scheme
        self.prec, self.layered = c.precision, c.granular
        self.G, self.D, self.clock = G, D, clock
        self.periodic = scene.periodic_x
        self.moving = {"moving": True} if any(b.velocity != 0.0 for b in scene.boundaries.values()) else {}
        self.unfused = self.periodic or bool(self.moving)
        self.mirror_walls = any(b.kind not in ("free", "periodic") for b in scene.boundaries.values())
        # the wall images touch only the nodes near the grid's edge: their kernels run over those
        tiles = scene.wall_tiles
        tiled = {"tile_rows": tiles.rows, "tile_end": tiles.cells + 1 + 2 * GHOST_NODES} if tiles else {}
        band = wall_band(*grid_dim, **tiled) if self.mirror_walls else np.zeros((1, 2), np.int32)
        self.wall_band = wp.array(band, dtype=wp.vec2i, device=device)
        self.band_dim = len(band)
        self.mirror_in_g2p = mirror_in_g2p and self.mirror_walls and not self.unfused
        self.mirror = wall_image_kernels.make_mirror_ghosts(self.prec, layered=self.layered, **self.moving)
        self.mirror_pair = wall_image_kernels.make_mirror_ghosts(self.prec, layered=self.layered, pair=True,
                                                                 **self.moving)
        self.period_dim = (scene.cell_counts[0], grid_dim[1])
        self.copy = []
        if self.periodic:
            copy = periodic_kernels.make_periodic_copy(self.prec, remap=c.update in ("MUSL", "USAVG"), xpic=s.xpic)
            self.copy = [Launch(copy, grid_dim, [self.G, self.D, self.clock])]

    def fold(self, **flags) -> list:
        """The folds after a P2G that scattered the fields of ``flags`` (``make_fold_ghosts``'):
        the periodic images first, so that the wall fold then sees whole columns."""
        G, D, clock = self.G, self.D, self.clock
        out = []
        if self.periodic:
            out.append(Launch(periodic_kernels.make_periodic_fold(self.prec, **flags), self.period_dim, [G, D, clock]))
        if self.mirror_walls:
            kernel = wall_image_kernels.make_fold_ghosts(self.prec, layered=self.layered, **flags, **self.moving)
            out.append(WallFold(Launch(kernel, self.band_dim, [G, D, clock, self.wall_band]), flags))
        return out

    def mirrored(self, *fields) -> list:
        """After a grid update that wrote ``fields``: the periodic copy, then the wall images of
        those fields (which then mirror the ghost rows of the image columns too); none where G2P
        reads the wall images itself."""
        if not self.mirror_walls or not fields or self.mirror_in_g2p:
            return list(self.copy)
        D, G, band = self.D, self.G, self.wall_band
        if len(fields) == 2:  # (V and Ṽ in one launch)
            return self.copy + [Launch(self.mirror_pair, self.band_dim, [*fields, D, self.clock, G.owner, band])]
        return self.copy + [Launch(self.mirror, self.band_dim, [f, f, D, self.clock, G.owner, band]) for f in fields]
