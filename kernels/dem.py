"""Device code of the spheropolygon DEM (MPM-SDEM §3), assembled for one precision from its parts:

* ``kernels.dem_bodies``: the bodies, the pair slots and the stage parameters (structs), with the
  motion kinds and status codes;
* ``kernels.verlet``: the Verlet rule, binning and rebuild bookkeeping (shared with the coupling);
* ``kernels.dem_lists``: the body-pair lists, rebuilt on the device;
* ``kernels.dem_contacts``: the start of the contact stage, the touch law and the pair search
  (vertex–edge and vertex–vertex contacts, eq. 38–43), and the contact kernel;
* ``kernels.dem_integrate``: the rigid-body update (eq. 17–20, 42), the step's end and the
  diagnostics sums;
* ``kernels.dem_split`` and ``kernels.dem_disks``: the pair search split over candidate vertices
  (large scenes) and the disk–disk pass.

A body is a spheropolygon (a core polygon ⊕ a disk of radius a, eq. 37) moved as a rigid body.
Bodies are stored moving-first (free and kinematic), fixed last; fixed bodies are never integrated
and their world vertices are computed once. Each pair of bodies is listed once, in the slots of its
owner (the lower index of two small bodies, the small one of a small–large pair), and one thread
per slot computes the pair and adds its forces to both bodies. Tangential history (the δ_t of
eq. 43) is kept per vertex–edge contact: each pair slot holds HISTORY_SLOTS (feature key, δ_t)
entries, carried across steps and across list rebuilds.
"""

import functools

from .dem_bodies import (
    FIXED,
    FREE,
    HISTORY_SLOTS,
    KINEMATIC,
    STATUS_CELL_OVERFLOW,
    STATUS_HISTORY_OVERFLOW,
    STATUS_NEIGHBOR_OVERFLOW,
    STATUS_NONFINITE,
    STATUS_OUTSIDE,
    STATUS_SIZE,
    make_dem_structs,
)
from .dem_contacts import make_dem_contact_forces, make_dem_contacts
from .dem_integrate import DIAG_NAMES, make_dem_integration
from .types import Namespace
from .verlet import make_verlet

__all__ = ["DIAG_NAMES", "FIXED", "FREE", "HISTORY_SLOTS", "KINEMATIC", "STATUS_CELL_OVERFLOW",
           "STATUS_HISTORY_OVERFLOW", "STATUS_NEIGHBOR_OVERFLOW", "STATUS_NONFINITE", "STATUS_OUTSIDE",
           "STATUS_SIZE", "make_dem_kernels"]


@functools.cache
def make_dem_kernels(precision: str, deterministic: bool = False, periodic: bool = False):
    """Structs, functions and kernels of the DEM stage for one precision ("f32" or "f64"), in one
    namespace: those of ``make_dem_structs``, ``make_verlet``, ``make_dem_contacts`` and
    ``make_dem_integration``, the contact kernel, and ``make_contact_forces(max_registers=None,
    disk_pairs=False)`` for its other builds (``make_dem_contact_forces``); ``periodic``: x periodic
    (``kernels.dem_period``)."""
    parts = make_dem_structs(precision)._asdict()
    for part in (make_verlet(precision), make_dem_contacts(precision, deterministic, periodic),
                 make_dem_integration(precision, periodic)):
        parts.update(vars(part))
    return Namespace(**parts, contact_forces=make_dem_contact_forces(precision, deterministic, periodic=periodic),
                     make_contact_forces=functools.partial(make_dem_contact_forces, precision, deterministic,
                                                           periodic=periodic))
