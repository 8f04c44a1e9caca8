"""The disk–disk pass of the DEM: pairs of two sphero-disks without the vertex–edge feature search.

Two sphero-disks (a core of one vertex at the centroid ⊕ a disk of radius a, MPM-SDEM eq. 37) touch
at one spot: the centre distance d = |x_i − x_j| against a_i + a_j (the overlap of eq. 38), normal
along the centre line, one tangential history entry per pair (eq. 43). The general search
(``kernels.dem_contacts``) finds the same single vertex–vertex touch after testing both sides' features;
here the touch is computed directly, with the general search's own force law (``touch_force``),
so the forces are the same floats.

Bodies flagged ``B.disk`` (small disks; the host sets the flags) keep the general lists: each pair
is listed once, by its owner (the lower index), sorted by partner. The pass adds what it needs:

* ``list_incoming`` / ``sort_incoming`` (in the list rebuild): each disk's pairs owned by a lower
  disk, as slot indices sorted by owner (``DiskPairs.incoming``), so every disk sees all its disk
  partners in the order of their indices;
* ``disk_forces`` (each step): one thread a disk gathers its disk–disk forces in that order and adds
  them to its own force and torque with one atomic each. A pair is computed by both its disks, by
  one call of the same function with the same arguments (owner first), so the two results are the
  same bits: the force on one is minus that on the other to the bit. No atomic a pair, no race,
  and the sums are in a fixed order (deterministic on GPUs too).

Tangential history: the owner keeps δ_t in its slot (``Contacts.slip[slot][0]``, as the general
search keeps a vertex–vertex touch), the partner a copy in ``DiskPairs.slip``; both compute the same
δ_t each step from the same value, so the copies stay equal (re-copied at each rebuild). The owner
also keeps the pair's stored energy and dissipated work in its slot (the diagnostics read them there).
Pairs of a disk with any other body (a wall, a polygon, a large disk) stay in the general search.
"""

import functools

import warp as wp

from .clock import CLOCK_DT
from .dem_bodies import STATUS_NEIGHBOR_OVERFLOW, make_dem_structs
from .dem_contacts import make_dem_contacts
from .dem_period import make_dem_period
from .types import Namespace, kernel, scalar_types
from .verlet import make_verlet

__all__ = ["make_disk_pairs"]


