"""The lock-free union–find over the points that merges interacting pairs into components
("Granular MPM" §3.4 task 2 and appendix Table A3, which groups the points of the interaction array
into grids; here that array is never stored: each interacting pair is merged when it is found).
Every pointer goes up in ``priority``, so concurrent hooks keep the forest acyclic and its roots
independent of thread order."""

import warp as wp

__all__ = ["find", "priority", "unite"]


@wp.func
def priority(i: int):
    """A fixed pseudo-random order of the points for the union–find (a multiplicative hash of the
    index, a bijection of the 32-bit integers): a component's root is its point of highest
    priority. Hooking the larger index under the smaller instead lines the hooks up along the
    cell-sorted order of a dense body, whose neighbours have nearby indices, into chains that every
    later search walks: a dense flow's merges took twice as long (H100, 262k and 1M points)."""
    return wp.uint32(i) * wp.uint32(2654435761)


@wp.func
def find(parent: wp.array(dtype=wp.int32), x: int):
    # root of x with path halving: each visited node is re-pointed to its grandparent, so the
    # trees stay shallow even when one component holds every point (a dense body); racing
    # writers only ever point a node at one of its ancestors, which keeps the forest valid
    r = x
    p = parent[r]
    while p != r:
        g = parent[p]
        if g != p:
            parent[r] = g
        r = p
        p = g
    return r


@wp.func
def unite(parent: wp.array(dtype=wp.int32), p: int, q: int):
    # p may be any ancestor of the point (a root it had): roots are only ever hooked under
    # others, so its root is still found from there; returns such an ancestor for the next call.
    # The root of lower ``priority`` is hooked under the other: every pointer goes up in
    # priority, so the forest stays acyclic whatever the order of the hooks
    a = find(parent, p)
    b = find(parent, q)
    while a != b:
        lo = a
        hi = b
        if priority(a) > priority(b):
            lo = b
            hi = a
        old = wp.atomic_cas(parent, lo, lo, hi)
        if old == lo:
            return hi
        a = find(parent, hi)
        b = find(parent, old)
    return a
