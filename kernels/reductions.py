"""Per-step time-step control and status flags, and per-frame diagnostics, all on the device.

The clock is a float64 array read by every kernel (its slots: ``kernels/clock.py``), so the host
never needs to know dt inside the step loop.
"""

import functools

import warp as wp

from .clock import (
    CLOCK_BOUND,
    CLOCK_DT,
    CLOCK_DT_FACTOR,
    CLOCK_DT_FIXED,
    CLOCK_SIZE,
    CLOCK_T,
    CLOCK_T_STOP,
    ROUND_OFF,
    land,
)
from .constitutive import make_strain_energy_density
from .state import make_state_structs
from .types import kernel, scalar_types

__all__ = [
    "CLOCK_SIZE",
    "DIAG_NAMES",
    "SPEED_SLOTS",
    "STATUS_NONFINITE",
    "STATUS_OUTSIDE",
    "advance_time",
    "compute_dt",
    "make_diagnostics",
    "make_probe_mass",
    "make_speed_check",
    "make_wave_speed",
]

STATUS_NONFINITE = 0
STATUS_OUTSIDE = 1

#: Order of the per-frame sums written by the diagnostics kernel.
DIAG_NAMES = (
    "energy_kinetic",
    "energy_strain",
    "energy_gravity",
    "momentum_x",
    "momentum_y",
    "momentum_angular",
    "mass",
)


#: The largest point speed is reduced into this many slots (point p uses slot p % SPEED_SLOTS) and
#: a point only issues its atomic when it beats the slot's current value: a million points then
#: cost a few thousand uncontended atomics instead of a million on one address.
SPEED_SLOTS = 32


@functools.cache
def make_speed_check(precision: str):
    """``speed_check(P, D, materials, p, max_speed, status)``: CFL speed c_p + |v_p| of point p
    into ``max_speed``, and counts of non-finite and escaped points into ``status``."""
    t = scalar_types(precision)
    T = t.scalar
    Particles, Grid, Domain = make_state_structs(precision)

    @wp.func
    def speed_check(
        P: Particles,
        D: Domain,
        materials: wp.array(dtype=t.params),
        p: int,
        max_speed: wp.array(dtype=wp.float32),
        status: wp.array(dtype=wp.int32),
    ):
        m = materials[P.material[p]]
        rho = P.mass[p] / P.vol[p]
        # dilatational wave speed sqrt((λ+2μ)/ρ) at the current density ("MPM notes" step 8)
        s = wp.sqrt((m[1] + T(2.0) * m[0]) / rho) + wp.length(P.v[p])
        x = P.x[p]
        if not (wp.isfinite(s) and wp.isfinite(x[0]) and wp.isfinite(x[1])):
            wp.atomic_add(status, STATUS_NONFINITE, 1)
            return
        if x[0] < D.lo[0] or x[0] > D.hi[0] or x[1] < D.lo[1] or x[1] > D.hi[1]:
            wp.atomic_add(status, STATUS_OUTSIDE, 1)
        slot = p % SPEED_SLOTS
        sf = wp.float32(s)
        if sf > max_speed[slot]:
            wp.atomic_max(max_speed, slot, sf)

    return speed_check


@functools.cache
def make_wave_speed(precision: str):
    """Speed check of every point (before the first step; later steps do it inside G2P)."""
    t = scalar_types(precision)
    Particles, Grid, Domain = make_state_structs(precision)
    speed_check = make_speed_check(precision)

    @kernel
    def wave_speed(
        P: Particles,
        D: Domain,
        materials: wp.array(dtype=t.params),
        max_speed: wp.array(dtype=wp.float32),
        status: wp.array(dtype=wp.int32),
    ):
        speed_check(P, D, materials, wp.tid(), max_speed, status)

    return wave_speed


@kernel
def compute_dt(clock: wp.array(dtype=wp.float64), max_speed: wp.array(dtype=wp.float32), h: wp.float64,
               cap: wp.float64, cap_bound: wp.float64):
    """dt = κ h / max(c+|v|) (CFL) or the fixed dt; 0 once the clock has reached t_stop.

    max(c+|v|) comes from the speed slots filled at the end of the previous step (or by the
    initial wave_speed pass); they are cleared here for this step.

    cap [s] > 0 (coupled scenes): dt = min(dt, cap) unless dt was fixed by the user (MPM-SDEM eq. 51
    takes the smallest of the MPM, DEM and contact terms), and ``cap_bound`` [s], the stable step
    of the contacts, lowers the reported bound; 0: no cap. (One launch for both: a small scene's
    step is paid per launch.)

    Steps land on t_stop (the next output frame): see ``kernels.clock.land_on_stop``.
    """
    # every load first: they leave together (one round trip, not one per slot read) on the critical
    # path of every step
    t = clock[CLOCK_T]
    t_stop = clock[CLOCK_T_STOP]
    fixed = clock[CLOCK_DT_FIXED]
    factor = clock[CLOCK_DT_FACTOR]
    last_bound = clock[CLOCK_BOUND]
    s = wp.float64(0.0)
    for k in range(wp.static(SPEED_SLOTS)):  # unrolled: independent loads
        s = wp.max(s, wp.float64(max_speed[k]))
    bound = wp.float64(1.0e30)
    if s > wp.float64(0.0):
        bound = h / s
    if not wp.isfinite(s):
        bound = last_bound  # a NaN speed is reported by the status flags; keep the clock sane
    dt = fixed
    if dt <= wp.float64(0.0):
        dt = factor * bound
    if t >= t_stop:
        dt = wp.float64(0.0)
    else:
        for k in range(wp.static(SPEED_SLOTS)):
            max_speed[k] = wp.float32(0.0)  # refilled by this step's G2P
    dt = land(t, t_stop, dt)
    if cap > wp.float64(0.0):
        # (the landed step is compared with the cap, and the cap landed in its place)
        if fixed <= wp.float64(0.0) and dt > cap:
            dt = land(t, t_stop, cap)
        bound = wp.min(bound, cap_bound)
    clock[CLOCK_BOUND] = bound
    clock[CLOCK_DT] = dt


