"""XPIC(m)'s smoothing passes over the points ("Motion integration" eq. 39-40): the grid field
G v*_{k−1} interpolated to the points, then spread back mass-weighted, m − 1 times a step
(``mpmdem.sim.mpm``'s ``xpic_smoothing`` lays them out between the grid updates)."""

import functools

import warp as wp

from .clock import CLOCK_DT
from .shape_functions import CORNERS, SUPPORT_NODES, make_stencil
from .state import make_state_structs
from .transfer_terms import make_point_on_grid
from .types import kernel, scalar_types

__all__ = ["make_xpic_gather", "make_xpic_scatter"]


@functools.cache
def make_xpic_gather(shape: str, precision: str):
    """XPIC smoothing, first half: Particles.tmp = G v*_{k−1} (interpolate ``Grid.vk``)."""
    t = scalar_types(precision)
    K = SUPPORT_NODES[shape]
    NC = CORNERS.get(shape, 1)
    Particles, Grid, Domain = make_state_structs(precision)
    stencil, contribution, on_grid = make_stencil(shape, precision)
    point_on_grid = make_point_on_grid(shape, precision)

    @kernel
    def xpic_gather(P: Particles, G: Grid, D: Domain, clock: wp.array(dtype=wp.float64)):
        p = wp.tid()
        if clock[CLOCK_DT] <= wp.float64(0.0) or not point_on_grid(P, D, G, p):
            return
        v = t.vec2()
        for k in range(wp.static(NC)):
            bx, by, wx, wy, dwx, dwy, g = stencil(P, D, p, k)
            for i in range(wp.static(K)):
                for j in range(wp.static(K)):
                    w, grad = contribution(wx, wy, dwx, dwy, g, i, j, D.inv_h)
                    v = v + w * G.vk[bx + i, by + j]
        P.tmp[p] = v

    return xpic_gather


@functools.cache
def make_xpic_scatter(shape: str, precision: str, *, deterministic: bool = False):
    """XPIC smoothing, second half: Grid.pk += Σ_p N m_p Particles.tmp (mass-weighted P2G)."""
    K = SUPPORT_NODES[shape]
    NC = CORNERS.get(shape, 1)
    Particles, Grid, Domain = make_state_structs(precision)
    stencil, contribution, on_grid = make_stencil(shape, precision)
    point_on_grid = make_point_on_grid(shape, precision)

    @kernel(deterministic=deterministic)
    def xpic_scatter(P: Particles, G: Grid, D: Domain, clock: wp.array(dtype=wp.float64)):
        p = wp.tid()
        if clock[CLOCK_DT] <= wp.float64(0.0) or not point_on_grid(P, D, G, p):
            return
        mv = P.mass[p] * P.tmp[p]
        for k in range(wp.static(NC)):
            bx, by, wx, wy, dwx, dwy, g = stencil(P, D, p, k)
            for i in range(wp.static(K)):
                for j in range(wp.static(K)):
                    w, grad = contribution(wx, wy, dwx, dwy, g, i, j, D.inv_h)
                    wp.atomic_add(G.pk, bx + i, by + j, w * mv)

    return xpic_scatter
