"""Per-step time-step control and status flags, and per-frame diagnostics, all on the device.

The clock is a float64 array read by every kernel (its slots: ``kernels/clock.py``), so the host
never needs to know dt inside the step loop.
"""

import functools

import warp as wp

from .clock import (
    CLOCK_BOUND,
    CLOCK_BOUND_NEXT,
    CLOCK_DT,
    CLOCK_DT_FACTOR,
    CLOCK_DT_FIXED,
    CLOCK_SIZE,
    CLOCK_T,
    CLOCK_T_STOP,
    ROUND_OFF,
    set_step,
    take_step,
)
from .constitutive import make_strain_energy_density
from .state import make_state_structs
from .tiles import make_tiles
from .types import kernel, scalar_types

__all__ = [
    "CLOCK_SIZE",
    "DIAG_NAMES",
    "SPEED_SLOTS",
    "STATUS_NONFINITE",
    "STATUS_OUTSIDE",
    "close_step",
    "end_step",
    "finish_step",
    "measure_bound",
    "prime_step",
    "make_diagnostics",
    "make_body_probe_mass",
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
    """``speed_check(P, D, materials, p, vol, max_speed, status)``: CFL speed c_p + |v_p| of point
    p (volume ``vol`` [m²/m]) into ``max_speed``, and counts of non-finite and escaped points (out of
    the domain; of its tile's, in a batch) into ``status``."""
    t = scalar_types(precision)
    T = t.scalar
    Particles, Grid, Domain = make_state_structs(precision)
    tile_shift = make_tiles(precision).shift

    @wp.func
    def speed_check(
        P: Particles,
        D: Domain,
        materials: wp.array(dtype=t.params),
        p: int,
        vol: T,
        max_speed: wp.array(dtype=wp.float32),
        status: wp.array(dtype=wp.int32),
    ):
        m = materials[P.material[p]]
        rho = P.mass[p] / vol
        # dilatational wave speed sqrt((λ+2μ)/ρ) at the current density ("MPM notes" step 8)
        s = wp.sqrt((m[1] + T(2.0) * m[0]) / rho) + wp.length(P.v[p])
        x = P.x[p]
        if not (wp.isfinite(s) and wp.isfinite(x[0]) and wp.isfinite(x[1])):
            wp.atomic_add(status, STATUS_NONFINITE, 1)
            return
        sx = tile_shift(D, x[0])  # (its tile's box in a batch: kernels/tiles.py)
        if x[0] < D.lo[0] + sx or x[0] > D.hi[0] + sx or x[1] < D.lo[1] or x[1] > D.hi[1]:
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
        p = wp.tid()
        speed_check(P, D, materials, p, P.vol[p], max_speed, status)

    return wave_speed


@wp.func
def measure_bound(clock: wp.array(dtype=wp.float64), max_speed: wp.array(dtype=wp.float32), h: wp.float64):
    """The bound h / max(c+|v|) [s] the next step's dt comes from (CFL, "MPM notes" step 8), from
    the speed slots the last G2P filled (or the initial wave_speed pass), stored as
    CLOCK_BOUND_NEXT and returned; the slots are cleared for the next G2P."""
    s = wp.float64(0.0)
    for k in range(wp.static(SPEED_SLOTS)):  # unrolled: independent loads
        s = wp.max(s, wp.float64(max_speed[k]))
    bound = wp.float64(1.0e30)
    if s > wp.float64(0.0):
        bound = h / s
    if not wp.isfinite(s):
        bound = clock[CLOCK_BOUND]  # a NaN speed is reported by the status flags; keep the clock sane
    for k in range(wp.static(SPEED_SLOTS)):
        max_speed[k] = wp.float32(0.0)
    clock[CLOCK_BOUND_NEXT] = bound
    return bound


@kernel
def prime_step(clock: wp.array(dtype=wp.float64), max_speed: wp.array(dtype=wp.float32), h: wp.float64):
    """CLOCK_BOUND_NEXT from the initial wave_speed pass, before the first step (whose dt the host
    sets with ``clock.land_step`` when it sets the first stop time)."""
    measure_bound(clock, max_speed, h)


@wp.func
def advance(clock: wp.array(dtype=wp.float64), steps: wp.array(dtype=wp.int64)):
    """t += dt and the step counted (the end of a step); returns the new t [s]. A time within
    round-off of t_stop is t_stop (``land``'s steps sum to it up to a few ulps)."""
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
    return t


@wp.func
def close_step(clock: wp.array(dtype=wp.float64), steps: wp.array(dtype=wp.int64)):
    """t += dt and the step counted (``advance``), the step recorded for the host
    (``clock.take_step``); returns what the next step's dt is set from (``clock.set_step``):
    (dt of this step, t, t_stop, fixed dt, factor, bound_next) [s]."""
    dt = clock[CLOCK_DT]  # (every load first: one round trip)
    t_stop = clock[CLOCK_T_STOP]
    fixed = clock[CLOCK_DT_FIXED]
    factor = clock[CLOCK_DT_FACTOR]
    bound = clock[CLOCK_BOUND]
    bound_next = clock[CLOCK_BOUND_NEXT]
    t = advance(clock, steps)
    take_step(clock, dt, bound)
    return dt, t, t_stop, fixed, factor, bound_next


@wp.func
def finish_step(clock: wp.array(dtype=wp.float64), steps: wp.array(dtype=wp.int64),
                max_speed: wp.array(dtype=wp.float32), h: wp.float64, cap: wp.float64, cap_bound: wp.float64):
    """The end of an MPM (or coupled) step, in the step's last launch: ``close_step``, then the
    next step's dt set (``clock.set_step``) from the bound the step's G2P measured. A step at
    t_stop (dt = 0) moved nothing: its G2P left the speed slots alone and CLOCK_BOUND_NEXT stands."""
    dt, t, t_stop, fixed, factor, bound_next = close_step(clock, steps)
    if dt > wp.float64(0.0):
        bound_next = measure_bound(clock, max_speed, h)
    set_step(clock, t, t_stop, fixed, factor, bound_next, cap, cap_bound)


@kernel
def end_step(clock: wp.array(dtype=wp.float64), steps: wp.array(dtype=wp.int64),
             max_speed: wp.array(dtype=wp.float32), h: wp.float64, cap: wp.float64, cap_bound: wp.float64):
    """``finish_step``: the last launch of an MPM or coupled step (granular mode: the judge's)."""
    finish_step(clock, steps, max_speed, h, cap, cap_bound)


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


@functools.cache
def make_body_probe_mass(precision: str):
    """Mass [kg/m] of the free DEM bodies (grains included) whose centroid lies inside each probe
    box lo ≤ x < hi (boxes as vec4 (x0, y0, x1, y1)) into ``out[k]``: the DEM side of a mass probe,
    the same test on the same boxes as ``make_probe_mass``'s points. ``motion`` 0 is free."""
    T, vec2 = scalar_types(precision)[:2]

    @kernel
    def body_probe_mass(x: wp.array(dtype=vec2), mass: wp.array(dtype=T), motion: wp.array(dtype=wp.int32),
                        boxes: wp.array(dtype=wp.vec4d), out: wp.array(dtype=wp.float64)):
        i = wp.tid()
        if motion[i] != 0:
            return
        px = wp.float64(x[i][0])
        py = wp.float64(x[i][1])
        for k in range(boxes.shape[0]):
            b = boxes[k]
            if px >= b[0] and py >= b[1] and px < b[2] and py < b[3]:
                wp.atomic_add(out, k, wp.float64(mass[i]))

    return body_probe_mass
