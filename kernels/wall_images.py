"""The wall images: ghost nodes beyond fixed and slip walls (the image-point method).

A point near a fixed or slip wall has a mirror image beyond it, which would put on an interior
node what the point puts on the node's ghost image. Folding the ghosts onto their interior mirrors
(``make_fold_ghosts``, or inside a grid update: ``make_fold_node``) gives the nodes next to a wall
a complete support, and giving the ghosts their mirrors' velocities, reflected
(``make_mirror_ghosts``, or read by G2P: ``make_mirrored_source``), makes the interpolated
velocity meet the wall condition at the wall itself. Wide stencils (B-splines, GIMP) so keep their
order of accuracy at walls.

A fixed wall moving along itself at speed U (``moving``, ``Domain.bc_speed``) reflects velocities
about U: an image carries 2U − v, so the fold adds 2U × the ghost's mass to the momentum and the
mirror adds 2U to the reflected velocity. A moving wall has no corner with another wall
(``mpmdem.model.boundaries.check_moving_walls``), so corner images never carry an offset.
"""

import functools

import warp as wp

from .clock import CLOCK_DT
from .granular import make_layer_row
from .state import make_state_structs
from .tiles import make_tiles
from .types import Namespace, kernel, scalar_types
from .wall_kinds import BC_FIXED, BC_FREE

__all__ = ["make_fold_ghosts", "make_fold_node", "make_mirror_ghosts", "make_mirrored_source"]


def _layer_row_find():
    return make_layer_row(insert=False)


@wp.func
def _mirror_node(i: int, j: int, lo: wp.vec2i, hi: wp.vec2i, kinds: wp.vec4i):
    """Interior mirror (si, sj) of a ghost node, the sign of each velocity component, and
    whether the node is a mirrored ghost (beyond a fixed or slip wall)."""
    si = i
    sj = j
    sx = 1.0
    sy = 1.0
    mirrored = False
    if i < lo[0] and (kinds[0] != BC_FREE):
        si = wp.min(2 * lo[0] - i, hi[0])
        sx = -1.0
        if kinds[0] == BC_FIXED:
            sy = -1.0
        mirrored = True
    elif i > hi[0] and (kinds[1] != BC_FREE):
        si = wp.max(2 * hi[0] - i, lo[0])
        sx = -1.0
        if kinds[1] == BC_FIXED:
            sy = -1.0
        mirrored = True
    if j < lo[1] and (kinds[2] != BC_FREE):
        sj = wp.min(2 * lo[1] - j, hi[1])
        sy = -sy
        if kinds[2] == BC_FIXED:
            sx = -sx
        mirrored = True
    elif j > hi[1] and (kinds[3] != BC_FREE):
        sj = wp.max(2 * hi[1] - j, lo[1])
        sy = -sy
        if kinds[3] == BC_FIXED:
            sx = -sx
        mirrored = True
    return si, sj, sx, sy, mirrored


@functools.cache
def make_mirrored_source(layered: bool):
    """``mirrored_source(owner, row, i, j, lo, hi, kinds, layer_rows, layers) -> (src, sj, sx, sy)``:
    where the velocities of node (i, j) (its copy in ``row``, granular mode) are read when the wall
    images are not written (``transfer.make_g2p``'s ``mirror``): the node itself (signs 1), or,
    beyond a fixed or slip wall, its interior mirror with the signs of ``make_mirror_ghosts``, in
    granular mode the mirror's copy of the same component (src −1 where it has none: zero, as
    there). The same values, bit for bit, as reading the ghost after ``mirror_ghosts``."""
    find_row = _layer_row_find()

    @wp.func
    def mirrored_source(owner: wp.array2d(dtype=wp.int32), row: int, i: int, j: int, lo: wp.vec2i, hi: wp.vec2i,
                        kinds: wp.vec4i, layer_rows: int, layers: int):
        si, sj, sx, sy, mirrored = _mirror_node(i, j, lo, hi, kinds)
        src = row
        if not mirrored:
            return src, j, 1.0, 1.0
        if wp.static(layered):
            c = owner[row, j]
            if c < 0:
                return src, j, 1.0, 1.0  # (no copy of a component here: mirror_ghosts leaves it)
            src = find_row(owner, si, sj, c, layer_rows, layers)
        else:
            src = si
        return src, sj, sx, sy

    return mirrored_source


