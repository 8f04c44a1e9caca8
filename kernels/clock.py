"""Slots of the device clock: one float64 array every kernel of a step reads (and the dt and
time kernels write), so the host never needs dt inside the step loop.

Kernels index it with these names (``clock[CLOCK_DT]``); the host side is ``mpmdem.sim.stage.Clock``.
``land_on_stop`` is the rule that makes the steps of a frame end on its time.

The dt of a step is set by the last kernel of the step before (``take_step`` then ``set_step``,
in one launch with t += dt: a small scene's step is paid per launch), or by ``land_step`` when the
host moves t_stop between batches. So the host reads the last step taken from CLOCK_DT_TAKEN and
CLOCK_BOUND_TAKEN, while CLOCK_DT already holds the next step's dt (0 at t_stop).
"""

import warp as wp

from .types import kernel

__all__ = ["CLOCK_BOUND", "CLOCK_BOUND_NEXT", "CLOCK_BOUND_TAKEN", "CLOCK_DT", "CLOCK_DT_FACTOR", "CLOCK_DT_FIXED",
           "CLOCK_DT_TAKEN", "CLOCK_SIZE", "CLOCK_T", "CLOCK_T_STOP", "LANDING_SLACK", "ROUND_OFF", "land",
           "land_on_stop", "land_step", "set_step", "take_step"]

#: t [s]: the time reached (advanced by dt at the end of each step).
CLOCK_T = 0
#: dt [s] of the current step (0 once t has reached t_stop: the step then changes nothing).
CLOCK_DT = 1
#: t_stop [s]: steps run while t < t_stop (set by the host before each batch of steps).
CLOCK_T_STOP = 2
#: the stable bound [s] of the current step: h / max(c + |v|) of the MPM stage, or the DEM bound
#: (capped by the contact bound in coupled scenes).
CLOCK_BOUND = 3
#: a fixed dt [s] chosen by the user; 0 lets the stage compute dt = factor × bound.
CLOCK_DT_FIXED = 4
#: the factor of the bound: the CFL number κ (MPM) or π κ2 (DEM, MPM-SDEM eq. 51).
CLOCK_DT_FACTOR = 5
#: the uncapped bound [s] the next step's dt comes from: h / max(c + |v|) measured over the last
#: step that moved the points (MPM), or the DEM bound.
CLOCK_BOUND_NEXT = 6
#: dt [s] of the last step taken (what the host reports; 0 if it was a step at t_stop).
CLOCK_DT_TAKEN = 7
#: the bound [s] of the last step taken (what the host reports).
CLOCK_BOUND_TAKEN = 8
#: Length of the clock array.
CLOCK_SIZE = 9

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
    (tests/sim/test_convergence.py).
    """
    return land(clock[CLOCK_T], clock[CLOCK_T_STOP], dt)


@wp.func
def take_step(clock: wp.array(dtype=wp.float64), dt: wp.float64, bound: wp.float64):
    """Record dt and the bound [s] of the step just taken (CLOCK_DT_TAKEN, CLOCK_BOUND_TAKEN) before
    ``set_step`` replaces them with the next step's."""
    clock[CLOCK_DT_TAKEN] = dt
    clock[CLOCK_BOUND_TAKEN] = bound


@wp.func
def set_step(clock: wp.array(dtype=wp.float64), t: wp.float64, t_stop: wp.float64, fixed: wp.float64,
             factor: wp.float64, bound_next: wp.float64, cap: wp.float64, cap_bound: wp.float64):
    """The next step's dt [s] and bound [s] onto the clock: the fixed dt, else factor × bound_next;
    0 once t has reached t_stop; landed on t_stop (``land``). cap [s] > 0 (coupled scenes): dt at
    most cap unless fixed by the user (MPM-SDEM eq. 51 takes the smallest of the MPM, DEM and
    contact terms; the landed step is compared with the cap and the cap landed in its place), and
    the bound at most ``cap_bound``, the stable step of the contacts."""
    dt = fixed
    if dt <= wp.float64(0.0):
        dt = factor * bound_next
    if t >= t_stop:
        dt = wp.float64(0.0)
    dt = land(t, t_stop, dt)
    bound = bound_next
    if cap > wp.float64(0.0):
        if fixed <= wp.float64(0.0) and dt > cap:
            dt = land(t, t_stop, cap)
        bound = wp.min(bound, cap_bound)
    clock[CLOCK_BOUND] = bound
    clock[CLOCK_DT] = dt


@kernel
def land_step(clock: wp.array(dtype=wp.float64), cap: wp.float64, cap_bound: wp.float64):
    """The next step's dt from CLOCK_BOUND_NEXT (``set_step``), launched by the host after it moved
    t_stop (``mpmdem.sim.stage.Clock.set_stop_time``): steps land on the new stop."""
    t = clock[CLOCK_T]  # (every load first: one round trip)
    t_stop = clock[CLOCK_T_STOP]
    fixed = clock[CLOCK_DT_FIXED]
    factor = clock[CLOCK_DT_FACTOR]
    bound_next = clock[CLOCK_BOUND_NEXT]
    set_step(clock, t, t_stop, fixed, factor, bound_next, cap, cap_bound)

