"""A frame's per-point output fields packed on the device in the scene's order, so that the host
reads them back in one copy instead of one per field and does not reorder them itself."""

import functools

import warp as wp

from .state import make_state_structs
from .types import kernel, scalar_types

__all__ = ["OUTPUT_COLUMNS", "make_pack_output", "output_width"]

#: The packed row of one point: field → (first column, shape of one point's value); ``contact_force``
#: only in coupled scenes (the last columns). Matrices are stored row by row.
OUTPUT_COLUMNS = {"x": (0, (2,)), "v": (2, (2,)), "stress": (4, (2, 2)), "volume": (8, ()), "mass": (9, ()),
                  "F": (10, (2, 2)), "contact_force": (14, (2,))}


def output_width(coupled: bool) -> int:
    """Columns of the packed array: 14, and 16 with the contact force."""
    return 16 if coupled else 14


@functools.cache
def make_pack_output(precision: str, coupled: bool):
    """``pack_output(P, out)``: row ``P.pid[p]`` of ``out`` [N, output_width] holds point p's position
    [m], velocity [m/s], Cauchy stress [Pa], volume [m²], mass [kg/m], deformation gradient and,
    when ``coupled``, the contact force from the bodies [N/m] (``OUTPUT_COLUMNS``): exact copies,
    the device order undone."""
    Particles = make_state_structs(precision)[0]
    T = scalar_types(precision).scalar

    @kernel
    def pack_output(P: Particles, out: wp.array2d(dtype=T)):
        p = wp.tid()
        q = P.pid[p]
        x = P.x[p]
        v = P.v[p]
        s = P.stress[p]
        f = P.F[p]
        out[q, 0] = x[0]
        out[q, 1] = x[1]
        out[q, 2] = v[0]
        out[q, 3] = v[1]
        out[q, 4] = s[0, 0]
        out[q, 5] = s[0, 1]
        out[q, 6] = s[1, 0]
        out[q, 7] = s[1, 1]
        out[q, 8] = P.vol[p]
        out[q, 9] = P.mass[p]
        out[q, 10] = f[0, 0]
        out[q, 11] = f[0, 1]
        out[q, 12] = f[1, 0]
        out[q, 13] = f[1, 1]
        if wp.static(coupled):
            c = P.fcont[p]
            out[q, 14] = c[0]
            out[q, 15] = c[1]

    return pack_output
