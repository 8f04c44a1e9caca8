"""The rigid-body update of the DEM and its step bookkeeping: semi-implicit Euler of the bodies
(MPM-SDEM eq. 17–20 and eq. 42, as the MPM stage), prescribed motion of kinematic bodies and the
work they do, the end of a step on the device clock, and the energy and momentum sums of the
diagnostics.
"""

import functools

import warp as wp

from .clock import (
    CLOCK_DT,
    CLOCK_T,
    set_step,
)
from .dem_bodies import FREE, KINEMATIC, STATUS_NONFINITE, STATUS_OUTSIDE, make_dem_structs
from .dem_period import make_dem_period
from .reductions import close_step
from .types import Namespace, kernel, scalar_types

__all__ = ["DIAG_NAMES", "make_dem_integration"]


@functools.cache
def make_dem_integration(precision: str, periodic: bool = False):
    """Kernels ``integrate``, ``end_step`` and ``diagnostics`` of the DEM stage for one precision;
    ``periodic``: x periodic, a centroid leaving [lo_x, hi_x) wrapped by one period."""
    t = scalar_types(precision)
    T = t.scalar
    vec2 = t.vec2
    Bodies, Contacts, Params = make_dem_structs(precision)
    wrap_x = make_dem_period(precision).wrap_x

    @kernel
    def integrate(B: Bodies, prm: Params, clock: wp.array(dtype=wp.float64), status: wp.array(dtype=wp.int32)):
        """Semi-implicit Euler (leapfrog with half-step velocities, as the MPM stage, MPM-SDEM
        eq. 17-20): v += dt F/m, x += dt v; the same for ω and the angle (eq. 42)."""
        i = wp.tid()
        dt = T(clock[CLOCK_DT])
        t = clock[CLOCK_T]
        v = B.v[i]
        w = B.omega[i]
        if B.motion[i] == KINEMATIC:
            window = B.kin_window[i]
            v = vec2()
            w = T(0.0)
            if t >= window[0] and t < window[1]:
                v = B.kin_v[i]
                w = B.kin_omega[i]
            # the driven body exerts −F, −τ on the others: their power is −(F·v + τ ω)
            B.work[i] = B.work[i] - wp.float64((wp.dot(B.force[i], v) + B.torque[i] * w) * dt)
        else:
            ramp = float(1.0)
            if prm.gravity_ramp > 0.0:
                ramp = wp.min(float(t) / prm.gravity_ramp, 1.0)
            v = v + dt * (B.inv_mass[i] * B.force[i] + T(ramp) * prm.gravity)
            w = w + dt * B.inv_inertia[i] * B.torque[i]
        x = B.x[i] + dt * v
        if wp.static(periodic):
            xw = wrap_x(x, prm)
            if xw[0] != x[0] and B.motion[i] == FREE:
                # the potential energy −m g·x jumps by −m g_x Δx as the centroid moves back by Δx across
                # the seam: booked as work brought in (in ``work``, summed with the driven work)
                gr = float(1.0)
                if prm.gravity_ramp > 0.0:
                    gr = wp.min(float(t) / prm.gravity_ramp, 1.0)
                B.work[i] = B.work[i] - wp.float64(B.mass[i] * T(gr) * prm.gravity[0] * (xw[0] - x[0]))
            x = xw
        B.v[i] = v
        B.omega[i] = w
        B.x[i] = x
        B.angle[i] = B.angle[i] + dt * w
        if not (wp.isfinite(x[0]) and wp.isfinite(x[1]) and wp.isfinite(v[0]) and wp.isfinite(v[1])
                and wp.isfinite(w)):
            wp.atomic_add(status, STATUS_NONFINITE, 1)
        elif B.motion[i] == FREE and (x[0] < prm.lo[0] or x[0] > prm.hi[0] or x[1] < prm.lo[1] or x[1] > prm.hi[1]):
            wp.atomic_add(status, STATUS_OUTSIDE, 1)

    @kernel
    def end_step(clock: wp.array(dtype=wp.float64), steps: wp.array(dtype=wp.int64)):
        """The last launch of a DEM step: t += dt and the step recorded for the host
        (``reductions.close_step``), and the next step's dt set (``clock.set_step``): the fixed dt, or
        the factor × the bound (both set once: they depend on masses and k_n only), split evenly to
        end on t_stop; 0 once the clock has reached t_stop."""
        dt, t, t_stop, fixed, factor, bound_next = close_step(clock, steps)
        set_step(clock, t, t_stop, fixed, factor, bound_next, wp.float64(0.0), wp.float64(0.0))

    # -- diagnostics ----------------------------------------------------------------------------
    @kernel
    def diagnostics(B: Bodies, C: Contacts, prm: Params, out: wp.array(dtype=wp.float64)):
        """Sums of: kinetic, gravity, contact energy, momenta x, y, angular, mass (free bodies),
        damping and friction work dissipated in contacts (all pairs), work of kinematic bodies (and,
        periodic x, the potential energy the free bodies brought across the seam)."""
        i = wp.tid()
        e = wp.float64(0.0)
        lost = C.body_dissipated[i]
        for s in range(C.slots):
            e += wp.float64(C.energy[i * C.slots + s])
            lost = lost + C.dissipated[i * C.slots + s]
        wp.atomic_add(out, 2, e)
        wp.atomic_add(out, 7, lost[0])
        wp.atomic_add(out, 8, lost[1])
        if wp.static(periodic):  # (a free body's: the potential energy it brought across the seam)
            if B.motion[i] == FREE:
                wp.atomic_add(out, 9, B.work[i])
        if B.motion[i] != FREE:
            wp.atomic_add(out, 9, B.work[i])
            return
        m = wp.float64(B.mass[i])
        inertia = wp.float64(B.inertia[i])
        vx = wp.float64(B.v[i][0])
        vy = wp.float64(B.v[i][1])
        w = wp.float64(B.omega[i])
        x = wp.float64(B.x[i][0])
        y = wp.float64(B.x[i][1])
        wp.atomic_add(out, 0, wp.float64(0.5) * (m * (vx * vx + vy * vy) + inertia * w * w))
        wp.atomic_add(out, 1, -m * (wp.float64(prm.gravity[0]) * x + wp.float64(prm.gravity[1]) * y))
        wp.atomic_add(out, 3, m * vx)
        wp.atomic_add(out, 4, m * vy)
        wp.atomic_add(out, 5, m * (x * vy - y * vx) + inertia * w)
        wp.atomic_add(out, 6, m)

    return Namespace(integrate=integrate, end_step=end_step, diagnostics=diagnostics)


#: Order of the sums written by the diagnostics kernel.
DIAG_NAMES = (
    "energy_kinetic",
    "energy_gravity",
    "energy_contact",
    "momentum_x",
    "momentum_y",
    "momentum_angular",
    "mass",
    "dissipated_damping",
    "dissipated_friction",
    "work_driven",
)
