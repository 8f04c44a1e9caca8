"""Domains of interaction ("Granular MPM" §3.3, Fig. 4) and the node ranges of the pre-task
(§3.4, appendix Table A1): what decides whether two points interact. Two points interact when they
send data to a common grid node (the pre-task) and their domains of interaction overlap (task 1,
appendix Table A2); a continuum point (no critical density) interacts with every point it shares a
node with."""

import functools

import warp as wp

from ..shape_functions import CORNERS, SUPPORT_NODES, make_stencil
from ..state import make_state_structs
from ..types import kernel, scalar_types

__all__ = ["DEFORMING_DOMAINS", "domains_overlap", "make_domain_of_interaction", "make_node_ranges",
           "make_node_reach"]

#: Shapes whose domain of interaction follows F; for the others it is fixed from the start, and
#: its largest extent is computed once on the host (``static_extent``).
DEFORMING_DOMAINS = ("cpgimp", "cpdi1")


@functools.cache
def _overlap(precision: str):
    t = scalar_types(precision)

    @wp.func
    def project(a: t.vec2, b: t.vec2, n: t.vec2):
        return wp.abs(wp.dot(a, n)) + wp.abs(wp.dot(b, n))

    @wp.func
    def separated(d: t.vec2, a1: t.vec2, b1: t.vec2, a2: t.vec2, b2: t.vec2, n: t.vec2):
        return wp.abs(wp.dot(d, n)) >= project(a1, b1, n) + project(a2, b2, n)

    @wp.func
    def overlap(x1: t.vec2, a1: t.vec2, b1: t.vec2, x2: t.vec2, a2: t.vec2, b2: t.vec2):
        # Task 1 for parallelograms ("Granular MPM" appendix, Fig. A2, CPDI's domains of interaction).
        # Separating-axis test of two parallelograms x ± a ± b: the candidate axes are the edge
        # normals of both; touching (a zero-width overlap) counts as apart, as in Fig. 4(b).
        d = x2 - x1
        if separated(d, a1, b1, a2, b2, t.vec2(-a1[1], a1[0])):
            return False
        if separated(d, a1, b1, a2, b2, t.vec2(-b1[1], b1[0])):
            return False
        if separated(d, a1, b1, a2, b2, t.vec2(-a2[1], a2[0])):
            return False
        if separated(d, a1, b1, a2, b2, t.vec2(-b2[1], b2[0])):
            return False
        return True

    return overlap


def domains_overlap(precision: str):
    """``overlap(x1, a1, b1, x2, a2, b2) -> bool``: whether parallelograms x ± a ± b intersect."""
    return _overlap(precision)


@functools.cache
def make_domain_of_interaction(shape: str, precision: str):
    """``domain(P, p, rho_cr) -> (a, b)``: half-vectors [m] of the domain of interaction of point p.

    "Granular MPM" §3.3: the point's domain scaled about its centre to the critical volume
    V_cr = m / ρ_cr. Original MPM, uGIMP and the B-splines use the initial rectangle (a constant
    square for square seeding, Fig. 4); cpGIMP the rectangle stretched along F's columns; CPDI1 the
    parallelogram F (l_x, 0), F (0, l_y). ρ_cr ≤ 0 (a continuum) keeps the current size.
    """
    t = scalar_types(precision)
    T = t.scalar
    Particles = make_state_structs(precision)[0]

    @wp.func
    def domain(P: Particles, p: int, rho_cr: T):
        h0 = P.half0[p]
        a = t.vec2(h0[0], T(0.0))
        b = t.vec2(T(0.0), h0[1])
        if wp.static(shape == "cpgimp"):
            F = P.F[p]
            a = a * wp.sqrt(F[0, 0] * F[0, 0] + F[1, 0] * F[1, 0])
            b = b * wp.sqrt(F[0, 1] * F[0, 1] + F[1, 1] * F[1, 1])
        if wp.static(shape == "cpdi1"):
            F = P.F[p]
            a = h0[0] * t.vec2(F[0, 0], F[1, 0])
            b = h0[1] * t.vec2(F[0, 1], F[1, 1])
        vol = T(4.0) * wp.abs(a[0] * b[1] - a[1] * b[0])
        if rho_cr > T(0.0) and vol > T(0.0):
            # V_cr = m / ρ_cr ("Granular MPM" §3.3; the rectangle's half-sides of appendix Table A2)
            s = wp.sqrt(P.mass[p] / (rho_cr * vol))
            a = s * a
            b = s * b
        return a, b

    return domain


@functools.cache
def make_node_reach(shape: str, precision: str):
    """``node_reach(P, D, p) -> vec4i``: the range (x0, x1, y0, y1) of grid nodes (indices of one
    layer) that point p's stencil reaches, all corners for CPDI: what the pre-task compares."""

    K = SUPPORT_NODES[shape]
    NC = CORNERS.get(shape, 1)
    Particles, Grid, Domain = make_state_structs(precision)
    stencil = make_stencil(shape, precision)[0]

    @wp.func
    def node_reach(P: Particles, D: Domain, p: int):
        x0 = int(1073741824)
        y0 = int(1073741824)
        x1 = int(-1073741824)
        y1 = int(-1073741824)
        for k in range(wp.static(NC)):
            bx, by, wx, wy, dwx, dwy, g = stencil(P, D, p, k)
            x0 = wp.min(x0, bx)
            y0 = wp.min(y0, by)
            x1 = wp.max(x1, bx + K - 1)
            y1 = wp.max(y1, by + K - 1)
        return wp.vec4i(x0, x1, y0, y1)

    return node_reach


@functools.cache
def make_node_ranges(shape: str, precision: str):
    """Kernel ``node_ranges(P, D, out)`` over the points: each point's node range (``make_node_reach``)
    into ``out`` (N,) vec4i, for the host (``MPMSolver.node_ranges``)."""
    Particles, Grid, Domain = make_state_structs(precision)
    node_reach = make_node_reach(shape, precision)

    @kernel
    def node_ranges(P: Particles, D: Domain, out: wp.array(dtype=wp.vec4i)):
        p = wp.tid()
        out[p] = node_reach(P, D, p)

    return node_ranges
