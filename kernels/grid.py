"""Grid update: nodal velocities from momenta, the explicit force update, boundary conditions."""

import functools

import warp as wp

from .clock import CLOCK_DT, CLOCK_T
from .granular import COPY_RUN
from .state import make_state_structs
from .tiles import make_tiles
from .types import kernel, scalar_types
from .wall_images import make_fold_node
from .wall_kinds import BC_FIXED, BC_FREE, BC_FRICTION, BC_SLIP

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
    "make_grid_update",
    "make_xpic_grid",
]


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
WORK_INFLOW = 3  # energy (kinetic + gravity) that released points bring into the scene, and the
# potential energy of points crossing a periodic side (``transfer.make_g2p``'s ``periodic_x``)
WORK_SLOTS = 1024


@functools.cache
def make_keep_inside_walls(precision: str):
    """``keep_inside_walls(x, D) -> x``: a point position [m] clamped to the domain box (its tile's
    in a batch: kernels/tiles.py) on every side that is a wall (fixed, slip or friction); free sides are left open.

    With image points the interpolated normal velocity vanishes on a wall, so in exact arithmetic a
    point approaching a wall under a stable step never reaches it; in floating point it can land a
    rounding error past it, and an unstable step can carry it across. Neither may put material
    beyond a wall: the position is projected back onto the wall line (Coulomb walls included:
    material may leave them, not pass them).
    """
    t = scalar_types(precision)
    Domain = make_state_structs(precision)[2]
    tile_shift = make_tiles(precision).shift

    @wp.func
    def keep_inside_walls(x: t.vec2, D: Domain):
        y = x
        s = tile_shift(D, x[0])  # (the walls of the tile the point is on: kernels/tiles.py)
        if D.bc_kind[0] != BC_FREE:
            y[0] = wp.max(y[0], D.lo[0] + s)
        if D.bc_kind[1] != BC_FREE:
            y[0] = wp.min(y[0], D.hi[0] + s)
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


