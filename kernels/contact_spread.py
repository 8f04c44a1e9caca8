"""The IMP scheme's contact forces on the grid as a launch of their own: f_I += N_I(x_p) f_p^cont.

The IMP P2G (``kernels.transfer.make_p2g(contact=True)``) adds each point's contact force from
the rigid bodies to its nodes with its internal force (MPM-SDEM eq. 47-48). So P2G must wait for
the contact forces, and a coupled step is one chain: IMP forces, then P2G. Spread by a launch of
its own, the contact forces need not wait for P2G nor P2G for them: on CUDA the two run as
parallel branches of the step's graph (``mpmdem.step_streams``), and this launch follows the
force kernel on its branch. The nodes, the weights and the dt of a fused impulse are P2G's own:
the nodal forces are the same sums, added in another order.
"""

import functools

import warp as wp

from .clock import CLOCK_DT, CLOCK_T
from .shape_functions import CORNERS, SUPPORT_NODES, make_stencil
from .state import make_state_structs
from .stencil_loop import make_stencil_loop
from .transfer import make_point_on_grid
from .types import kernel, scalar_types

__all__ = ["make_contact_spread"]


@functools.cache
def make_contact_spread(shape: str, precision: str, *, fused_impulse: bool, staged: bool = False):
    """``spread(P, G, D, clock)``, a thread a point: the point's contact force f_p^cont [N/m]
    (``Particles.fcont``) onto its stencil's nodes, N_I(x_p) f_p^cont into ``Grid.force`` [N/m]
    (eq. 47), or, with ``fused_impulse`` (a USL step that moves momentum and impulse in one P2G),
    dt N_I(x_p) f_p^cont into ``Grid.mom`` [kg m/s per m]. Points without a contact force, off the
    grid, or (``staged``) not yet released add nothing, as in P2G. Not for granular mode, whose
    node copies only P2G knows."""
    t = scalar_types(precision)
    T = t.scalar
    K = SUPPORT_NODES[shape]
    NC = CORNERS.get(shape, 1)
    Particles, Grid, Domain = make_state_structs(precision)
    stencil, contribution, on_grid = make_stencil(shape, precision)
    point_on_grid = make_point_on_grid(shape, precision)
    node, point_layers = make_stencil_loop(precision, K, NC, contribution)

    @kernel()
    def spread(P: Particles, G: Grid, D: Domain, clock: wp.array(dtype=wp.float64)):
        p = wp.tid()
        fc = P.fcont[p]
        if fc[0] == T(0.0) and fc[1] == T(0.0):
            return
        dt = T(clock[CLOCK_DT])
        if dt <= T(0.0):
            return
        if wp.static(staged):
            if clock[CLOCK_T] < P.release[p]:
                return
        if not point_on_grid(P, D, G, p):
            return
        if wp.static(fused_impulse):
            fc = fc * dt
        for k in range(wp.static(NC)):
            bx, by, wx, wy, dwx, dwy, g = stencil(P, D, p, k)
            for i in range(wp.static(K)):
                for j in range(wp.static(K)):
                    w, grad, gi, gj, n = node(bx, by, wx, wy, dwx, dwy, g, k, i, j, D.inv_h)
                    if wp.static(fused_impulse):
                        wp.atomic_add(G.mom, gi, gj, w * fc)
                    else:
                        wp.atomic_add(G.force, gi, gj, w * fc)

    return spread