@functools.cache
def make_mirror_ghosts(precision: str, layered: bool = False, pair: bool = False, moving: bool = False):
    """Ghost nodes beyond a fixed or slip wall take the mirrored velocity of the interior:
    ``mirror_ghosts(field, second, D, clock, owner)`` mirrors ``field``, and with ``pair`` also
    ``second`` (two fields in one launch; without it ``second`` is not read). Launched over the
    nodes of ``band`` (``mpmdem.sim.mpm_state.wall_band``: those within two ghost widths of the edge).

    Wide stencils (B-splines) reach one or two nodes past the wall. Setting those ghosts to the
    mirror image of the interior field (odd in every component for a fixed wall, odd in the
    normal component for a slip wall) makes the interpolated velocity satisfy the wall condition
    at the wall itself, instead of clamping a whole layer of material to it. Mirror sources are
    clamped to the interior (boundary nodes included), so no thread reads a node another writes.
    layered (granular mode): a ghost copy mirrors the interior copy of the same component
    (``owner``), zero if that component has none there. moving: a ghost beyond a moving fixed wall
    takes 2U − v (the module docstring).
    """
    t = scalar_types(precision)
    T = t.scalar
    Domain = make_state_structs(precision)[2]
    find_row = _layer_row_find()
    tile_walls = make_tiles(precision).walls

    @wp.func
    def wall_offset(D: Domain, lo: wp.vec2i, hi: wp.vec2i, i: int, j: int):
        # 2U [m/s] of the moving fixed wall that ghost node (i, j) lies beyond (zero if none);
        # lo, hi: the walls' node indices (its tile's)
        ox = T(0.0)
        oy = T(0.0)
        if i < lo[0] and D.bc_kind[0] == BC_FIXED:
            oy = T(2.0) * D.bc_speed[0]
        elif i > hi[0] and D.bc_kind[1] == BC_FIXED:
            oy = T(2.0) * D.bc_speed[1]
        if j < lo[1] and D.bc_kind[2] == BC_FIXED:
            ox = T(2.0) * D.bc_speed[2]
        elif j > hi[1] and D.bc_kind[3] == BC_FIXED:
            ox = T(2.0) * D.bc_speed[3]
        return t.vec2(ox, oy)

    @wp.func
    def reflect(v: t.vec2, D: Domain, lo: wp.vec2i, hi: wp.vec2i, i: int, j: int, sx: float, sy: float):
        u = t.vec2(T(sx) * v[0], T(sy) * v[1])
        if wp.static(moving):
            u = u + wall_offset(D, lo, hi, i, j)
        return u

    @wp.func
    def mirror(field: wp.array2d(dtype=t.vec2), D: Domain, owner: wp.array2d(dtype=wp.int32), lo: wp.vec2i,
               hi: wp.vec2i, i: int, j: int, si: int, sj: int, sx: float, sy: float):
        if wp.static(layered):
            for s in range(D.layers):
                r = s * D.layer_rows + i
                c = owner[r, j]
                if c < 0:
                    break
                src = find_row(owner, si, sj, c, D.layer_rows, D.layers)
                v = t.vec2()
                if src >= 0:
                    v = field[src, sj]
                field[r, j] = reflect(v, D, lo, hi, i, j, sx, sy)
        else:
            v = field[si, sj]
            field[i, j] = reflect(v, D, lo, hi, i, j, sx, sy)

    @kernel
    def mirror_ghosts(field: wp.array2d(dtype=t.vec2), second: wp.array2d(dtype=t.vec2), D: Domain,
                      clock: wp.array(dtype=wp.float64), owner: wp.array2d(dtype=wp.int32),
                      band: wp.array(dtype=wp.vec2i)):
        node = band[wp.tid()]  # a node of one layer near its edge (mpm_state.wall_band)
        i = node[0]
        j = node[1]
        if clock[CLOCK_DT] <= wp.float64(0.0):
            return
        lo, hi, first, end = tile_walls(D, i)  # (the walls of node row i's tile: kernels/tiles.py)
        si, sj, sx, sy, mirrored = _mirror_node(i, j, lo, hi, D.bc_kind)
        if not mirrored:
            return
        mirror(field, D, owner, lo, hi, i, j, si, sj, sx, sy)
        if wp.static(pair):
            mirror(second, D, owner, lo, hi, i, j, si, sj, sx, sy)

    return mirror_ghosts


