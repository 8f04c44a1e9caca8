"""The data of the MPM–DEM coupling by identified material points (MPM-SDEM §4): each point's list
of nearby bodies with the tangential history of its contacts (``Links``), the coupling's parameters
(``Params``, the contact law's constants in the shared ``ContactLaw`` of
``kernels.contact_geometry``), the status codes, and the release gate of staged points.

A point touches a body as a disk of radius r_p (eq. 44–45); it keeps up to IMP_HISTORY (feature
key, δ_t) entries per listed body (eq. 43), carried across steps and list rebuilds.
"""

import functools
from typing import NamedTuple

import warp as wp

from .clock import CLOCK_T
from .contact_geometry import make_contact_geometry
from .dem_bodies import make_dem_structs
from .state import make_state_structs
from .types import scalar_types

__all__ = ["IMP_HISTORY", "STATUS_CELL_OVERFLOW", "STATUS_SIZE", "STATUS_SLOT_OVERFLOW", "ImpStructs",
           "make_imp_structs", "make_release_gate"]

#: Features of one body a point may touch at once (two edges in a concave corner); the kernels
#: spell the vectors of this length out.
IMP_HISTORY = 2

STATUS_SLOT_OVERFLOW = 0
STATUS_CELL_OVERFLOW = 1
STATUS_SIZE = 2


class ImpStructs(NamedTuple):
    """The structs the coupling's kernels take (the MPM points, the DEM bodies, the point–body
    lists, the parameters) and the vector types of a pair's history (IMP_HISTORY keys, δ_t)."""

    Particles: type
    Bodies: type
    Links: type
    Params: type
    veci: type
    vec2h: type


@functools.cache
def make_imp_structs(precision: str):
    """``ImpStructs`` of the coupling for one precision (``Links`` and ``Params`` defined here, SI
    units per field)."""
    t = scalar_types(precision)
    T = t.scalar
    vec2 = t.vec2
    ContactLaw = make_contact_geometry(precision).ContactLaw
    vec2h = wp.types.vector(IMP_HISTORY, T)
    veci = wp.types.vector(IMP_HISTORY, wp.int32)

    @wp.struct
    class Links:
        body: wp.array(dtype=wp.int32)  # (points * slots) listed body of each slot, −1 empty
        count: wp.array(dtype=wp.int32)  # (points) bodies listed
        key: wp.array(dtype=veci)  # (points * slots) feature keys of the tangential history
        slip: wp.array(dtype=vec2h)  # (points * slots) tangential spring stretch δ_t [m]
        old_body: wp.array(dtype=wp.int32)
        old_key: wp.array(dtype=veci)
        old_slip: wp.array(dtype=vec2h)
        x_ref: wp.array(dtype=vec2)  # (points) position at the last build [m]
        body_x_ref: wp.array(dtype=vec2)  # (bodies) centroid and angle at the last build
        body_angle_ref: wp.array(dtype=T)
        radius: wp.array(dtype=T)  # (points) contact radius r_p [m] (MPM-SDEM eq. 45)
        energy: wp.array(dtype=T)  # (points) elastic energy of the point's contacts [J/m]
        dissipated: wp.array(dtype=wp.vec2d)  # (points) damping, friction work since the start [J/m]
        contact_at: wp.array(dtype=vec2)  # (points) where the force acts ("grid" scheme) [m]
        active: wp.array(dtype=wp.int32)  # (points) contacts touching this step
        listed: wp.array(dtype=wp.int32)  # (points) the points the force kernel visits, packed at each build
        listed_count: wp.array(dtype=wp.int32)  # (1) how many
        near: wp.array(dtype=wp.int32)  # (points, large scenes) the listed points near a body this step (``sift``)
        near_count: wp.array(dtype=wp.int32)  # (1) how many (reset by ``check_lists``)
        slots: int

    @wp.struct
    class Params:
        law: ContactLaw  # k_n, k_t, ζ of the contacts (eq. 43)
        skin: T  # Verlet skin [m]
        r_max: T  # largest contact radius [m]
        cell_origin: vec2  # point bins (the MPM grid's cells)
        inv_cell: T
        cells_x: int
        cells_y: int
        cell_cap: int
        bodies: int
        moving: int  # bodies [0, moving) can move
        tile: int  # threads per body in the list build
        friction: wp.array(dtype=T)  # (materials * bodies) Coulomb μ of each (material, body) pair

    return ImpStructs(make_state_structs(precision)[0], make_dem_structs(precision).Bodies, Links, Params, veci, vec2h)


@functools.cache
def make_release_gate(precision: str, staged: bool):
    """``released(P, clock, p)``: whether point p takes part at the clock's time (staged: its
    release time has come; otherwise always)."""
    Particles = make_state_structs(precision)[0]

    @wp.func
    def released(P: Particles, clock: wp.array(dtype=wp.float64), p: int):
        ok = True
        if wp.static(staged):
            ok = clock[CLOCK_T] >= P.release[p]
        return ok

    return released
