"""Grid update: nodal velocities from momenta, the explicit force update, boundary conditions."""

import functools

import warp as wp

from .clock import CLOCK_DT, CLOCK_T
from .granular import COPY_RUN, make_layer_row
from .state import make_state_structs
from .types import Namespace, kernel, scalar_types

__all__ = [
    "BC_FIXED",
    "BC_FREE",
    "BC_FRICTION",
    "BC_SLIP",
    "WORK_INFLOW",
    "WORK_PLASTIC",
    "WORK_SLOTS",
    "WORK_TERMS",
    "WALLS",
    "IMPULSE_BASE",
    "make_boundary",
    "make_boundary_condition",
    "make_fold_ghosts",
    "make_fold_node",
    "make_grid_update",
    "make_mirror_ghosts",
    "make_mirrored_source",
    "make_xpic_grid",
]

BC_FIXED = 0
BC_SLIP = 1
BC_FRICTION = 2
BC_FREE = 3


@functools.cache
def make_boundary_condition(precision: str):
    """``apply_bc(v, kind, mu, n) -> v`` for a node on a wall with outward normal n."""
    t = scalar_types(precision)
    T = t.scalar

    @wp.func
    def apply_bc(v: t.vec2, kind: int, mu: T, n: t.vec2):
        vn = wp.dot(v, n)
        if kind == BC_FIXED:
            return t.vec2()
        if kind == BC_SLIP:
            # roller: no normal motion either way, free tangential motion
            return v - vn * n
        if kind == BC_FRICTION:
            # Coulomb wall: a node moving into the wall loses its normal velocity and its
            # tangential velocity is reduced by μ|Δv_n| (not past zero); a node moving away is free.
            if vn > T(0.0):
                vt = v - vn * n
                s = wp.length(vt)
                if s <= mu * vn:
                    return t.vec2()
                return vt * (T(1.0) - mu * vn / s)
        return v

    return apply_bc


#: Cumulative works accumulated on the device ("Motion integration" eq. 66-68), each spread over
#: WORK_SLOTS addresses to keep atomics uncontended; the host sums the slots at output frames.
WORK_TERMS = ("work_boundary", "work_damping", "work_plastic", "work_inflow")
WORK_PLASTIC = 2
WORK_INFLOW = 3  # energy (kinetic + gravity) that released points bring into the scene
WORK_SLOTS = 1024


@functools.cache
def make_keep_inside_walls(precision: str):
    """``keep_inside_walls(x, D) -> x``: a point position [m] clamped to the domain box on every
    side that is a wall (fixed, slip or friction); free sides are left open.

    With image points the interpolated normal velocity vanishes on a wall, so in exact arithmetic a
    point approaching a wall under a stable step never reaches it; in floating point it can land a
    rounding error past it, and an unstable step can carry it across. Neither may put material
    beyond a wall: the position is projected back onto the wall line (Coulomb walls included:
    material may leave them, not pass them).
    """
    t = scalar_types(precision)
    Domain = make_state_structs(precision)[2]

    @wp.func
    def keep_inside_walls(x: t.vec2, D: Domain):
        y = x
        if D.bc_kind[0] != BC_FREE:
            y[0] = wp.max(y[0], D.lo[0])
        if D.bc_kind[1] != BC_FREE:
            y[0] = wp.min(y[0], D.hi[0])
        if D.bc_kind[2] != BC_FREE:
            y[1] = wp.max(y[1], D.lo[1])
        if D.bc_kind[3] != BC_FREE:
            y[1] = wp.min(y[1], D.hi[1])
        return y

    return keep_inside_walls


#: Cumulative impulse [N s/m] that the material exerts on the obstacles (x, y), stored after the
#: work terms in the same array: a load cell's reading is its change over a frame divided by the
#: frame's duration. Obstacle nodes are plain fixed nodes, so the impulse of their constraint is
#: the whole reaction. (Domain walls are not measured: their image points carry part of the
#: reaction through the folded ghost nodes, which a nodal sum does not capture exactly.)
WALLS = ("obstacles",)
IMPULSE_BASE = len(WORK_TERMS)


#: Registers per thread of the layered (granular) grid update on CUDA, None for the compiler's choice.
GRID_UPDATE_REGISTERS = 32


@wp.func
def work_slot(term: int, i: int, j: int) -> int:
    return term * WORK_SLOTS + (i * 7 + j) % WORK_SLOTS