@wp.func
def _image(i: int, lo: int, hi: int, kind_lo: int, kind_hi: int, first: int, end: int):
    """Ghost node whose mirror is node i (−1 if none), with the wall it lies beyond (0 lo, 1 hi);
    ghosts lie in [first, end) (the grid, or along x the tile: kernels/tiles.py)."""
    if i > lo and (kind_lo != BC_FREE):
        g = 2 * lo - i
        if g >= first:
            return g, 0
    if i < hi and (kind_hi != BC_FREE):
        g = 2 * hi - i
        if g < end:
            return g, 1
    return -1, 0


@functools.cache
def make_fold_node(precision: str, *, mass: bool, momentum: bool, force: bool, remap: bool = False,
                   xpic: bool = False, layered: bool = False, clear_images: bool = False, clear_force: bool = True,
                   moving: bool = False):
    """``fold_node(G, D, i, j)``: fold what points put on the ghost images of node (i, j) back onto
    it (all its copies in use, granular mode); nothing at a node no ghost mirrors. The body of
    ``make_fold_ghosts``, and of a grid update that folds its own node first (``make_grid_update``'s
    ``fold``): a node reads only ghost nodes and writes only itself.

    In a domain narrower than the stencil, ghosts farther out than the opposite wall have no
    interior mirror and are not folded. layered (granular mode): each copy in use of an interior
    node gathers from the ghost copies of its own component (``G.owner``).
    clear_images (a clearing grid update that leaves the ghosts alone, ``make_grid_update``'s
    ``images``): the ghost copies read are cleared here after the read (mass, momentum and, with
    clear_force, force: what the update would clear there), each by the one node that folds it.
    moving: momenta (and XPIC's ``pk``) gathered across a moving fixed wall gain 2U × the ghost's
    mass (the module docstring).
    """
    t = scalar_types(precision)
    T = t.scalar
    Particles, Grid, Domain = make_state_structs(precision)
    find_row = _layer_row_find()
    tile_walls = make_tiles(precision).walls

    @wp.func
    def sign(kind: int, normal_axis: int, axis: int) -> float:
        # image of a velocity component: odd in the wall normal; tangential odd only if fixed
        if axis == normal_axis or kind == BC_FIXED:
            return -1.0
        return 1.0

    @wp.func
    def fold_vec(a: wp.array2d(dtype=t.vec2), r: int, j: int, rx: int, ry: int, gj: int, rxy: int,
                 kx: int, ky: int):
        # rows: r of the node, rx of its x-image (same column j), ry of its y-image (column gj),
        # rxy of the corner image (column gj); −1 where there is none
        v = a[r, j]
        if rx >= 0:
            u = a[rx, j]
            v = v + t.vec2(T(sign(kx, 0, 0)) * u[0], T(sign(kx, 0, 1)) * u[1])
        if ry >= 0:
            u = a[ry, gj]
            v = v + t.vec2(T(sign(ky, 1, 0)) * u[0], T(sign(ky, 1, 1)) * u[1])
        if rxy >= 0:
            u = a[rxy, gj]
            v = v + t.vec2(T(sign(kx, 0, 0) * sign(ky, 1, 0)) * u[0], T(sign(kx, 0, 1) * sign(ky, 1, 1)) * u[1])
        a[r, j] = v

    @wp.func
    def drag(a: wp.array2d(dtype=t.vec2), G: Grid, r: int, j: int, rx: int, ry: int, gj: int, kx: int, ky: int,
             ux: T, uy: T):
        # a moving fixed wall's images carry 2U − v: 2U × the ghost's mass on top of the reflection
        v = a[r, j]
        if rx >= 0 and kx == BC_FIXED:
            v = v + t.vec2(T(0.0), T(2.0) * ux * G.mass[rx, j])
        if ry >= 0 and ky == BC_FIXED:
            v = v + t.vec2(T(2.0) * uy * G.mass[ry, gj], T(0.0))
        a[r, j] = v

    @wp.func
    def fold_copy(G: Grid, D: Domain, r: int, i: int, j: int, gi: int, gj: int, kx: int, ky: int, ux: T,
                  uy: T):
        # node (i, j) of the grid, stored in row r (its copy's row in granular mode), gathers from
        # its images: gi (same column), gj (same row), both (−1: none); kx, ky the walls' kinds
        rx = int(-1)
        ry = int(-1)
        rxy = int(-1)
        if wp.static(layered):
            c = G.owner[r, j]
            if gi >= 0:
                rx = find_row(G.owner, gi, j, c, D.layer_rows, D.layers)
            if gj >= 0:
                ry = find_row(G.owner, i, gj, c, D.layer_rows, D.layers)
            if gi >= 0 and gj >= 0:
                rxy = find_row(G.owner, gi, gj, c, D.layer_rows, D.layers)
        else:
            if gi >= 0:
                rx = gi
            if gj >= 0:
                ry = i
            if gi >= 0 and gj >= 0:
                rxy = gi
        if wp.static(mass):
            m = G.mass[r, j]
            if rx >= 0:
                m += G.mass[rx, j]
            if ry >= 0:
                m += G.mass[ry, gj]
            if rxy >= 0:
                m += G.mass[rxy, gj]
            G.mass[r, j] = m
        if wp.static(momentum):
            if wp.static(remap):
                fold_vec(G.vm, r, j, rx, ry, gj, rxy, kx, ky)
                if wp.static(moving):
                    drag(G.vm, G, r, j, rx, ry, gj, kx, ky, ux, uy)
            else:
                fold_vec(G.mom, r, j, rx, ry, gj, rxy, kx, ky)
                if wp.static(moving):
                    drag(G.mom, G, r, j, rx, ry, gj, kx, ky, ux, uy)
        if wp.static(force):
            fold_vec(G.force, r, j, rx, ry, gj, rxy, kx, ky)
        if wp.static(xpic):
            fold_vec(G.pk, r, j, rx, ry, gj, rxy, kx, ky)
            if wp.static(moving):
                drag(G.pk, G, r, j, rx, ry, gj, kx, ky, ux, uy)
        if wp.static(clear_images):
            if rx >= 0:
                clear_copy(G, rx, j)
            if ry >= 0:
                clear_copy(G, ry, gj)
            if rxy >= 0:
                clear_copy(G, rxy, gj)

    @wp.func
    def clear_copy(G: Grid, r: int, j: int):
        G.mass[r, j] = T(0.0)
        G.mom[r, j] = t.vec2()
        if wp.static(clear_force):
            G.force[r, j] = t.vec2()

    @wp.func
    def fold_node(G: Grid, D: Domain, i: int, j: int):
        lo, hi, first, end = tile_walls(D, i)  # (the walls of node row i's tile: kernels/tiles.py)
        if i < lo[0] or i > hi[0] or j < lo[1] or j > hi[1]:
            return
        gi, wx = _image(i, lo[0], hi[0], D.bc_kind[0], D.bc_kind[1], first, end)
        gj, wy = _image(j, lo[1], hi[1], D.bc_kind[2], D.bc_kind[3], 0, G.mass.shape[1])
        if gi < 0 and gj < 0:
            return  # (most nodes: no ghost mirrors them)
        kx = D.bc_kind[wx]
        ky = D.bc_kind[2 + wy]
        ux = D.bc_speed[wx]
        uy = D.bc_speed[2 + wy]
        if wp.static(layered):
            for s in range(D.layers):
                r = s * D.layer_rows + i
                if G.owner[r, j] < 0:
                    break
                fold_copy(G, D, r, i, j, gi, gj, kx, ky, ux, uy)
        else:
            fold_copy(G, D, i, i, j, gi, gj, kx, ky, ux, uy)

    @wp.func
    def folded_by(G: Grid, D: Domain, i: int, j: int, r: int):
        """Whether copy r of ghost node (i, j) is read by a fold: the interior node that mirrors it
        has (i, j) as its image on each axis it lies out on, and (granular) a copy of the same
        component."""
        lo, hi, first, end = tile_walls(D, i)
        ii = i
        jj = j
        if i < lo[0]:
            ii = 2 * lo[0] - i
        elif i > hi[0]:
            ii = 2 * hi[0] - i
        if j < lo[1]:
            jj = 2 * lo[1] - j
        elif j > hi[1]:
            jj = 2 * hi[1] - j
        if ii < lo[0] or ii > hi[0] or jj < lo[1] or jj > hi[1]:
            return False
        if ii != i:
            gi, wx = _image(ii, lo[0], hi[0], D.bc_kind[0], D.bc_kind[1], first, end)
            if gi != i:
                return False
        if jj != j:
            gj, wy = _image(jj, lo[1], hi[1], D.bc_kind[2], D.bc_kind[3], 0, G.mass.shape[1])
            if gj != j:
                return False
        if wp.static(layered):
            return find_row(G.owner, ii, jj, G.owner[r, j], D.layer_rows, D.layers) >= 0
        return True

    @wp.func
    def leave_ghost(G: Grid, D: Domain, i: int, j: int):
        """Whether node (i, j) is a ghost left out of the update (``make_grid_update``'s ``images``):
        out of the interior only beyond fixed or slip walls. Its copies that no fold reads are
        cleared here; the others by the node that folds them (``clear_images``)."""
        lo, hi, first, end = tile_walls(D, i)
        out_x = i < lo[0] or i > hi[0]
        out_y = j < lo[1] or j > hi[1]
        if not (out_x or out_y):
            return False
        if out_x:
            if (i < lo[0] and D.bc_kind[0] == BC_FREE) or (i > hi[0] and D.bc_kind[1] == BC_FREE):
                return False  # (beyond a free side: a node like any other)
        if out_y:
            if (j < lo[1] and D.bc_kind[2] == BC_FREE) or (j > hi[1] and D.bc_kind[3] == BC_FREE):
                return False
        if wp.static(clear_images):
            if wp.static(layered):
                for s in range(D.layers):
                    r = s * D.layer_rows + i
                    if G.owner[r, j] < 0:
                        break
                    if not folded_by(G, D, i, j, r):
                        clear_copy(G, r, j)
            else:
                if not folded_by(G, D, i, j, i):
                    clear_copy(G, i, j)
        return True

    return Namespace(fold_node=fold_node, leave_ghost=leave_ghost)


