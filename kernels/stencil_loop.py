"""The steps that the P2G and the G2P (``kernels.transfer``) share in their loop over a point's stencil.

Both kernels run ``for k (sub-stencils): stencil(...); for i, j (nodes): ...``; the node's weight,
gradient, grid indices and its number among the point's nodes come from one ``wp.func`` here, so
the two loops cannot drift apart. Warp inlines it: the loop structure and the order of the
arithmetic are those of the kernels themselves.
"""

import functools

import warp as wp

from .granular import slot_words
from .state import make_state_structs
from .types import scalar_types

__all__ = ["make_stencil_loop"]


@functools.cache
def make_stencil_loop(precision: str, K: int, corners: int, contribution):
    """``node`` and ``point_layers`` of a stencil of ``corners`` sub-stencils of K × K nodes whose
    weights come from ``contribution`` (of ``transfer.make_stencil``).

    ``node(bx, by, wx, wy, dwx, dwy, g, k, i, j, inv_h) -> (w, ∇w, gi, gj, n)``: weight and gradient
    [1/m] of node (gi, gj) = (bx + i, by + j) of sub-stencil k, and its number n among the point's
    corners·K² nodes, under which ``Particles.slots`` keeps the layer of its grid copy (granular
    mode); ``point_layers(P, p)``: point p's layers, 8 bits each.
    """
    t = scalar_types(precision)
    T = t.scalar
    words = slot_words(corners * K * K)
    Particles, Grid, Domain = make_state_structs(precision)
    vecK = wp.types.vector(K, T)

    @wp.func
    def node(bx: int, by: int, wx: vecK, wy: vecK, dwx: vecK, dwy: vecK, g: t.vec2, k: int, i: int, j: int,
             inv_h: T):
        w, grad = contribution(wx, wy, dwx, dwy, g, i, j, inv_h)
        return w, grad, bx + i, by + j, (k * K + i) * K + j

    @wp.func
    def point_layers(P: Particles, p: int):
        packed = wp.vec4i()
        for word in range(wp.static(words)):
            packed[word] = P.slots[p, word]
        return packed

    return node, point_layers
