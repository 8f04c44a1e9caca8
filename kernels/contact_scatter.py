"""The "grid" coupling scheme's scatter of the points' contact forces (MPM-SDEM §5.4, MPM-GRID).

Each point's contact force from the rigid bodies goes to one grid node near its contact point,
not through the point's own shape function as in the IMP scheme's P2G (``kernels.transfer``).
"""

import functools

import warp as wp

from .clock import CLOCK_DT
from .state import make_state_structs
from .types import kernel, scalar_types

__all__ = ["make_contact_scatter"]


@functools.cache
def make_contact_scatter(precision: str, *, fused_impulse: bool, deterministic: bool = False):
    """The "grid" coupling scheme (MPM-SDEM §5.4, MPM-GRID, Fig. 17b): each point's contact force
    f_p is applied at the grid node nearest its contact point q, not through the point's own shape
    function (eq. 47). fused_impulse: add dt f to the momentum.

    q lies up to r_p outside the material, so the nearest node may hold little or no mass (a
    huge acceleration, or a force dropped while the body keeps the reaction: both gained energy).
    The node is therefore the nearest of the four around q that holds at least a quarter of the
    largest mass among them; with no mass there, the four around the point itself.
    """
    t = scalar_types(precision)
    T = t.scalar
    Particles, Grid, Domain = make_state_structs(precision)

    @wp.func
    def loaded_node(G: Grid, D: Domain, x: t.vec2):
        c = (x - D.origin) * D.inv_h
        bx = wp.clamp(int(wp.floor(c[0])), 0, D.layer_rows - 2)
        by = wp.clamp(int(wp.floor(c[1])), 0, G.mass.shape[1] - 2)
        heaviest = wp.max(wp.max(G.mass[bx, by], G.mass[bx, by + 1]),
                          wp.max(G.mass[bx + 1, by], G.mass[bx + 1, by + 1]))
        best = int(-1)
        best_d = T(1.0e30)
        for k in range(4):
            gi = bx + k // 2
            gj = by + k % 2
            d = wp.length(c - t.vec2(T(gi), T(gj)))
            if heaviest > T(0.0) and G.mass[gi, gj] >= T(0.25) * heaviest and d < best_d:
                best = k
                best_d = d
        return bx, by, best

    @kernel(deterministic=deterministic)
    def contact_scatter(P: Particles, G: Grid, D: Domain, clock: wp.array(dtype=wp.float64),
                        contact_at: wp.array(dtype=t.vec2)):
        p = wp.tid()
        dt = T(clock[CLOCK_DT])
        f = P.fcont[p]
        if dt <= T(0.0) or (f[0] == T(0.0) and f[1] == T(0.0)):
            return
        if wp.static(fused_impulse):
            f = f * dt
        bx, by, k = loaded_node(G, D, contact_at[p])
        if k < 0:
            bx, by, k = loaded_node(G, D, P.x[p])
        if k < 0:
            return
        gi = bx + k // 2
        gj = by + k % 2
        if wp.static(fused_impulse):
            wp.atomic_add(G.mom, gi, gj, f)
        else:
            wp.atomic_add(G.force, gi, gj, f)

    return contact_scatter
