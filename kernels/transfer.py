"""Particle-to-grid and grid-to-particle kernels for the whole transfer family.

One factory per direction, ``make_p2g`` (``kernels.p2g``) and ``make_g2p`` (``kernels.g2p``), over
the terms both sum (``kernels.transfer_terms``); the variant (shape function, affine term, FLIP
fraction, position update, which fields to move, whether the stress update is fused) is fixed at
build time through ``wp.static`` so each variant compiles to a lean kernel ("Motion integration"
Table 1).
"""

from .g2p import make_g2p
from .p2g import make_p2g
from .transfer_terms import CORNERS, make_point_on_grid, make_stencil

__all__ = ["CORNERS", "make_g2p", "make_p2g", "make_point_on_grid", "make_stencil"]