@wp.func
def work_slot(term: int, row: int, key: int, tile_rows: int, layer_rows: int) -> int:
    """Address in the works array of a contribution to term ``term`` from node row ``row`` (a point:
    the row it lies on), spread by ``key``: the term's WORK_SLOTS are shared evenly by the grid's
    tiles (kernels/tiles.py), each tile's contributions in its own share, so that a batch's works
    sum per world (one tile: the whole term)."""
    per = WORK_SLOTS // ((layer_rows + tile_rows - 1) // tile_rows)
    return term * WORK_SLOTS + (row // tile_rows) * per + key % per


@functools.cache
def make_boundary(precision: str, bilateral_only: bool = False, moving: bool = False):
    """``boundary(v, D, i, j)``: the wall conditions of every side the node (i, j) is on or beyond
    (the walls of its tile in a batch: kernels/tiles.py).

    bilateral_only: apply only the fixed and slip (Dirichlet) conditions, not the unilateral
    Coulomb walls; used for the start-of-step velocity V (see make_grid_update).
    moving: a fixed wall moves along itself at ``D.bc_speed`` [m/s] (along +x for bottom and top,
    +y for left and right): its nodes take that velocity instead of zero.
    """
    t = scalar_types(precision)
    T = t.scalar
    Domain = make_state_structs(precision)[2]
    apply_bc = make_boundary_condition(precision)
    tile_walls = make_tiles(precision).walls

    @wp.func
    def side(v: t.vec2, kind: int, mu: T, n: t.vec2, speed: T):
        if wp.static(moving):
            if kind == BC_FIXED:
                return speed * t.vec2(wp.abs(n[1]), wp.abs(n[0]))  # (the wall's own velocity)
        if wp.static(bilateral_only):
            if kind == BC_FRICTION:
                return v
        return apply_bc(v, kind, mu, n)

    @wp.func
    def boundary(v: t.vec2, D: Domain, i: int, j: int):
        out = v
        lo, hi, first, end = tile_walls(D, i)  # (the walls of node row i's tile: kernels/tiles.py)
        if i <= lo[0]:
            out = side(out, D.bc_kind[0], D.bc_mu[0], t.vec2(T(-1.0), T(0.0)), D.bc_speed[0])
        if i >= hi[0]:
            out = side(out, D.bc_kind[1], D.bc_mu[1], t.vec2(T(1.0), T(0.0)), D.bc_speed[1])
        if j <= D.node_lo[1]:
            out = side(out, D.bc_kind[2], D.bc_mu[2], t.vec2(T(0.0), T(-1.0)), D.bc_speed[2])
        if j >= D.node_hi[1]:
            out = side(out, D.bc_kind[3], D.bc_mu[3], t.vec2(T(0.0), T(1.0)), D.bc_speed[3])
        return out

    return boundary


@functools.cache
def make_grid_update(precision: str, *, velocity: bool, force: bool, fused_impulse: bool = False,
                     remap: bool = False, damping: bool = False, layered: bool = False, obstacles: bool = False,
                     clear: bool = False, zero_remap: bool = False, fold: tuple = (), images: bool = False,
                     moving: bool = False, copies: int = 4, max_registers: int | None = None):
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
    moving: fixed walls move along themselves (``make_boundary``'s ``moving``); not with fold.
    copies (layered): the copies of a node loaded at once before they are updated (1, 2 or 4;
    ``Tuning.grid_update_copies``). max_registers (layered, CUDA): registers per thread, None for the
    compiler's choice (``Tuning.grid_update_registers``).
    """
    if copies not in (1, 2, 4):
        raise ValueError(f"make_grid_update: copies must be 1, 2 or 4, got {copies}")
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
    if moving and fold:
        raise ValueError("make_grid_update: moving walls fold in their own launch (``make_fold_ghosts``)")
    boundary = make_boundary(precision, moving=moving)
    dirichlet = make_boundary(precision, bilateral_only=True, moving=moving)

    @wp.func
    def push(work: wp.array(dtype=wp.float64), D: Domain, wall: int, axis: int, i: int, j: int, value: T):
        wp.atomic_add(work, work_slot(IMPULSE_BASE + 2 * wall + axis, i, i * 7 + j, D.tile_rows, D.layer_rows),
                      wp.float64(value))

    @wp.func
    def wall_work(v: t.vec2, vb: t.vec2, m: T, D: Domain, G: Grid, i: int, j: int,
                  work: wp.array(dtype=wp.float64)):
        # Wall reaction impulse m Δv acting on the constrained velocity: dW = F·V Δt (eq. 66);
        # zero for fixed and slip walls, negative for a sliding Coulomb wall. At obstacle nodes the
        # opposite impulse −m Δv is what the material exerts on the obstacle (a load cell's reading).
        if vb[0] != v[0] or vb[1] != v[1]:
            wp.atomic_add(work, work_slot(0, i, i * 7 + j, D.tile_rows, D.layer_rows),
                          wp.float64(m * wp.dot(vb - v, vb)))
            if wp.static(obstacles):
                if G.solid[i, j] != 0:
                    on_obstacle = m * (v - vb)
                    push(work, D, 0, 0, i, j, on_obstacle[0])
                    push(work, D, 0, 1, i, j, on_obstacle[1])
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
                # (row i holds a copy of node row ib in granular mode)
                wp.atomic_add(work, work_slot(1, ib, i * 7 + j, D.tile_rows, D.layer_rows),
                              wp.float64(wp.dot(fd, v) * dt))
            # Ṽ = V + a Δt, a = f/m + g ("Motion integration" eq. 28; "MPM notes" steps 5-7)
            G.vt[i, j] = constrain(v + dt * f * inv_m, m, D, G, ib, j, work)

    @kernel(max_registers=max_registers if layered else None)
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
            # ``copies`` copies at a time: their loads leave together, where one copy after another
            # would wait for each (its loads may not pass the stores of the copy before, which for
            # all the compiler knows could alias them); rows past the depth are clamped to the last
            # one and loaded, not updated.
            n = G.depth[i, j // COPY_RUN]
            if n == 1:
                # one component on the whole run (a dense body): copy 0 alone, without the batch
                # (whose registers a capped kernel would spill here too)
                m, mom, fint = load_node(G, i, j)
                update_node(G, D, clock, work, i, i, j, m, mom, fint)
                return
            rows = D.layer_rows
            if wp.static(copies == 1):
                for b in range(n):
                    r = b * rows + i
                    m, mom, fint = load_node(G, r, j)
                    update_node(G, D, clock, work, r, i, j, m, mom, fint)
            elif wp.static(copies == 2):
                for b in range(0, n, 2):
                    r0 = b * rows + i
                    r1 = wp.min(b + 1, n - 1) * rows + i
                    m0, p0, f0 = load_node(G, r0, j)
                    m1, p1, f1 = load_node(G, r1, j)
                    update_node(G, D, clock, work, r0, i, j, m0, p0, f0)
                    if b + 1 < n:
                        update_node(G, D, clock, work, r1, i, j, m1, p1, f1)
            else:
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


@functools.cache
def make_xpic_grid(precision: str, moving: bool = False):
    """(xpic_init, xpic_update) grid kernels of XPIC(m) ("Motion integration" eq. 39-40).

    (I − (I − S)^m) V = Σ_{k=1..m} (−1)^{k+1} C(m,k) S^k V with S = G P_m, and S^k V = G v*_k where
    v*_1 = P_m V is the nodal velocity and v*_k = P_m G v*_{k−1}. xpic_init sets v*_1 and the sum
    m v*_1; each xpic_update (after an xpic gather/scatter pair) normalises v*_k and adds
    coef · v*_k. G2P then interpolates the sum (``Grid.vs``). moving: see ``make_boundary``.
    """
    t = scalar_types(precision)
    T = t.scalar
    Particles, Grid, Domain = make_state_structs(precision)
    boundary = make_boundary(precision, moving=moving)

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