@functools.cache
def make_disk_pairs(precision: str, deterministic: bool = False, periodic: bool = False,
                    max_registers: int | None = None):
    """Struct ``DiskPairs`` and kernels ``list_incoming``, ``sort_incoming``, ``disk_forces`` of the
    disk–disk pass for one precision (the structs of ``make_dem_structs(precision)``); ``periodic``:
    x periodic, a pair computed with the partner's image nearest the owner (``kernels.dem_period``);
    ``max_registers``: the register cap of ``disk_forces`` on CUDA (None: the compiler's choice)."""
    t = scalar_types(precision)
    T = t.scalar
    vec2 = t.vec2
    vec4 = t.vec4
    Bodies, Contacts, Params = make_dem_structs(precision)
    contacts = make_dem_contacts(precision, deterministic, periodic)
    image = make_dem_period(precision).image
    touch_force, cross, sort_ids = contacts.touch_force, contacts.cross, make_verlet(precision).sort_ids

    @wp.struct
    class DiskPairs:
        incoming: wp.array(dtype=wp.int32)  # (bodies * K) slots of the disk pairs owned by a lower disk
        fill: wp.array(dtype=wp.int32)  # (bodies) entries appended in a rebuild (0 between rebuilds)
        count: wp.array(dtype=wp.int32)  # (bodies) entries of ``incoming``
        slip: wp.array(dtype=T)  # (bodies * K) the partner's copy of each incoming pair's δ_t [m]

    @kernel
    def list_incoming(B: Bodies, C: Contacts, D: DiskPairs, flags: wp.array(dtype=wp.int32),
                      status: wp.array(dtype=wp.int32)):
        """Each disk–disk slot of disk i (after ``build_lists``) appended to its partner's incoming
        entries; more than K entries count as a neighbour-list overflow."""
        if flags[0] == 0:
            return
        i = wp.tid()
        if B.disk[i] == 0:
            return
        K = C.slots
        for s in range(C.count[i]):
            tid = i * K + s
            j = C.nbr[tid]
            if B.disk[j] != 0:
                r = wp.atomic_add(D.fill, j, 1)
                if r < K:
                    D.incoming[j * K + r] = tid
                else:
                    wp.atomic_add(status, STATUS_NEIGHBOR_OVERFLOW, 1)

    @kernel
    def sort_incoming(C: Contacts, D: DiskPairs, flags: wp.array(dtype=wp.int32)):
        """Body j's incoming entries sorted by slot (so by owner: the order does not depend on the
        order of the appends), counted, and their δ_t copied from the owners' slots (handed over by
        ``build_lists``); the fill counter reset for the next rebuild."""
        if flags[0] == 0:
            return
        j = wp.tid()
        K = C.slots
        n = wp.min(D.fill[j], K)
        D.fill[j] = 0
        D.count[j] = n
        sort_ids(D.incoming, j * K, n)
        for r in range(n):
            D.slip[j * K + r] = C.slip[D.incoming[j * K + r]][0]

    @wp.func
    def disk_pair(B: Bodies, prm: Params, i: int, j: int, slip0: T, dt: T):
        """Disks i (the owner) and j with δ_t = slip0 [m]: (touching, force [N/m] and torque [N m/m] on
        i, on j, δ_t, stored energy [J/m], dissipated work [J/m]). The general search's sums of its one
        vertex–vertex touch (``search_pair``: side 0, X = x_i, N from j towards i), in its order."""
        xi = B.x[i]
        xj = B.x[j]
        if wp.static(periodic):  # (as touch_force: j's image nearest i)
            xj = xj + image(xi, xj, prm)
        reach = B.radius[i] + B.radius[j]
        D = xi - xj
        d = wp.length(D)
        fi = vec2()
        ti = T(0.0)
        fj = vec2()
        tj = T(0.0)
        slip = T(0.0)
        energy = T(0.0)
        lost = wp.vec2d(0.0, 0.0)
        touching = d < reach and d > T(1.0e-12) * reach
        if touching:
            F, p, slip, e_pair, lost_pair = touch_force(B, prm, i, j, 0, xi, D / d, d, reach, B.radius[i], slip0, dt)
            lost = lost + lost_pair
            energy += e_pair
            fi += F
            ti += cross(p - xi, F)
            fj -= F
            tj -= cross(p - xj, F)
        return touching, fi, ti, fj, tj, slip, energy, lost

    @kernel(deterministic=deterministic, max_registers=max_registers)
    def disk_forces(B: Bodies, C: Contacts, D: DiskPairs, prm: Params, clock: wp.array(dtype=wp.float64)):
        """Disk b's disk–disk forces and torques (eq. 39-40), its partners in the order of their
        indices (incoming, then owned), added to its force and torque; the owner's slot updated."""
        b = wp.tid()
        if B.disk[b] == 0:
            return
        K = C.slots
        dt = T(clock[CLOCK_DT])
        n_in = D.count[b]
        f = vec2()
        tq = T(0.0)
        for r in range(n_in + C.count[b]):
            own = r >= n_in
            i = b
            j = b
            at = b * K + r
            slip0 = T(0.0)
            if own:
                at = b * K + r - n_in
                j = C.nbr[at]
                slip0 = C.slip[at][0]
            else:
                i = D.incoming[at] // K
                slip0 = D.slip[at]
            if B.disk[i] != 0 and B.disk[j] != 0:  # (an owned pair with another kind: the general search's)
                touching, fi, ti, fj, tj, slip, energy, lost = disk_pair(B, prm, i, j, slip0, dt)
                if own:
                    f += fi
                    tq += ti
                    # (a pair apart now and at the last step has δ_t and energy 0 stored already: about
                    # half the listed pairs, whose stores are skipped)
                    if touching or slip0 != T(0.0):
                        C.slip[at] = vec4(slip, T(0.0), T(0.0), T(0.0))
                    if touching or C.energy[at] != T(0.0):
                        C.energy[at] = energy
                    if touching:
                        C.dissipated[at] = C.dissipated[at] + lost
                else:
                    f += fj
                    tq += tj
                    if touching or slip0 != T(0.0):
                        D.slip[at] = slip
        wp.atomic_add(B.force, b, f)
        wp.atomic_add(B.torque, b, tq)

    return Namespace(DiskPairs=DiskPairs, list_incoming=list_incoming, sort_incoming=sort_incoming,
                     disk_forces=disk_forces, disk_pair=disk_pair)