@functools.cache
def make_fold_ghosts(precision: str, *, mass: bool, momentum: bool, force: bool, remap: bool = False,
                     xpic: bool = False, layered: bool = False, moving: bool = False):
    """Fold what points put on ghost nodes back onto their interior mirrors.

    This is the image-point method: a point near a fixed or slip wall has a mirror image beyond
    it (velocity reflected as in ``make_mirror_ghosts``), and that image would put on interior
    node k exactly what the point puts on ghost node −k. Adding it makes the nodes next to a wall
    see a complete B-spline/GIMP support, so wide stencils keep their order of accuracy at walls.
    (Exact for slip walls; for fixed walls the odd extension is exact in 1D and a close
    approximation in 2D.) Each interior node gathers its images in a fixed order (no atomics),
    so the fold is deterministic (``make_fold_node``). Launched over the nodes near the grid's
    edge (``mpmdem.sim.mpm_state.wall_band``).
    """
    Particles, Grid, Domain = make_state_structs(precision)
    fold_node = make_fold_node(precision, mass=mass, momentum=momentum, force=force, remap=remap, xpic=xpic,
                               layered=layered, **({"moving": True} if moving else {})).fold_node

    @kernel
    def fold_ghosts(G: Grid, D: Domain, clock: wp.array(dtype=wp.float64), band: wp.array(dtype=wp.vec2i)):
        node = band[wp.tid()]  # a node of one layer near its edge (mpm_state.wall_band)
        if clock[CLOCK_DT] <= wp.float64(0.0):
            return
        fold_node(G, D, node[0], node[1])

    return fold_ghosts
