"""Slots of the device clock: one float64 array every kernel of a step reads (and the dt and
time kernels write), so the host never needs dt inside the step loop.

Kernels index it with these names (``clock[CLOCK_DT]``); the host side is ``mpmdem.stage.Clock``.
"""

__all__ = ["CLOCK_BOUND", "CLOCK_DT", "CLOCK_DT_FACTOR", "CLOCK_DT_FIXED", "CLOCK_SIZE", "CLOCK_T", "CLOCK_T_STOP"]

#: t [s]: the time reached (advanced by dt at the end of each step).
CLOCK_T = 0
#: dt [s] of the current step (0 once t has reached t_stop: the step then changes nothing).
CLOCK_DT = 1
#: t_stop [s]: steps run while t < t_stop (set by the host before each batch of steps).
CLOCK_T_STOP = 2
#: the stable bound [s]: h / max(c + |v|) of the MPM stage, refreshed every step, or the DEM bound.
CLOCK_BOUND = 3
#: a fixed dt [s] chosen by the user; 0 lets the stage compute dt = factor × bound.
CLOCK_DT_FIXED = 4
#: the factor of the bound: the CFL number κ (MPM) or π κ2 (DEM, MPM-SDEM eq. 51).
CLOCK_DT_FACTOR = 5
#: Length of the clock array.
CLOCK_SIZE = 6