@functools.cache
def make_boundary(precision: str, bilateral_only: bool = False):
    """``boundary(v, D, i, j)``: the wall conditions of every side the node (i, j) is on or beyond.

    bilateral_only: apply only the fixed and slip (Dirichlet) conditions, not the unilateral
    Coulomb walls; used for the start-of-step velocity V (see make_grid_update).
    """
    t = scalar_types(precision)
    T = t.scalar
    Domain = make_state_structs(precision)[2]
    apply_bc = make_boundary_condition(precision)

    @wp.func
    def side(v: t.vec2, kind: int, mu: T, n: t.vec2):
        if wp.static(bilateral_only):
            if kind == BC_FRICTION:
                return v
        return apply_bc(v, kind, mu, n)

    @wp.func
    def boundary(v: t.vec2, D: Domain, i: int, j: int):
        out = v
        if i <= D.node_lo[0]:
            out = side(out, D.bc_kind[0], D.bc_mu[0], t.vec2(T(-1.0), T(0.0)))
        if i >= D.node_hi[0]:
            out = side(out, D.bc_kind[1], D.bc_mu[1], t.vec2(T(1.0), T(0.0)))
        if j <= D.node_lo[1]:
            out = side(out, D.bc_kind[2], D.bc_mu[2], t.vec2(T(0.0), T(-1.0)))
        if j >= D.node_hi[1]:
            out = side(out, D.bc_kind[3], D.bc_mu[3], t.vec2(T(0.0), T(1.0)))
        return out

    return boundary


