"""A strain-driven single-point driver of the granular laws (``plasticity.py``, ``mu_i.py``): the
tests' and calibrations' way to run a return mapping along a prescribed strain path, one thread
per material point."""

import functools

import warp as wp

from .mu_i import make_mu_i
from .plasticity import (
    MODELS,
    P_LAMBDA,
    P_MU,
    P_RHO0,
    P_RHO_CRIT,
    make_below_critical,
    make_drucker_prager,
    make_mohr_coulomb,
    param_vector,
)
from .types import kernel, scalar_types

__all__ = ["make_point_driver"]


@functools.cache
def make_point_driver(precision: str, model: str):
    """Strain-driven single-point test kernel, one thread per material point.

    ``drive(sigma0, szz0, prm, deps, dw, dt, hold_xx, sxx_target, sig_out, szz_out, work_out,
    j_out, deps_out)``, launched with dim = number of points P, N steps:
      sigma0 [P] mat22, szz0 [P] T: initial stress [Pa]; prm [P] packed parameters;
      deps, dw [P, N] mat22: strain and spin increments per step [-]; dt: step [s];
      hold_xx [P] int32, sxx_target [P] T [Pa]: where hold_xx ≠ 0, deps_xx of every step is
        replaced by the value that keeps σ_xx = sxx_target after the return (secant iterations;
        a biaxial test at constant lateral stress);
      sig_out, szz_out, work_out, j_out, deps_out [P, N]: stress, plastic work increment [J/m³],
        volume ratio J = V/V0 and the strain increment actually applied, after every step.
    J follows det(I + Δε + Δw) each step. When ρ0 / J falls below the critical density the point
    becomes stress-free and keeps the previous J ("Granular MPM" eq. 13–15); the work of that step
    is recorded as 0 (the released elastic energy is the caller's to book).
    """
    if model not in MODELS:
        raise ValueError(f"model={model!r}: one of {sorted(MODELS)}")
    t = scalar_types(precision)
    T = t.scalar
    vecp = param_vector(precision)
    laws = {"mohr_coulomb": make_mohr_coulomb, "drucker_prager": make_drucker_prager, "mu_i": make_mu_i}
    law = laws[model](precision)
    below_critical = make_below_critical(precision)
    rtol = 1.0e-14 if precision == "f64" else 1.0e-6
    atol = 1.0e-300 if precision == "f64" else 1.0e-30

    @wp.func
    def sxx_after(sig: t.mat22, szz: T, d: t.mat22, w: t.mat22, dt: T, prm: vecp, x: T):
        sn, zn, wk = law(sig, szz, t.mat22(x, d[0, 1], d[1, 0], d[1, 1]), w, dt, prm)
        return sn[0, 0]

    @wp.func
    def hold_sxx(sig: t.mat22, szz: T, d: t.mat22, w: t.mat22, dt: T, prm: vecp, target: T):
        # secant iterations on deps_xx for σ_xx(deps_xx) = target, started from the elastic slope
        x0 = d[0, 0]
        r0 = sxx_after(sig, szz, d, w, dt, prm, x0) - target
        x1 = x0 - r0 / (prm[P_LAMBDA] + T(2.0) * prm[P_MU])
        for _it in range(60):
            r1 = sxx_after(sig, szz, d, w, dt, prm, x1) - target
            if r1 == r0 or wp.abs(x1 - x0) <= T(rtol) * wp.abs(x1) + T(atol):
                break
            x2 = x1 - r1 * (x1 - x0) / (r1 - r0)
            x0 = x1
            r0 = r1
            x1 = x2
        return t.mat22(x1, d[0, 1], d[1, 0], d[1, 1])

    @kernel
    def drive(
        sigma0: wp.array(dtype=t.mat22),
        szz0: wp.array(dtype=T),
        prm: wp.array(dtype=vecp),
        deps: wp.array2d(dtype=t.mat22),
        dw: wp.array2d(dtype=t.mat22),
        dt: T,
        hold_xx: wp.array(dtype=wp.int32),
        sxx_target: wp.array(dtype=T),
        sig_out: wp.array2d(dtype=t.mat22),
        szz_out: wp.array2d(dtype=T),
        work_out: wp.array2d(dtype=T),
        j_out: wp.array2d(dtype=T),
        deps_out: wp.array2d(dtype=t.mat22),
    ):
        p = wp.tid()
        pr = prm[p]
        sig = sigma0[p]
        szz = szz0[p]
        jac = T(1.0)
        eye = wp.identity(n=2, dtype=T)
        for k in range(deps.shape[1]):
            d = deps[p, k]
            if hold_xx[p] != 0:
                d = hold_sxx(sig, szz, d, dw[p, k], dt, pr, sxx_target[p])
            sn, zn, wk = law(sig, szz, d, dw[p, k], dt, pr)
            jn = jac * wp.determinant(eye + d + dw[p, k])
            if below_critical(pr[P_RHO0] / jn, pr[P_RHO_CRIT]):
                sn = t.mat22()
                zn = T(0.0)
                wk = T(0.0)
                jn = jac
            sig = sn
            szz = zn
            jac = jn
            sig_out[p, k] = sig
            szz_out[p, k] = szz
            work_out[p, k] = wk
            j_out[p, k] = jac
            deps_out[p, k] = d

    return drive
