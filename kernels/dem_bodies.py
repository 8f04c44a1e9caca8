"""The data of the spheropolygon DEM: the bodies, the body-pair slots of the contact lists and the
stage parameters, with the codes the kernels and the host share (motion kinds, status counters,
history sizes).

A body is a spheropolygon (a core polygon ⊕ a disk of radius a, MPM-SDEM eq. 37) moved as a rigid
body (eq. 42). Bodies are stored moving-first (free and kinematic), fixed last. Each pair of bodies
is listed once, in the slots of its owner (``Contacts``, built by ``kernels.dem_lists``), and each
slot keeps the tangential history δ_t of eq. 43 for up to HISTORY_SLOTS vertex–edge contacts
under their feature keys. The constants of the contact law are the shared ``ContactLaw``
(``kernels.contact_geometry``).
"""

import functools
from typing import NamedTuple

import warp as wp

from .contact_geometry import make_contact_geometry
from .types import scalar_types

__all__ = ["FIXED", "FREE", "HISTORY_SLOTS", "KEY_KIND", "KEY_VERTEX", "KINEMATIC", "STATUS_CELL_OVERFLOW",
           "STATUS_HISTORY_OVERFLOW", "STATUS_NEIGHBOR_OVERFLOW", "STATUS_NONFINITE", "STATUS_OUTSIDE", "STATUS_SIZE",
           "DemStructs", "make_dem_structs"]

FREE = 0
FIXED = 1
KINEMATIC = 2

#: Tangential-history entries per body pair (active vertex–edge contacts of one pair).
HISTORY_SLOTS = 4

STATUS_NONFINITE = 0
STATUS_OUTSIDE = 1
STATUS_NEIGHBOR_OVERFLOW = 2
STATUS_CELL_OVERFLOW = 3
STATUS_HISTORY_OVERFLOW = 4
STATUS_SIZE = 5

#: Feature keys of a contact: kind * KEY_KIND + vertex * KEY_VERTEX + edge (or partner vertex).
KEY_KIND = 1 << 28
KEY_VERTEX = 1 << 14


class DemStructs(NamedTuple):
    """The structs of the DEM stage's kernels."""

    Bodies: type
    Contacts: type
    Params: type


@functools.cache
def make_dem_structs(precision: str):
    """Structs ``Bodies``, ``Contacts`` and ``Params`` of the DEM stage for one precision ("f32" or
    "f64"); SI units as commented per field."""
    t = scalar_types(precision)
    T, vec2, vec4 = t.scalar, t.vec2, t.vec4
    ContactLaw = make_contact_geometry(precision).ContactLaw

    @wp.struct
    class Bodies:
        x: wp.array(dtype=vec2)  # centroid [m]
        angle: wp.array(dtype=T)  # [rad]
        v: wp.array(dtype=vec2)  # [m/s] (half-step velocity of the leapfrog update)
        omega: wp.array(dtype=T)  # [rad/s]
        force: wp.array(dtype=vec2)  # contact force of this step [N/m]
        torque: wp.array(dtype=T)  # contact torque about the centroid [N m/m]
        mass: wp.array(dtype=T)  # [kg/m]
        inertia: wp.array(dtype=T)  # about the centroid [kg m²/m]
        inv_mass: wp.array(dtype=T)  # 0 for fixed and kinematic bodies
        inv_inertia: wp.array(dtype=T)
        radius: wp.array(dtype=T)  # sphero radius a [m]
        core_radius: wp.array(dtype=T)  # max |vertex - centroid| [m]
        friction: wp.array(dtype=T)  # Coulomb μ
        motion: wp.array(dtype=wp.int32)  # FREE, FIXED, KINEMATIC
        vstart: wp.array(dtype=wp.int32)  # first vertex in the vertex arrays
        vcount: wp.array(dtype=wp.int32)
        x_ref: wp.array(dtype=vec2)  # position and angle at the last list build
        angle_ref: wp.array(dtype=T)
        kin_v: wp.array(dtype=vec2)  # prescribed motion of kinematic bodies
        kin_omega: wp.array(dtype=T)
        kin_window: wp.array(dtype=wp.vec2d)  # [t_start, t_end) of the prescribed motion [s]
        work: wp.array(dtype=wp.float64)  # work done on the other bodies by a kinematic one [J/m]
        disk: wp.array(dtype=wp.int32)  # 1: a small sphero-disk whose disk–disk pairs take kernels.dem_disks

    @wp.struct
    class Contacts:
        nbr: wp.array(dtype=wp.int32)  # (bodies * K) partner index of each owned pair, -1 empty
        count: wp.array(dtype=wp.int32)  # (bodies) pairs owned
        key: wp.array(dtype=wp.vec4i)  # (bodies * K) feature keys of the tangential history
        slip: wp.array(dtype=vec4)  # (bodies * K) tangential spring stretch δ_t [m]
        energy: wp.array(dtype=T)  # (bodies * K) elastic energy of the pair's contacts [J/m]
        dissipated: wp.array(dtype=wp.vec2d)  # (bodies * K) damping, friction work since build [J/m]
        body_dissipated: wp.array(dtype=wp.vec2d)  # (bodies) folded in at each rebuild
        old_nbr: wp.array(dtype=wp.int32)  # (bodies * K) the partners before a rebuild (history hand-over)
        pairs: wp.array(dtype=wp.int32)  # listed slots packed at the front (non-deterministic mode)
        total: wp.array(dtype=wp.int32)  # (1) listed pairs
        slots: int  # K

    @wp.struct
    class Params:
        law: ContactLaw  # k_n, k_t, ζ of the contacts (eq. 43)
        skin: T  # Verlet skin [m]
        gravity: vec2
        gravity_ramp: float
        lo: vec2  # domain corners [m]; a free body whose centroid leaves them is an error
        hi: vec2
        cell_origin: vec2  # broad-phase cells
        inv_cell: T
        cells_x: int
        cells_y: int
        cell_cap: int
        moving: int  # bodies [0, moving) are free or kinematic

    return DemStructs(Bodies, Contacts, Params)
