"""Slots of the device clock: one float64 array every kernel of a step reads (and the dt and
time kernels write), so the host never needs dt inside the step loop.

Kernels index it with these names (``clock[CLOCK_DT]``); the host side is ``mpmdem.stage.Clock``.
``land_on_stop`` is the rule that makes the steps of a frame end on its time.
"""

import warp as wp

__all__ = ["CLOCK_BOUND", "CLOCK_DT", "CLOCK_DT_FACTOR", "CLOCK_DT_FIXED", "CLOCK_SIZE", "CLOCK_T", "CLOCK_T_STOP",
           "LANDING_SLACK", "ROUND_OFF", "land", "land_on_stop"]

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

#: How much longer than asked, in steps per frame, a step may be to land on t_stop: n = ⌈R/dt − slack⌉,
#: so a step grows by at most slack/n (0.1 % at one step per frame). The CFL step's own estimate of
#: max(c+|v|) from the previous step is no closer than that; without it a frame that holds exactly
#: k steps of h/c by construction (c+|v| a hair above c) would take k+1.
LANDING_SLACK = 1.0e-3
#: A time within ROUND_OFF steps of t_stop is t_stop (the landed steps sum to it to about n ε t).
ROUND_OFF = 1.0e-6


@wp.func
def land(t: wp.float64, t_stop: wp.float64, dt: wp.float64) -> wp.float64:
    """``land_on_stop`` from the values t and t_stop [s] (a kernel that loaded them already: the
    one-thread clock kernels load every slot first, so the loads leave together)."""
    r = t_stop - t
    out = dt
    if dt > wp.float64(0.0) and r > wp.float64(0.0):
        n = wp.max(wp.ceil(r / dt - wp.float64(LANDING_SLACK)), wp.float64(1.0))
        out = r / n
    return out


@wp.func
def land_on_stop(clock: wp.array(dtype=wp.float64), dt: wp.float64) -> wp.float64:
    """The step [s] no longer than ``dt`` (but for LANDING_SLACK) that splits the time left to
    t_stop into whole equal steps: R / n, n = ⌈R / dt − LANDING_SLACK⌉, R = t_stop − t, so the
    last step of a frame ends on the frame's time.

    Shortening only the step that would cross t_stop changes dt suddenly, which breaks the
    staggering of the explicit central-difference update (MPM-SDEM eq. 17) and costs a first-order
    error. Equal steps across the frame keep dt constant within it: with a fixed dt that divides
    the frame, dt itself; otherwise a dt smaller by less than one step per frame, and a change
    between frames of order dt² / frame length, which keeps the update second order
    (tests/test_convergence.py).
    """
    return land(clock[CLOCK_T], clock[CLOCK_T_STOP], dt)
