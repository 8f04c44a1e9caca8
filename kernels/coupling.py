"""Device code of the MPM–DEM coupling by identified material points (MPM-SDEM §4), assembled for one
precision and scheme from its parts.

A material point within the Verlet distance of a rigid spheropolygon is an *identified material
point* (IMP): for the contact it is a disk of radius r_p centred on the point (MPM-SDEM Fig. 4–5).
Per step (all kernels, no host sync, capturable in a CUDA graph):

1. ``kernels.imp_lists``: flag a rebuild of the point–body lists (the DEM's Verlet rule), and on a
   flagged step only rebuild them: points binned in the MPM grid's cells, each body listing the
   points within a_i + r_p + skin of its core outline (eq. 44's gap plus the skin), the history of
   pairs that stay listed carried over.
2. ``kernels.imp_sift`` (large scenes): pack the listed points near a body this step, end the
   contacts of the others.
3. ``kernels.imp_forces``: every point against its listed bodies (eq. 43–46), summed into the
   point's contact force f_p that the P2G spreads (eq. 47–48); the reactions go to the bodies
   (eq. 49–50).

The structs and status codes are ``kernels.imp_links``'; the "liu" scheme's nodal exchange is
``kernels.liu_exchange``.
"""

import functools

from .dem_bodies import FIXED
from .imp_forces import IMP_DIAG_NAMES, make_imp_diagnostics, make_imp_forces
from .imp_links import IMP_HISTORY, STATUS_CELL_OVERFLOW, STATUS_SIZE, STATUS_SLOT_OVERFLOW, make_imp_structs
from .imp_lists import make_imp_lists
from .imp_sift import make_imp_sift
from .liu_exchange import make_liu_kernels
from .types import Namespace
from .verlet import make_verlet

__all__ = [
    "COUPLING_SCHEMES",
    "IMP_DIAG_NAMES",
    "IMP_HISTORY",
    "STATUS_CELL_OVERFLOW",
    "STATUS_SIZE",
    "STATUS_SLOT_OVERFLOW",
    "make_coupling_kernels",
    "make_liu_kernels",
]

#: How the contact force reaches the grid: at the point (the paper's), at the node nearest the
#: contact point, or not at all (Liu et al.'s momentum exchange through shared nodes).
COUPLING_SCHEMES = ("imp", "grid", "liu")


@functools.cache
def make_coupling_kernels(precision: str, scheme: str = "imp", *, staged: bool = False, deterministic: bool = False):
    """Structs and kernels of the IMP coupling for one precision and coupling scheme, in one namespace.

    scheme "imp" and "liu" take the body's torque about x_p, "grid" about the contact point.
    staged: points whose release time is still ahead take no part.
    ``make_forces(sifted, static_bodies=0)`` builds the force kernel's other variants
    (``make_imp_forces``).
    """
    structs = make_imp_structs(precision)
    verlet = make_verlet(precision)
    lists = make_imp_lists(precision, staged)

    def make_forces(sifted: bool, static_bodies: int = 0):
        """The force kernel over the listed points or (``sifted``) those ``sift`` kept."""
        return make_imp_forces(precision, scheme, staged, deterministic, sifted, static_bodies)

    return Namespace(Links=structs.Links, Params=structs.Params, check_lists=lists.check_lists,
                     clear_cells=verlet.clear_cells, bin_points=lists.bin_points, build_lists=lists.build_lists,
                     finish_lists=lists.finish_lists, forces=make_forces(False), make_forces=make_forces,
                     sift=make_imp_sift(precision, staged), diagnostics=make_imp_diagnostics(precision, deterministic),
                     finish_rebuild=verlet.finish_rebuild, FIXED=FIXED)
