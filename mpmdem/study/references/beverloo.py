"""The 2D Beverloo law of MPM-SDEM Fig. 16: the discharge rate of a silo through an orifice of width D0,
its constants and the paper's five orifices (SI units; Table 3's sand, ``table3``)."""

import math

from .table3 import DENSITY, GRAVITY, R_P_TABLE

__all__ = ["BEVERLOO_C", "BEVERLOO_K", "ORIFICES_PAPER", "beverloo"]

BEVERLOO_C = 0.58
BEVERLOO_K = 2.2
ORIFICES_PAPER = (0.02, 0.03, 0.04, 0.05, 0.06)  # m, the five D0 of Fig. 16


def beverloo(orifice, c=BEVERLOO_C, k=BEVERLOO_K, r_p=R_P_TABLE, density=DENSITY, gravity=GRAVITY):
    """The 2D Beverloo rate C ρ sqrt(g) (D0 − k r_p)^(3/2) [kg/(m s)] of MPM-SDEM Fig. 16."""
    return c * density * math.sqrt(gravity) * max(orifice - k * r_p, 0.0) ** 1.5
