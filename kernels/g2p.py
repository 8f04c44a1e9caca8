"""Grid-to-particle transfer (G2P) for the whole transfer family ("Motion integration" Table 1): the
points' velocity (PIC/FLIP blend, eq. 40 for XPIC), affine matrix (APIC / TPIC), position (eq. 41
for XPIC) and, fused where the scheme allows, the stress update from the nodal velocity gradient.
The variant (shape function, affine term, FLIP fraction, position update, stress field, wall
images, MUSL's re-mapping) is fixed at build time through ``wp.static``, so each variant compiles
to a lean kernel.
"""

import functools

import warp as wp

from .clock import CLOCK_DT, CLOCK_T
from .constitutive import make_point_update
from .grid import WORK_INFLOW, WORK_PLASTIC, make_keep_inside_walls, work_slot
from .periodic import make_wrap_point
from .reductions import make_speed_check
from .shape_functions import CORNERS, SUPPORT_NODES, make_stencil
from .state import make_state_structs
from .stencil_loop import make_stencil_loop
from .tiles import make_tiles
from .transfer_terms import copy_row, make_momentum_term, make_point_on_grid
from .types import kernel, scalar_types
from .wall_images import make_mirrored_source

__all__ = ["make_g2p"]



@functools.cache
def make_g2p(
    shape: str,
    affine: str,
    flip_fraction: float,
    position_mode: str,
    precision: str,
    material_kinds: tuple,
    *,
    velocity: bool,
    position: bool,
    stress: str,
    stress_fraction: float = 1.0,
    density_control: str = "revert",
    critical: bool = False,
    layered: bool = False,
    staged: bool = False,
    derived: bool = False,
    mirror: bool = False,
    remap: bool = False,
    periodic_x: bool = False,
    max_registers: int | None = None,
):
    """G2P: particle velocity, affine matrix, position, and (optionally fused) stress update.

    velocity: update V_p and C_p from Ṽ (and V for FLIP). position: move the points.
    stress: "none", or the grid field whose gradient drives the stress update: "vt" (USL), "v"
    (USF: velocities before the force update) or "vm" (MUSL: re-mapped velocities).
    The variant that moves the points (always the step's last) also does the speed check.
    stress_fraction: the share of dt this stress update covers (0.5 for each half of USAVG).
    density_control, critical: see ``constitutive.make_point_update``; the energy the update
    dissipates goes to the "work_plastic" term of ``work``. layered: granular mode, each point
    reads its component's copy of every node (``kernels.granular``). staged: points not yet
    released stay where they are, untouched. derived: stress and volume follow from F
    (``constitutive.stress_from_deformation``), so the update stores F alone.
    position_mode "xpic": XPIC(m) velocity (eq. 40, from the smoothed field ``Grid.vs``) and
    position (eq. 41) updates; when velocity and position are split (MUSL) the displacement is
    kept in ``Particles.tmp`` between the two kernels.
    mirror: the wall images are read here: a stencil node beyond a fixed or slip wall gives the
    velocities of its interior mirror, reflected (``wall_images.make_mirrored_source``), the values
    ``wall_images.make_mirror_ghosts`` would have written there, so that launch is left out of the step.
    Only where nothing else reads the ghost nodes' velocities between the grid update and G2P.
    remap (with velocity, without position): MUSL's re-mapping P2G in the same thread, once the
    point's new V_p and C_p are stored: m_p (V_p + C_p (x_i − x_p)) N_i into ``Grid.vm`` at the
    point's nodes (copies), the terms ``make_p2g(mass=False, momentum=True, remap=True)`` adds, in
    the same order per node (one launch fewer: a small scene's step is paid per launch).
    periodic_x (with position): a point that left [x0, x1) wraps back (``periodic.make_wrap_point``).
    max_registers: registers per thread on CUDA (``Tuning.g2p_registers``; None: the compiler's choice).
    """
    t = scalar_types(precision)
    T = t.scalar
    K = SUPPORT_NODES[shape]
    NC = CORNERS.get(shape, 1)
    mirrored_source = make_mirrored_source(layered)
    tile_walls = make_tiles(precision).walls
    point_row = make_tiles(precision).row
    Particles, Grid, Domain = make_state_structs(precision)
    stencil, contribution, on_grid = make_stencil(shape, precision)
    point_on_grid = make_point_on_grid(shape, precision)
    node, point_layers = make_stencil_loop(precision, K, NC, contribution)
    point_update = make_point_update(material_kinds, precision, density_control, critical, derived)
    dissipative = critical or any(k >= 2 for k in material_kinds)
    X = float(flip_fraction)
    X_pic = 1.0 - X
    flip = X > 0.0
    xpic = position_mode == "xpic"
    need_v_old = (velocity and (flip or xpic))
    stress_dt = float(stress_fraction)
    apic = affine == "apic"
    taylor = affine == "taylor"
    # For B-splines the APIC inertia-like tensor D_p is a constant (h²/4, h²/3) times I.
    d_const = {"bspline2": 0.25, "bspline3": 1.0 / 3.0}.get(shape, 0.0)
    inv_d = 1.0 / d_const if d_const else 0.0
    need_grad_vt = velocity and (taylor or (apic and d_const == 0.0))
    fused_grad = stress == "vt"
    has_stress = stress != "none"
    speed_check = make_speed_check(precision)
    keep_inside_walls = make_keep_inside_walls(precision)
    wrap_point = make_wrap_point(precision)
    if remap and (position or not velocity):
        raise ValueError("a G2P re-maps the momentum only after a velocity update that moves no point (MUSL)")
    remap_affine = remap and affine != "none"
    momentum_term = make_momentum_term(precision, remap_affine)

    @wp.func
    def read(field: wp.array2d(dtype=t.vec2), row: int, gj: int, sx: float, sy: float):
        # a nodal velocity, reflected where it is a wall image's (``mirror``; row −1: none, zero)
        if wp.static(mirror):
            v = t.vec2()
            if row >= 0:
                v = field[row, gj]
            return t.vec2(T(sx) * v[0], T(sy) * v[1])
        return field[row, gj]

    @wp.func
    def stress_velocity(G: Grid, row: int, gj: int, sx: float, sy: float):
        # the nodal velocity a separate stress update takes: V before the force update (USF) or
        # the re-mapped one (MUSL)
        if wp.static(stress == "vm"):
            return read(G.vm, row, gj, sx, sy)
        return read(G.v, row, gj, sx, sy)

    @kernel(max_registers=max_registers)
    def g2p(
        P: Particles,
        G: Grid,
        D: Domain,
        clock: wp.array(dtype=wp.float64),
        materials: wp.array(dtype=t.params),
        max_speed: wp.array(dtype=wp.float32),
        status: wp.array(dtype=wp.int32),
        work: wp.array(dtype=wp.float64),
    ):
        p = wp.tid()
        dt = T(clock[CLOCK_DT])
        if dt <= T(0.0):
            return
        if wp.static(staged):
            if clock[CLOCK_T] < P.release[p]:
                return
            if wp.static(position) and P.release[p] >= wp.float64(0.0):
                # first step in the scene: book the energy it brings (kinetic + gravity) as inflow
                # work, then mark it as booked (release = −1); points there from t = 0 are in the
                # initial energy already
                if P.release[p] > wp.float64(0.0):
                    vp = P.v[p]
                    e = P.mass[p] * (T(0.5) * wp.dot(vp, vp) - wp.dot(D.gravity, P.x[p]))
                    wp.atomic_add(work, work_slot(WORK_INFLOW, point_row(D, P.x[p][0]), p * 7, D.tile_rows,
                                                  D.layer_rows), wp.float64(e))
                P.release[p] = wp.float64(-1.0)
        if not point_on_grid(P, D, G, p):
            return  # escaped (or non-finite) point: skipped here, flagged by the status check
        c = (P.x[p] - D.origin) * D.inv_h
        v_pic = t.vec2()
        v_old = t.vec2()
        v_s = t.vec2()
        B = t.mat22()
        Dm = t.mat22()
        grad_vt = t.mat22()
        L = t.mat22()
        gsum = t.vec2()
        vref = t.vec2()
        packed = wp.vec4i()  # the layers of the stencil's copies, from the step's claiming P2G
        if wp.static(layered):
            packed = point_layers(P, p)
        for k in range(wp.static(NC)):
            bx, by, wx, wy, dwx, dwy, g = stencil(P, D, p, k)
            at_wall = bool(False)  # (``mirror``: whether this stencil reaches past the walls' node lines)
            wall_lo = D.node_lo
            wall_hi = D.node_hi
            if wp.static(mirror):
                wall_lo, wall_hi, first, end = tile_walls(D, bx)  # (its tile's walls: kernels/tiles.py)
                at_wall = (bx < wall_lo[0] or by < wall_lo[1] or bx + wp.static(K - 1) > wall_hi[0]
                           or by + wp.static(K - 1) > wall_hi[1])
            for i in range(wp.static(K)):
                for j in range(wp.static(K)):
                    w, grad, gi, gj, n = node(bx, by, wx, wy, dwx, dwy, g, k, i, j, D.inv_h)
                    row = gi
                    if wp.static(layered):
                        row = copy_row(packed, n, gi, D.layer_rows)
                        if row < 0:
                            row = gi
                            w = T(0.0)  # a node the point put nothing on (a layer overflow)
                            grad = t.vec2()
                    src = row  # where the node's velocities are read
                    sj = gj
                    sx = 1.0
                    sy = 1.0
                    if wp.static(mirror):
                        if at_wall:
                            src, sj, sx, sy = mirrored_source(G.owner, row, gi, gj, wall_lo, wall_hi,
                                                              D.bc_kind, D.layer_rows, D.layers)
                    vt = read(G.vt, src, sj, sx, sy)
                    if wp.static(velocity or position):
                        v_pic = v_pic + w * vt  # G→P of Ṽ ("Motion integration" eq. 31)
                    if wp.static(need_v_old):
                        v_old = v_old + w * read(G.v, src, sj, sx, sy)
                    if wp.static(velocity and xpic):
                        v_s = v_s + w * G.vs[row, gj]  # G of the smoothed field, eq. 39-40
                    if wp.static(velocity and apic):
                        dpos = (t.vec2(T(gi), T(gj)) - c) * D.h
                        B = B + w * wp.outer(vt, dpos)  # eq. 26
                        if wp.static(d_const == 0.0):
                            Dm = Dm + w * wp.outer(dpos, dpos)  # eq. 27
                    if wp.static(need_grad_vt or fused_grad):
                        grad_vt = grad_vt + wp.outer(vt, grad)  # ∇Ṽ, eq. 22/45
                        if wp.static(layered):
                            if w > T(0.0):
                                gsum = gsum + grad
                    if wp.static(stress == "v" or stress == "vm"):
                        vn = stress_velocity(G, src, sj, sx, sy)
                        L = L + wp.outer(vn, grad)
                        if wp.static(layered):
                            if w > T(0.0):
                                gsum = gsum + grad
                                vref = vref + w * vn
        if wp.static(layered and (need_grad_vt or fused_grad)):
            # ∇Ṽ = Σ (v_i − v_p) ⊗ ∇N_i over the nodes the point puts mass on: equal to Σ v_i ⊗ ∇N_i
            # when it has mass on its whole stencil (Σ ∇N_i = 0), and zero for a lone point of a
            # component sitting on a node line, whose massless neighbour node (v = 0) would
            # otherwise fake a strain rate −v_p/h (points alone on their grid are common here)
            grad_vt = grad_vt - wp.outer(v_pic, gsum)
        if wp.static(layered and (stress == "v" or stress == "vm")):
            L = L - wp.outer(vref, gsum)  # the same for the gradient of V or of the re-mapped field
        if wp.static(fused_grad):
            L = grad_vt
        x_old = P.x[p]
        if wp.static(velocity):
            v_new = v_pic
            if wp.static(flip):
                # FLIP: V_p + G(Ṽ − V) (eq. 33), blended with PIC by X (eq. 37)
                v_flip = P.v[p] + (v_pic - v_old)
                v_new = T(X) * v_flip + T(X_pic) * v_pic
            if wp.static(xpic):
                # XPIC(m): V − (I − S)^m V + G a Δt = G(Vs + Ṽ − V) (eq. 40), and the second
                # order move x + Δt [G Ṽ − ½ G a Δt − ½ (I − S)^m V] (eq. 41)
                v_new = v_s + v_pic - v_old
                dx = dt * (T(0.5) * (v_pic + v_old) - T(0.5) * P.v[p] + T(0.5) * v_s)
                if wp.static(position):
                    P.x[p] = x_old + dx
                else:
                    P.tmp[p] = dx
            P.v[p] = v_new
            if wp.static(apic):
                if wp.static(d_const != 0.0):
                    P.C[p] = B * (T(inv_d) * D.inv_h * D.inv_h)  # C = B D⁻¹, eq. 25
                else:
                    det = wp.determinant(Dm)
                    # D_p is singular for the tent function at a node line: fall back to ∇Ṽ,
                    # which equals B D⁻¹ for any field affine over the support.
                    if wp.abs(det) > T(1.0e-6) * D.h * D.h * D.h * D.h:
                        P.C[p] = B * wp.inverse(Dm)
                    else:
                        P.C[p] = grad_vt
            if wp.static(taylor):
                P.C[p] = grad_vt
        if wp.static(remap):
            # MUSL's re-mapping P2G of the new velocities (``make_p2g``'s remap pass, term by term)
            mp = P.mass[p]
            mv = mp * P.v[p]
            mC = t.mat22()
            if wp.static(remap_affine):
                mC = mp * P.C[p]
            for k in range(wp.static(NC)):
                bx, by, wx, wy, dwx, dwy, g = stencil(P, D, p, k)
                for i in range(wp.static(K)):
                    for j in range(wp.static(K)):
                        w, grad, gi, gj, n = node(bx, by, wx, wy, dwx, dwy, g, k, i, j, D.inv_h)
                        row = gi
                        if wp.static(layered):
                            row = copy_row(packed, n, gi, D.layer_rows)
                        mom = momentum_term(w, mv, mC, gi, gj, c, D.h)
                        if row >= 0:
                            wp.atomic_add(G.vm, row, gj, mom)
        if wp.static(position and not xpic):
            if wp.static(position_mode == "grid"):
                P.x[p] = x_old + dt * v_pic  # eq. 32
            else:
                P.x[p] = x_old + dt * P.v[p]  # eq. 36 / 38
        if wp.static(position and xpic and not velocity):
            P.x[p] = x_old + P.tmp[p]
        if wp.static(position):
            P.x[p] = keep_inside_walls(P.x[p], D)  # no material past a wall, not even by round-off
            if wp.static(periodic_x):
                wrap_point(P, D, p, work)  # back into [x0, x1) (``periodic.make_wrap_point``)
        vol = T(0.0)
        if wp.static(has_stress):
            diss, vol = point_update(P, p, materials[P.material[p]], L, dt * T(stress_dt))
            if wp.static(dissipative):
                if diss != wp.float64(0.0):
                    wp.atomic_add(work, work_slot(WORK_PLASTIC, point_row(D, P.x[p][0]), p * 7, D.tile_rows,
                                                  D.layer_rows), diss)
        if wp.static(position):
            # the kernel that moves the points is the last of the step: it also gathers the
            # CFL speed for the next step and flags non-finite or escaped points
            if wp.static(not has_stress):
                if wp.static(derived):
                    vol = P.vol0[p] * wp.determinant(P.F[p])
                else:
                    vol = P.vol[p]
            speed_check(P, D, materials, p, vol, max_speed, status)

    return g2p