@wp.func
def advance(clock: wp.array(dtype=wp.float64), steps: wp.array(dtype=wp.int64)):
    """t += dt; count steps taken (the end of a step). A time within round-off of t_stop is t_stop
    (``land_on_stop``'s steps sum to it up to a few ulps)."""
    dt = clock[CLOCK_DT]  # (every load first: one round trip)
    t = clock[CLOCK_T]
    t_stop = clock[CLOCK_T_STOP]
    taken = steps[0]
    if dt > wp.float64(0.0):
        t = t + dt
        if wp.abs(t_stop - t) <= wp.float64(ROUND_OFF) * dt:
            t = t_stop
        clock[CLOCK_T] = t
        steps[0] = taken + wp.int64(1)


@kernel
def advance_time(clock: wp.array(dtype=wp.float64), steps: wp.array(dtype=wp.int64)):
    """t += dt; count steps taken."""
    advance(clock, steps)


@functools.cache
def make_diagnostics(precision: str, material_kinds: tuple = (0,), staged: bool = False):
    """Sums over points of the DIAG_NAMES quantities into a float64 array.

    Stored energy: accumulated per point for the rate-form linear elastic law; for Neo-Hookean
    points it is a function of F alone, evaluated here (so the step never computes it).
    staged: points not yet released (``P.release`` > t) are left out.
    """
    t = scalar_types(precision)
    Particles, Grid, Domain = make_state_structs(precision)
    psi = make_strain_energy_density(precision)
    has_nh = 1 in material_kinds

    @kernel
    def diagnostics(P: Particles, D: Domain, materials: wp.array(dtype=t.params), out: wp.array(dtype=wp.float64),
                    t_now: wp.float64):
        p = wp.tid()
        if wp.static(staged):
            if t_now < P.release[p]:
                return
        m = wp.float64(P.mass[p])
        vx = wp.float64(P.v[p][0])
        vy = wp.float64(P.v[p][1])
        x = wp.float64(P.x[p][0])
        y = wp.float64(P.x[p][1])
        gx = wp.float64(D.gravity[0])
        gy = wp.float64(D.gravity[1])
        energy = wp.float64(P.strain_energy[p])
        if wp.static(has_nh):
            mat = materials[P.material[p]]
            if int(mat[3]) == 1:
                energy = wp.float64(P.vol0[p] * psi(P.F[p], mat[0], mat[1]))
        wp.atomic_add(out, 0, wp.float64(0.5) * m * (vx * vx + vy * vy))
        wp.atomic_add(out, 1, energy)
        wp.atomic_add(out, 2, -m * (gx * x + gy * y))
        wp.atomic_add(out, 3, m * vx)
        wp.atomic_add(out, 4, m * vy)
        wp.atomic_add(out, 5, m * (x * vy - y * vx))
        wp.atomic_add(out, 6, m)

    return diagnostics


@functools.cache
def make_probe_mass(precision: str, staged: bool = False):
    """Mass [kg/m] of the points inside each probe box lo ≤ x < hi (boxes as vec4 (x0, y0, x1, y1))
    into ``out[k]``; points not yet released are left out."""
    Particles, Grid, Domain = make_state_structs(precision)

    @kernel
    def probe_mass(P: Particles, boxes: wp.array(dtype=wp.vec4d), out: wp.array(dtype=wp.float64),
                   t_now: wp.float64):
        p = wp.tid()
        if wp.static(staged):
            if t_now < P.release[p]:
                return
        x = wp.float64(P.x[p][0])
        y = wp.float64(P.x[p][1])
        for k in range(boxes.shape[0]):
            b = boxes[k]
            if x >= b[0] and y >= b[1] and x < b[2] and y < b[3]:
                wp.atomic_add(out, k, wp.float64(P.mass[p]))

    return probe_mass
