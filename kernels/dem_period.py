"""The periodic image of the DEM in a domain periodic in x (period L = hi_x − lo_x of ``Params``).

A body's centroid stays in [lo_x, lo_x + L): the rigid-body update wraps it by ±L when it leaves
(``kernels.dem_integrate``), and the wrap alone rebuilds no list (``needs_rebuild_image``). A pair is
computed with the minimum image of its partner: body j's centroid shifted by a whole number of
periods to the image nearest body i (``image``), and the vertices of one body moved into the other's
frame by that shift (``kernels.dem_contacts``). The broad-phase cells tile the period exactly, so a
cell index wraps in x (``periodic_cell``); the host takes a period of at least three cells
(``mpmdem.sim.dem_period``), so the three columns of cells around a body are distinct and a pair is
listed once, under one image.

Only the factories built with ``periodic=True`` call these; the others compile as before.
"""

import functools

import warp as wp

from .dem_bodies import make_dem_structs
from .types import Namespace, scalar_types

__all__ = ["make_dem_period"]


@functools.cache
def make_dem_period(precision: str):
    """Functions ``image``, ``wrap_x``, ``periodic_cell`` and ``needs_rebuild_image`` of the periodic DEM
    for one precision."""
    t = scalar_types(precision)
    T = t.scalar
    vec2 = t.vec2
    Bodies, _, Params = make_dem_structs(precision)

    @wp.func
    def image(xi: vec2, xj: vec2, prm: Params):
        """The shift [m] (a whole number of periods along x) that brings centroid xj to its image
        nearest xi: xj + image is the partner in i's frame."""
        L = prm.hi[0] - prm.lo[0]
        return vec2(-L * wp.round((xj[0] - xi[0]) / L), T(0.0))

    @wp.func
    def wrap_x(x: vec2, prm: Params):
        """Centroid x [m] brought back into [lo_x, lo_x + L) by one period when it left (a body moves
        far less than a period in one step)."""
        L = prm.hi[0] - prm.lo[0]
        y = x
        if x[0] >= prm.hi[0]:
            y = vec2(x[0] - L, x[1])
        elif x[0] < prm.lo[0]:
            y = vec2(x[0] + L, x[1])
        return y

    @wp.func
    def periodic_cell(x: vec2, prm: Params):
        """Cell (cx, cy) holding x: cx wrapped into the cells_x columns that tile the period (origin at
        lo_x), cy clamped."""
        cx = int(wp.floor((x[0] - prm.cell_origin[0]) * prm.inv_cell)) % prm.cells_x
        if cx < 0:
            cx += prm.cells_x
        cy = wp.clamp(int(wp.floor((x[1] - prm.cell_origin[1]) * prm.inv_cell)), 0, prm.cells_y - 1)
        return cx, cy

    @wp.func
    def needs_rebuild_image(B: Bodies, i: int, skin: T, prm: Params):
        """``kernels.verlet.needs_rebuild`` with the centroid's shift since the list build taken to the
        nearest image: a wrap across the seam moves nothing (the lists hold partners, not places)."""
        d = B.x[i] - B.x_ref[i] - image(B.x[i], B.x_ref[i], prm)
        moved = wp.length(d) + B.core_radius[i] * wp.abs(B.angle[i] - B.angle_ref[i])
        return moved > T(0.5) * skin or not wp.isfinite(moved)

    return Namespace(image=image, wrap_x=wrap_x, periodic_cell=periodic_cell, needs_rebuild_image=needs_rebuild_image)