@functools.cache
def make_grid_update(precision: str, *, velocity: bool, force: bool, fused_impulse: bool = False,
                     remap: bool = False, damping: bool = False, layered: bool = False, obstacles: bool = False,
                     clear: bool = False, zero_remap: bool = False, fold: tuple = (), images: bool = False):
    """Nodal velocity V = p/m, and/or Ṽ = V + dt (f/m + g), both with the wall conditions.

    fused_impulse: the momentum already holds p + dt f (USL + PIC), so Ṽ = p/m + dt g.
    remap: normalise ``Grid.vm`` (MUSL re-mapped momentum) in place instead of ``Grid.mom``.
    damping: add Cundall's local damping force ("Motion integration" eq. 61-62).
    The work of wall reactions and of the damping force is accumulated into ``work``.
    layered: granular mode, launched over the nodes of one layer; each thread updates the copies
    of its node that components claimed (a prefix of the layers). clear (the step's last grid
    update, when nothing after it reads the nodal mass): zero the mass, momentum and force of the
    nodes (copies) used, so the next step needs no memset of the grid (of every layer).
    zero_remap (MUSL, the update before the re-mapping P2G): zero ``Grid.vm`` at the nodes (copies)
    it visits, which are those that P2G adds to, so the step needs no memset of it.
    obstacles: nodes marked in ``Grid.solid`` (inside a ``Scene.add_obstacle`` shape) are fixed
    (1) or slip along the obstacle's surface (2: no velocity along ``Grid.solid_normal``).
    The reaction impulses on walls and obstacles go to the IMPULSE_BASE slots of ``work``.
    fold: (mass, momentum, force, remap) of ``make_fold_node``: each thread first folds the ghost images
    of its node onto it, in place of a ``fold_ghosts`` launch before (the same sums, in the same
    order). Only where this update writes none of the fields the fold reads at the ghosts (not a
    clearing update, not a re-mapped one), unless ``images``: the ghosts' own threads may run first.
    images (with fold): the ghosts beyond fixed and slip walls are not updated, since nothing
    reads what the update would put there (G2P reads the wall images from the interior,
    ``transfer.make_g2p``'s ``mirror``, and such walls do no work); in a clearing update their
    copies are cleared by the node that folds them, or by their own thread where none does.
    """
    t = scalar_types(precision)
    T = t.scalar
    Particles, Grid, Domain = make_state_structs(precision)
    if fold:
        if (clear or remap) and not images:
            raise ValueError("make_grid_update: fold with clear or remap would race with the ghosts' own threads")
        fold_mass, fold_momentum, fold_force, fold_remap = fold
        folding = make_fold_node(precision, mass=fold_mass, momentum=fold_momentum, force=fold_force,
                                 remap=fold_remap, layered=layered, clear_images=images and clear,
                                 clear_force=not fused_impulse)
        fold_node, leave_ghost = folding.fold_node, folding.leave_ghost
    elif images:
        raise ValueError("make_grid_update: images needs fold (the ghosts' values reach the interior by it)")
    boundary = make_boundary(precision)
    dirichlet = make_boundary(precision, bilateral_only=True)

    @wp.func
    def push(work: wp.array(dtype=wp.float64), wall: int, axis: int, i: int, j: int, value: T):
        wp.atomic_add(work, work_slot(IMPULSE_BASE + 2 * wall + axis, i, j), wp.float64(value))

    @wp.func
    def wall_work(v: t.vec2, vb: t.vec2, m: T, D: Domain, G: Grid, i: int, j: int,
                  work: wp.array(dtype=wp.float64)):
        # Wall reaction impulse m Δv acting on the constrained velocity: dW = F·V Δt (eq. 66);
        # zero for fixed and slip walls, negative for a sliding Coulomb wall. At obstacle nodes the
        # opposite impulse −m Δv is what the material exerts on the obstacle (a load cell's reading).
        if vb[0] != v[0] or vb[1] != v[1]:
            wp.atomic_add(work, work_slot(0, i, j), wp.float64(m * wp.dot(vb - v, vb)))
            if wp.static(obstacles):
                if G.solid[i, j] != 0:
                    on_obstacle = m * (v - vb)
                    push(work, 0, 0, i, j, on_obstacle[0])
                    push(work, 0, 1, i, j, on_obstacle[1])
        return vb

    @wp.func
    def solid(vb: t.vec2, G: Grid, i: int, j: int):
        if wp.static(obstacles):
            kind = G.solid[i, j]
            if kind == 1:
                return t.vec2()
            if kind == 2:
                n = G.solid_normal[i, j]  # a roller: no motion through the surface, either way
                return vb - wp.dot(vb, n) * n
        return vb

    @wp.func
    def constrain(v: t.vec2, m: T, D: Domain, G: Grid, i: int, j: int, work: wp.array(dtype=wp.float64)):
        return wall_work(v, solid(boundary(v, D, i, j), G, i, j), m, D, G, i, j, work)

    @wp.func
    def constrain_start(v: t.vec2, m: T, D: Domain, G: Grid, i: int, j: int, work: wp.array(dtype=wp.float64)):
        return wall_work(v, solid(dirichlet(v, D, i, j), G, i, j), m, D, G, i, j, work)

    @wp.func
    def load_node(G: Grid, i: int, j: int):
        # what the update of node (i, j) reads first: mass, momentum (the re-mapped one with remap)
        # and internal force
        m = G.mass[i, j]
        mom = t.vec2()
        if wp.static(remap):
            mom = G.vm[i, j]
        else:
            mom = G.mom[i, j]
        fint = t.vec2()
        if wp.static(force):
            fint = G.force[i, j]
        return m, mom, fint

    @wp.func
    def update_node(G: Grid, D: Domain, clock: wp.array(dtype=wp.float64), work: wp.array(dtype=wp.float64),
                    i: int, ib: int, j: int, m: T, mom: t.vec2, fint: t.vec2):
        # node (ib, j) of the grid, stored in row i (its copy's row in granular mode), whose mass,
        # momentum and force (``load_node``) are m, mom, fint
        dt = T(clock[CLOCK_DT])
        if wp.static(zero_remap):
            G.vm[i, j] = t.vec2()
        if wp.static(clear):
            # (a node or copy that received nothing is zero already: no stores, which in a run as
            # deep as its busiest node, or outside the material, are most of them. Momentum and
            # force reach only nodes that received mass: P2G weights them alike)
            if m != T(0.0) or mom[0] != T(0.0) or mom[1] != T(0.0) or fint[0] != T(0.0) or fint[1] != T(0.0):
                G.mass[i, j] = T(0.0)
                G.mom[i, j] = t.vec2()
                if wp.static(not fused_impulse):  # (a fused P2G puts its forces into the momentum)
                    G.force[i, j] = t.vec2()
        if m <= D.mass_eps:
            if wp.static(remap):
                G.vm[i, j] = t.vec2()
            else:
                if wp.static(not fused_impulse):  # (PIC after a fused P2G reads Ṽ alone)
                    G.v[i, j] = t.vec2()
                G.vt[i, j] = t.vec2()
            return
        inv_m = T(1.0) / m
        g = D.gravity
        if D.gravity_ramp > wp.float64(0.0):
            g = g * T(wp.min(clock[CLOCK_T] / D.gravity_ramp, wp.float64(1.0)))
        if wp.static(remap):
            G.vm[i, j] = solid(boundary(mom * inv_m, D, ib, j), G, ib, j)
            return
        if wp.static(fused_impulse):
            G.vt[i, j] = constrain(mom * inv_m + dt * g, m, D, G, ib, j, work)
            return
        v = G.v[i, j]
        if wp.static(velocity):
            # Fixed and slip (Dirichlet) nodes keep their prescribed velocity with zero acceleration
            # ("Motion integration" note to eq. 28), so they are constrained in V as in Ṽ and FLIP's
            # Ṽ − V carries no impulse from them (a FLIP disk then rebounds to 0.97 of its drop
            # height, 0.86 if not). A Coulomb wall is a unilateral contact: its impulse must reach
            # the points through Ṽ − V, or FLIP points pressed on it keep their velocity into it and
            # give the energy back when the wall lets go (+30 % on an impact), so V stays free there.
            v = constrain_start(mom * inv_m, m, D, G, ib, j, work)  # eq. 16
            G.v[i, j] = v
        if wp.static(force):
            f = fint + m * g
            if wp.static(damping):
                # Cundall: f_damp = −D |f| ⊙ sign(V), component by component (eq. 61-62)
                fd = t.vec2(-D.damping * wp.abs(f[0]) * wp.sign(v[0]), -D.damping * wp.abs(f[1]) * wp.sign(v[1]))
                if v[0] == T(0.0):
                    fd = t.vec2(T(0.0), fd[1])
                if v[1] == T(0.0):
                    fd = t.vec2(fd[0], T(0.0))
                f = f + fd
                wp.atomic_add(work, work_slot(1, i, j), wp.float64(wp.dot(fd, v) * dt))
            # Ṽ = V + a Δt, a = f/m + g ("Motion integration" eq. 28; "MPM notes" steps 5-7)
            G.vt[i, j] = constrain(v + dt * f * inv_m, m, D, G, ib, j, work)

    @kernel(max_registers=GRID_UPDATE_REGISTERS if layered else None)
    def grid_update(G: Grid, D: Domain, clock: wp.array(dtype=wp.float64), work: wp.array(dtype=wp.float64)):
        i, j = wp.tid()
        if clock[CLOCK_DT] <= wp.float64(0.0):
            return
        if wp.static(images):
            if leave_ghost(G, D, i, j):
                return  # (a ghost beyond a fixed or slip wall: nothing reads its update, ``images``)
        if wp.static(bool(fold)):
            fold_node(G, D, i, j)  # (the wall images onto this node first, ``fold``)
        if wp.static(layered):
            # launched over one layer: the copies in use at a node are a prefix (claimed first-fit);
            # every node of a run goes as deep as the busiest one (COPY_RUN), so that the clearing
            # stores cover whole sectors (copies not in use have no mass and are written zero).
            # Four copies at a time: their loads leave together, where one copy after another would
            # wait for each (its loads may not pass the stores of the copy before, which for all the
            # compiler knows could alias them); rows past the depth are clamped to the last one and
            # loaded, not updated.
            n = G.depth[i, j // COPY_RUN]
            if n == 1:
                # one component on the whole run (a dense body): copy 0 alone, without the batch
                # of four (whose registers a capped kernel would spill here too)
                m, mom, fint = load_node(G, i, j)
                update_node(G, D, clock, work, i, i, j, m, mom, fint)
                return
            rows = D.layer_rows
            for b in range(0, n, 4):
                r0 = b * rows + i
                r1 = wp.min(b + 1, n - 1) * rows + i
                r2 = wp.min(b + 2, n - 1) * rows + i
                r3 = wp.min(b + 3, n - 1) * rows + i
                m0, p0, f0 = load_node(G, r0, j)
                m1, p1, f1 = load_node(G, r1, j)
                m2, p2, f2 = load_node(G, r2, j)
                m3, p3, f3 = load_node(G, r3, j)
                update_node(G, D, clock, work, r0, i, j, m0, p0, f0)
                if b + 1 < n:
                    update_node(G, D, clock, work, r1, i, j, m1, p1, f1)
                if b + 2 < n:
                    update_node(G, D, clock, work, r2, i, j, m2, p2, f2)
                if b + 3 < n:
                    update_node(G, D, clock, work, r3, i, j, m3, p3, f3)
        else:
            m, mom, fint = load_node(G, i, j)
            update_node(G, D, clock, work, i, i, j, m, mom, fint)

    return grid_update


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
def make_mirror_ghosts(precision: str, layered: bool = False, pair: bool = False):
    """Ghost nodes beyond a fixed or slip wall take the mirrored velocity of the interior:
    ``mirror_ghosts(field, second, D, clock, owner)`` mirrors ``field``, and with ``pair`` also
    ``second`` (two fields in one launch; without it ``second`` is not read). Launched over the
    nodes of ``band`` (``mpmdem.mpm_state.wall_band``: those within two ghost widths of the edge).

    Wide stencils (B-splines) reach one or two nodes past the wall. Setting those ghosts to the
    mirror image of the interior field (odd in every component for a fixed wall, odd in the
    normal component for a slip wall) makes the interpolated velocity satisfy the wall condition
    at the wall itself, instead of clamping a whole layer of material to it. Mirror sources are
    clamped to the interior (boundary nodes included), so no thread reads a node another writes.
    layered (granular mode): a ghost copy mirrors the interior copy of the same component
    (``owner``), zero if that component has none there.
    """
    t = scalar_types(precision)
    T = t.scalar
    Domain = make_state_structs(precision)[2]
    find_row = _layer_row_find()

    @wp.func
    def mirror(field: wp.array2d(dtype=t.vec2), D: Domain, owner: wp.array2d(dtype=wp.int32), i: int, j: int,
               si: int, sj: int, sx: float, sy: float):
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
                field[r, j] = t.vec2(T(sx) * v[0], T(sy) * v[1])
        else:
            v = field[si, sj]
            field[i, j] = t.vec2(T(sx) * v[0], T(sy) * v[1])

    @kernel
    def mirror_ghosts(field: wp.array2d(dtype=t.vec2), second: wp.array2d(dtype=t.vec2), D: Domain,
                      clock: wp.array(dtype=wp.float64), owner: wp.array2d(dtype=wp.int32),
                      band: wp.array(dtype=wp.vec2i)):
        node = band[wp.tid()]  # a node of one layer near its edge (mpm_state.wall_band)
        i = node[0]
        j = node[1]
        if clock[CLOCK_DT] <= wp.float64(0.0):
            return
        si, sj, sx, sy, mirrored = _mirror_node(i, j, D.node_lo, D.node_hi, D.bc_kind)
        if not mirrored:
            return
        mirror(field, D, owner, i, j, si, sj, sx, sy)
        if wp.static(pair):
            mirror(second, D, owner, i, j, si, sj, sx, sy)

    return mirror_ghosts


@wp.func
def _image(i: int, lo: int, hi: int, kind_lo: int, kind_hi: int, n: int):
    """Ghost node whose mirror is node i (−1 if none), with the wall it lies beyond (0 lo, 1 hi)."""
    if i > lo and (kind_lo != BC_FREE):
        g = 2 * lo - i
        if g >= 0:
            return g, 0
    if i < hi and (kind_hi != BC_FREE):
        g = 2 * hi - i
        if g < n:
            return g, 1
    return -1, 0


@functools.cache
def make_fold_node(precision: str, *, mass: bool, momentum: bool, force: bool, remap: bool = False,
                   xpic: bool = False, layered: bool = False, clear_images: bool = False, clear_force: bool = True):
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
    """
    t = scalar_types(precision)
    T = t.scalar
    Particles, Grid, Domain = make_state_structs(precision)
    find_row = _layer_row_find()

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
    def fold_copy(G: Grid, D: Domain, r: int, i: int, j: int, gi: int, gj: int, kx: int, ky: int):
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
            else:
                fold_vec(G.mom, r, j, rx, ry, gj, rxy, kx, ky)
        if wp.static(force):
            fold_vec(G.force, r, j, rx, ry, gj, rxy, kx, ky)
        if wp.static(xpic):
            fold_vec(G.pk, r, j, rx, ry, gj, rxy, kx, ky)
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
        lo = D.node_lo
        hi = D.node_hi
        if i < lo[0] or i > hi[0] or j < lo[1] or j > hi[1]:
            return
        gi, wx = _image(i, lo[0], hi[0], D.bc_kind[0], D.bc_kind[1], D.layer_rows)
        gj, wy = _image(j, lo[1], hi[1], D.bc_kind[2], D.bc_kind[3], G.mass.shape[1])
        if gi < 0 and gj < 0:
            return  # (most nodes: no ghost mirrors them)
        kx = D.bc_kind[wx]
        ky = D.bc_kind[2 + wy]
        if wp.static(layered):
            for s in range(D.layers):
                r = s * D.layer_rows + i
                if G.owner[r, j] < 0:
                    break
                fold_copy(G, D, r, i, j, gi, gj, kx, ky)
        else:
            fold_copy(G, D, i, i, j, gi, gj, kx, ky)

    @wp.func
    def folded_by(G: Grid, D: Domain, i: int, j: int, r: int):
        """Whether copy r of ghost node (i, j) is read by a fold: the interior node that mirrors it
        has (i, j) as its image on each axis it lies out on, and (granular) a copy of the same
        component."""
        lo = D.node_lo
        hi = D.node_hi
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
            gi, wx = _image(ii, lo[0], hi[0], D.bc_kind[0], D.bc_kind[1], D.layer_rows)
            if gi != i:
                return False
        if jj != j:
            gj, wy = _image(jj, lo[1], hi[1], D.bc_kind[2], D.bc_kind[3], G.mass.shape[1])
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
        lo = D.node_lo
        hi = D.node_hi
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
                     xpic: bool = False, layered: bool = False):
    """Fold what points put on ghost nodes back onto their interior mirrors.

    This is the image-point method: a point near a fixed or slip wall has a mirror image beyond
    it (velocity reflected as in ``make_mirror_ghosts``), and that image would put on interior
    node k exactly what the point puts on ghost node −k. Adding it makes the nodes next to a wall
    see a complete B-spline/GIMP support, so wide stencils keep their order of accuracy at walls.
    (Exact for slip walls; for fixed walls the odd extension is exact in 1D and a close
    approximation in 2D.) Each interior node gathers its images in a fixed order (no atomics),
    so the fold is deterministic (``make_fold_node``). Launched over the nodes near the grid's
    edge (``mpmdem.mpm_state.wall_band``).
    """
    Particles, Grid, Domain = make_state_structs(precision)
    fold_node = make_fold_node(precision, mass=mass, momentum=momentum, force=force, remap=remap, xpic=xpic,
                               layered=layered).fold_node

    @kernel
    def fold_ghosts(G: Grid, D: Domain, clock: wp.array(dtype=wp.float64), band: wp.array(dtype=wp.vec2i)):
        node = band[wp.tid()]  # a node of one layer near its edge (mpm_state.wall_band)
        if clock[CLOCK_DT] <= wp.float64(0.0):
            return
        fold_node(G, D, node[0], node[1])

    return fold_ghosts


@functools.cache
def make_xpic_grid(precision: str):
    """(xpic_init, xpic_update) grid kernels of XPIC(m) ("Motion integration" eq. 39-40).

    (I − (I − S)^m) V = Σ_{k=1..m} (−1)^{k+1} C(m,k) S^k V with S = G P_m, and S^k V = G v*_k where
    v*_1 = P_m V is the nodal velocity and v*_k = P_m G v*_{k−1}. xpic_init sets v*_1 and the sum
    m v*_1; each xpic_update (after an xpic gather/scatter pair) normalises v*_k and adds
    coef · v*_k. G2P then interpolates the sum (``Grid.vs``).
    """
    t = scalar_types(precision)
    T = t.scalar
    Particles, Grid, Domain = make_state_structs(precision)
    boundary = make_boundary(precision)

    @kernel
    def xpic_init(G: Grid, D: Domain, clock: wp.array(dtype=wp.float64), coef: float):
        i, j = wp.tid()
        if clock[CLOCK_DT] <= wp.float64(0.0):
            return
        v = G.v[i, j]
        G.vk[i, j] = v
        G.vs[i, j] = T(coef) * v

    @kernel
    def xpic_update(G: Grid, D: Domain, clock: wp.array(dtype=wp.float64), coef: float):
        i, j = wp.tid()
        if clock[CLOCK_DT] <= wp.float64(0.0):
            return
        m = G.mass[i, j]
        v = t.vec2()
        if m > D.mass_eps:
            v = boundary(G.pk[i, j] / m, D, i, j)
        G.vk[i, j] = v
        G.vs[i, j] = G.vs[i, j] + T(coef) * v

    return xpic_init, xpic_update
