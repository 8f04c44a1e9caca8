"""Particle-to-grid transfer (P2G) of mass, momentum with its affine term and internal force, for the
whole transfer family ("Motion integration" Table 1): m_I = Σ_p N_I m_p, (mv)_I = Σ_p N_I m_p (V_p
+ C_p (x_I − x_p)) (eq. 19, 23), f_I = −Σ_p V_p σ_p ∇N_I, plus the contact force of the identified
material points, N_I(x_p) f_p^cont (MPM-SDEM eq. 47–48). The variant (shape function, affine term,
which fields move, granular copies, shared-memory tiles) is fixed at build time through
``wp.static``, so each variant compiles to a lean kernel.
"""

import functools

import warp as wp

from .clock import CLOCK_DT, CLOCK_T
from .constitutive import make_derived_state
from .granular import STATUS_DEEP_CLAIM, STATUS_LAYER_OVERFLOW, make_layer_row, slot_words
from .granular.cells import make_cells
from .shape_functions import CORNERS, SUPPORT_NODES, make_stencil
from .state import make_state_structs
from .stencil_loop import make_stencil_loop
from .transfer_terms import copy_row, make_momentum_term, make_point_on_grid
from .types import kernel, scalar_types

__all__ = ["make_p2g"]


@functools.cache
def make_p2g(
    shape: str,
    affine: str,
    precision: str,
    *,
    mass: bool,
    momentum: bool,
    force: bool,
    fused_impulse: bool = False,
    remap: bool = False,
    deterministic: bool = False,
    layered: bool = False,
    staged: bool = False,
    contact: bool = False,
    derived: tuple = (),
    tile: tuple = (),
    rows: bool = False,
    tile_layers: int = 1,
):
    """P2G of mass, momentum (with the affine term) and internal force.

    fused_impulse: add dt·f_int to the momentum (USL with a pure PIC velocity update needs only
    Ṽ, so mass and impulse go in one pass, as in MLS-MPM). remap: write momentum to ``Grid.vm``
    (MUSL's re-mapping of the updated particle velocities). deterministic: run-to-run
    bit-identical float atomics on GPUs. layered: granular mode, each point writes to its
    component's copy of every node (``kernels.granular``); the pass that moves mass claims the
    copies, and a node without a free copy counts into ``status``. staged: points whose release
    time (``P.release``) is still ahead take no part (``Scene.add_points(release_time=...)``).
    contact: the force pass also spreads the point's contact force from rigid bodies,
    f_I += N_I(x_p) f_p^cont (MPM-SDEM eq. 47-48; ``kernels.imp_forces``).
    derived: the material kinds, when every point's stress and volume follow from its F
    (``constitutive.stress_from_deformation``): the force pass computes V σ from F instead of
    reading them (empty: read the stored ones).
    tile: (B, TX, TY) to sum in shared memory (CUDA, large scenes of cell-sorted points,
    ``MPMSolver.p2g_tile``; launched over whole blocks of B threads): the B points of a block add
    their terms into one TX × TY tile of nodes placed at the block's first point, one scatter (and
    block barrier) per stencil node, and the tile's non-empty nodes are then added to the grid,
    one atomic per node and field: about 3 TX TY / B global atomics a point instead of 27 (f32,
    bspline2: 4 × 22 nodes for 64 points). A node outside the tile takes the global atomic as
    before, so any order is right, a cell-sorted one fast. Layered: the tile holds the nodes' first
    copies (layer 0), and a term for another copy takes the global atomic; with ``tile_layers`` L
    it holds the first L copies of each node (L tiles of TX × TY), a term for a deeper copy taking
    the global atomic. Not with deterministic or multi-stencil variants. Empty: one global atomic
    per point and node.
    rows: a point's K stencil rows over K threads (launched over K n threads: thread K p + i takes
    row i of point p), each reading the point and adding its row's K nodes: a small scene's P2G is
    as long as one warp's chain of instructions (bench/README.md, "Where a small step's kernels
    wait"), and a third of the node loop shortens it. Each node still gets its points' terms in
    point order. Not with layered, tiled or multi-stencil variants.
    """
    t = scalar_types(precision)
    T = t.scalar
    K = SUPPORT_NODES[shape]
    NC = CORNERS.get(shape, 1)
    Particles, Grid, Domain = make_state_structs(precision)
    stencil, contribution, on_grid = make_stencil(shape, precision)
    point_on_grid = make_point_on_grid(shape, precision)
    node, point_layers = make_stencil_loop(precision, K, NC, contribution)
    with_contact = contact and (force or fused_impulse)
    has_affine = affine != "none" and momentum
    momentum_term = make_momentum_term(precision, has_affine)
    claim = layered and mass  # the step's first P2G claims the copies (kernels/granular.py)
    # (outside the tent's cells, whose node threads give the copies out, relabels keep the copies
    # between rebuilds: a claim past half the layers asks for one, ``STATUS_DEEP_CLAIM``)
    kept_copies = claim and not make_cells(shape, precision, staged).tent_cells
    layer_row = make_layer_row(insert=True)
    WORDS = slot_words(NC * K * K)
    from_F = bool(derived) and force
    volume_stress = make_derived_state(tuple(derived) or (1,), precision).volume_stress
    tiled = bool(tile)
    if tiled and (deterministic or NC != 1):
        raise ValueError("a tiled P2G is built for single-stencil, non-deterministic variants")
    B, TX, TY = tile if tiled else (1, 1, 1)
    LT = int(tile_layers) if tiled and layered else 1  # copies of a node in the tile
    if not 1 <= int(tile_layers) <= 8 or (int(tile_layers) > 1 and not (tiled and layered)):
        raise ValueError("tile_layers is 1 to 8, above 1 only for a tiled, layered P2G")
    if rows and (layered or tiled or NC != 1):
        raise ValueError("a P2G by stencil rows is built for single-stencil, non-layered, untiled variants")
    ROWS = 1 if rows else K  # rows of the stencil a thread adds
    mom_on = momentum or fused_impulse
    force_on = force and not fused_impulse
    # one shared tile of (mass, momentum, force) per node, the components the pass adds, so that
    # a node costs one scatter (each scatter ends in a block barrier)
    M0 = 0
    P0 = M0 + (1 if mass else 0)
    F0 = P0 + (2 if mom_on else 0)
    SUMS = max(1, F0 + (2 if force_on else 0))
    sums = wp.types.vector(SUMS, T)

    @kernel(deterministic=deterministic)
    def p2g(P: Particles, G: Grid, D: Domain, clock: wp.array(dtype=wp.float64),
            status: wp.array(dtype=wp.int32), materials: wp.array(dtype=t.params)):
        p = wp.tid()
        own_row = int(0)
        if wp.static(rows):
            own_row = p - (p // wp.static(K)) * wp.static(K)
            p = p // wp.static(K)
        dt = T(clock[CLOCK_DT])
        active = True
        lane = int(0)
        threads = int(1)
        ox = int(0)
        oy = int(0)
        if wp.static(tiled):
            # every thread of the block reaches the shared-tile calls: the early returns become
            # "active", and threads past the last point take the last point's data, inactive
            n = P.x.shape[0]
            threads = wp.block_dim()  # B on CUDA; 1 on the CPU, which runs a lane per block
            lane = p - (p // threads) * threads
            first = p - lane  # the block's first point (before p is clamped: the origin is the block's)
            if p >= n:
                active = False
                p = n - 1
            # the tile starts one column left of and two rows below the block's first point (points
            # are sorted by cell column, then by height: the rest of the block lies above it)
            c0 = (P.x[wp.min(first, n - 1)] - D.origin) * D.inv_h
            ox = wp.clamp(int(wp.floor(c0[0])) - 1, 0, D.layer_rows - wp.static(TX))  # (in the first layer)
            oy = wp.clamp(int(wp.floor(c0[1])) - 2, 0, G.mass.shape[1] - wp.static(TY))
            node_sums = wp.tile_zeros(shape=(wp.static(LT * TX), wp.static(TY)), dtype=sums, storage="shared")
        if dt <= T(0.0):
            if wp.static(not tiled):
                return
            active = False
        if wp.static(staged):
            if clock[CLOCK_T] < P.release[p]:
                if wp.static(not tiled):
                    return
                active = False
        if not point_on_grid(P, D, G, p):
            # escaped (or non-finite) point: skipped here, flagged by the status check
            if wp.static(not tiled):
                return
            active = False
        c = (P.x[p] - D.origin) * D.inv_h
        mp = P.mass[p]
        mv = mp * P.v[p]
        mC = t.mat22()
        if wp.static(has_affine):
            # APIC / TPIC: m_p (V_p + C_p (x_i − x_p)) ("Motion integration" eq. 19, 23)
            mC = mp * P.C[p]
        vs = t.mat22()
        if wp.static(force):
            # f_int,i = −Σ_p V_p σ_p ∇N_i(x_p) ("MPM notes" step 4; MPM-SDEM eq. 13)
            if wp.static(from_F):
                vol, sigma = volume_stress(P, p, materials[P.material[p]])
                vs = -vol * sigma
            else:
                vs = -P.vol[p] * P.stress[p]
            if wp.static(fused_impulse):
                vs = vs * dt
        fc = t.vec2()
        if wp.static(with_contact):
            fc = P.fcont[p]
            if wp.static(fused_impulse):
                fc = fc * dt
        comp = int(0)
        packed = wp.vec4i()  # the layer of each stencil node, 8 bits each (Particles.slots)
        claiming = False
        if wp.static(layered):
            packed = point_layers(P, p)
        if wp.static(claim):
            # claim only after a rebuild (prepare voided the layers); a step that keeps the labels
            # keeps the copies and the point's nodes, so the layers kept are still right
            comp = P.comp[p]  # (read alongside the layers, not after them)
            claiming = packed[0] == -1
            if claiming:
                packed = wp.vec4i()
        for k in range(wp.static(NC)):
            bx, by, wx, wy, dwx, dwy, g = stencil(P, D, p, k)
            for r in range(wp.static(ROWS)):
                i = r
                if wp.static(rows):
                    i = own_row  # (this thread's row: the same loop for every thread of a warp)
                for j in range(wp.static(K)):
                    w, grad, gi, gj, n = node(bx, by, wx, wy, dwx, dwy, g, k, i, j, D.inv_h)
                    row = gi
                    if wp.static(layered):
                        if claiming:
                            # claim (or find) the component's copy of the node, and keep its layer
                            row, s = layer_row(G.owner, G.depth, gi, gj, comp, D.layer_rows, D.layers)
                            if row < 0:
                                wp.atomic_add(status, STATUS_LAYER_OVERFLOW, 1)
                            elif wp.static(kept_copies):
                                if 2 * s >= D.layers:
                                    status[STATUS_DEEP_CLAIM] = 1  # (the next relabel frees every copy: ``check``)
                            packed[n // 4] = packed[n // 4] | (s << (8 * (n % 4)))
                        else:
                            row = copy_row(packed, n, gi, D.layer_rows)
                    mom = t.vec2()
                    if wp.static(momentum):
                        mom = momentum_term(w, mv, mC, gi, gj, c, D.h)
                    f = t.vec2()
                    if wp.static(force):
                        f = vs * grad
                        if wp.static(with_contact):
                            f = f + w * fc  # eq. 47
                        if wp.static(fused_impulse):
                            mom = mom + f
                    in_tile = False
                    if wp.static(tiled):
                        li = gi - ox
                        lj = gj - oy
                        in_tile = active and li >= 0 and li < wp.static(TX) and lj >= 0 and lj < wp.static(TY)
                        if wp.static(layered):
                            # the tile holds the nodes' first LT copies (rows gi + l layer_rows, l < LT):
                            # in a dense flow the block's points are one component (l = 0); a deeper
                            # copy takes the global atomic
                            if wp.static(LT == 1):
                                in_tile = in_tile and row == gi
                            else:
                                depth = (row - gi) // D.layer_rows
                                in_tile = in_tile and row >= 0 and depth < wp.static(LT)
                                li = li + depth * wp.static(TX)
                        if not in_tile:
                            li = 0
                            lj = 0
                        term = sums()
                        if wp.static(mass):
                            term[wp.static(M0)] = w * mp
                        if wp.static(mom_on):
                            term[wp.static(P0)] = mom[0]
                            term[wp.static(P0 + 1)] = mom[1]
                        if wp.static(force_on):
                            term[wp.static(F0)] = f[0]
                            term[wp.static(F0 + 1)] = f[1]
                        wp.tile_scatter_add(node_sums, li, lj, term, in_tile)
                    if row >= 0 and active and not in_tile:
                        if wp.static(mass):
                            wp.atomic_add(G.mass, row, gj, w * mp)
                        if wp.static(force_on):
                            wp.atomic_add(G.force, row, gj, f)
                        if wp.static(mom_on):
                            if wp.static(remap):
                                wp.atomic_add(G.vm, row, gj, mom)
                            else:
                                wp.atomic_add(G.mom, row, gj, mom)
        if claiming:
            for word in range(wp.static(WORDS)):
                P.slots[p, word] = packed[word]
        if wp.static(tiled):
            # the block's sums onto the grid, a node per thread, one atomic per field and node
            # that holds something (the last scatter's barrier made the tile complete)
            for e in range(lane, wp.static(LT * TX * TY), threads):
                a = e // wp.static(TY)
                b = e - a * wp.static(TY)
                v = wp.tile_extract(node_sums, a, b)
                held = True
                if wp.static(mass):
                    held = v[wp.static(M0)] != T(0.0)
                elif wp.static(LT > 1):
                    held = False  # (a deeper copy's tile is mostly empty: no atomic of zeros)
                    for q in range(wp.static(SUMS)):
                        held = held or v[q] != T(0.0)
                if held:
                    gi = ox + a
                    if wp.static(LT > 1):
                        depth = a // wp.static(TX)
                        gi = ox + a - depth * wp.static(TX) + depth * D.layer_rows  # (copy ``depth`` of the node)
                    gj = oy + b
                    if wp.static(mass):
                        wp.atomic_add(G.mass, gi, gj, v[wp.static(M0)])
                    if wp.static(mom_on):
                        if wp.static(remap):
                            wp.atomic_add(G.vm, gi, gj, t.vec2(v[wp.static(P0)], v[wp.static(P0 + 1)]))
                        else:
                            wp.atomic_add(G.mom, gi, gj, t.vec2(v[wp.static(P0)], v[wp.static(P0 + 1)]))
                    if wp.static(force_on):
                        wp.atomic_add(G.force, gi, gj, t.vec2(v[wp.static(F0)], v[wp.static(F0 + 1)]))

    return p2g
