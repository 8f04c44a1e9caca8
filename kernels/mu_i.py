"""The μ(I) rheology as an elasto-viscoplastic return mapping (a ``@wp.func`` law, plane strain).

Same sign convention and signature as the laws of ``plasticity.py`` (tension positive, p = −σ_m):

    law(sigma: mat22, sigma_zz: T, deps: mat22, dw: mat22, dt: T, prm: vec10)
        -> (sigma_new: mat22, sigma_zz_new: T, dw_p: T)

The friction coefficient of a flowing point depends on its inertial number
I = γ̇ᵖ d / sqrt(p / ρs) (γ̇ᵖ the plastic shear rate [1/s], d the grain diameter [m], ρs the grain
density [kg/m³], p the pressure [Pa]): μ(I) = μs + (μ2 − μs) / (I0 / I + 1) (Jop, Forterre &
Pouliquen 2006, eq. 2). The return follows the closed form of Dunatunga & Kamrin 2015 (§3): an
elastic trial (Jaumann rotation + plane-strain Hooke), then

  p_tr ≤ 0:             the grains separate, σ = 0 (the stress-free state; the density check of
                        "Granular MPM" §3.2 applies on top when the material has ρ_cr);
  τ_tr ≤ μs p_tr:       elastic;
  otherwise:            radial return of the deviator, τ = τ_tr − x with x = G Δγᵖ ≥ 0 the root of
                        τ_tr − x = p μ(I(x)),  I(x) = x d sqrt(ρs) / (G dt sqrt(p)).

τ = sqrt(J2) of the 3D deviator (σ_zz included) and Δγᵖ = √2 |Δεᵖ_dev| the engineering plastic
shear increment, so a simple shear at rate γ̇ has τ/p = μ(I) with I = γ̇ d / sqrt(p/ρs). With
a = τ_tr − μs p, Δμ = μ2 − μs and c = I0 G dt sqrt(p) / (d sqrt(ρs)) the root solves the quadratic
x² − (a − c − p Δμ) x − a c = 0; its positive root lies in (0, a), so μs p < τ_new < min(τ_tr, μ2 p).

Optional dilatancy (slot 8, q_ψ = 3 α_ψ as for Drucker–Prager): plastic shear then dilates,
Δεᵖ_v = q_ψ Δγᵖ, which raises the pressure of the constrained point by K q_ψ Δγᵖ. The root then
has no closed form; a bracketed regula falsi (Illinois) on [0, x(p_tr)] finds it.

Parameter layout (``PARAM_LEN`` = 10, SI): 0 μ_G [Pa] 1 λ [Pa] 2 ρ0 [kg/m³] 3 kind = 4
4 μs 5 μ2 6 I0 7 d sqrt(ρs) [m sqrt(kg/m³)] 8 q_ψ 9 ρ_cr [kg/m³] (0: none).
"""

import functools

import warp as wp

from .plasticity import MU_I, P_LAMBDA, P_MU, make_elastic_trial, make_plastic_work, param_vector
from .types import scalar_types

__all__ = ["MU_I", "MUI_D_SQRT_RHO", "MUI_I0", "MUI_MU2", "MUI_MUS", "MUI_Q_PSI", "make_mu_i"]

MUI_MUS, MUI_MU2, MUI_I0, MUI_D_SQRT_RHO, MUI_Q_PSI = 4, 5, 6, 7, 8

#: regula falsi iterations of the dilatant return (the bracket shrinks superlinearly; 40 reach
#: round-off in f64 for any q_ψ ≤ 1)
_DILATANT_ITERATIONS = 40


@functools.cache
def make_mu_i(precision: str):
    """The μ(I) law ``law(sigma, sigma_zz, deps, dw, dt, prm) -> (sigma_new, sigma_zz_new, dw_p)``.

    Units as in the module docstring; dw_p = σ_new : Δεᵖ [J/m³] ≥ 0. With dt ≤ 0 (a rate that
    cannot be measured) the flow is taken as infinitely fast: τ = min(τ_tr, μ2 p).
    """
    t = scalar_types(precision)
    T = t.scalar
    vecp = param_vector(precision)
    trial = make_elastic_trial(precision)
    work = make_plastic_work(precision)

    @wp.func
    def slip(tau_tr: T, p: T, mus: T, dmu: T, rate_scale: T):
        # x = G Δγᵖ with τ_tr − x = p μ(I(x)), I = x / rate_scale: the positive root of
        # x² − b x − a c = 0, b = a − c − p Δμ, c = I0 rate_scale (Dunatunga & Kamrin 2015 §3)
        a = tau_tr - mus * p
        if a <= T(0.0):
            return T(0.0)
        c = rate_scale
        b = a - c - p * dmu
        disc = wp.sqrt(b * b + T(4.0) * a * c)
        if b >= T(0.0):
            return T(0.5) * (b + disc)
        if disc - b <= T(0.0):
            return T(0.0)
        return T(2.0) * a * c / (disc - b)  # the same root, free of cancellation when b < 0

    @wp.func
    def rate_scale_of(p: T, mu_g: T, dt: T, i0: T, d_sqrt_rho: T):
        # I0 G dt sqrt(p) / (d sqrt(ρs)): the x at which I = I0
        return i0 * mu_g * dt * wp.sqrt(p) / d_sqrt_rho

    @wp.func
    def friction(x: T, c: T, mus: T, dmu: T):
        # μ(I) with I = I0 x / c: μs + Δμ x / (c + x); μ2 once c = 0 (an unmeasurable, fast rate)
        if x <= T(0.0):
            return mus
        return mus + dmu * x / (c + x)

    @wp.func
    def residual(x: T, tau_tr: T, p: T, mus: T, dmu: T, mu_g: T, dt: T, i0: T, d_sqrt_rho: T):
        # τ_tr − x − μ(I(x, p)) p [Pa]: zero at the return's slip x
        return tau_tr - x - p * friction(x, rate_scale_of(p, mu_g, dt, i0, d_sqrt_rho), mus, dmu)

    @wp.func
    def mu_i(sigma: t.mat22, sigma_zz: T, deps: t.mat22, dw: t.mat22, dt: T, prm: vecp):
        mu_g = prm[P_MU]
        lam = prm[P_LAMBDA]
        mus = prm[MUI_MUS]
        dmu = prm[MUI_MU2] - mus
        i0 = prm[MUI_I0]
        d_sqrt_rho = prm[MUI_D_SQRT_RHO]
        q_psi = prm[MUI_Q_PSI]
        sig_tr, szz_tr = trial(sigma, sigma_zz, deps, dw, mu_g, lam)
        sm = (sig_tr[0, 0] + sig_tr[1, 1] + szz_tr) / T(3.0)
        p_tr = -sm
        if p_tr <= T(0.0):
            zero = t.mat22()
            return zero, T(0.0), work(sig_tr, szz_tr, zero, T(0.0), mu_g, lam)
        eye = wp.identity(n=2, dtype=T)
        dev = sig_tr - sm * eye
        dzz = szz_tr - sm
        j2 = T(0.5) * (dev[0, 0] * dev[0, 0] + dev[1, 1] * dev[1, 1] + dzz * dzz)
        tau_tr = wp.sqrt(j2 + T(0.5) * (dev[0, 1] * dev[0, 1] + dev[1, 0] * dev[1, 0]))
        if tau_tr <= mus * p_tr:
            return sig_tr, szz_tr, T(0.0)
        step = wp.max(dt, T(0.0))
        x = slip(tau_tr, p_tr, mus, dmu, rate_scale_of(p_tr, mu_g, step, i0, d_sqrt_rho))
        p_new = p_tr
        if q_psi > T(0.0):
            # dilatancy: p(x) = p_tr + K q_ψ x / G; r(x) = τ_tr − x − μ(x) p(x) falls monotonically
            # and r(0) > 0 ≥ r(x(p_tr)): Illinois regula falsi on that bracket
            dil = (lam + T(2.0) / T(3.0) * mu_g) * q_psi / mu_g
            lo = T(0.0)
            hi = x
            r_lo = tau_tr - mus * p_tr
            r_hi = residual(hi, tau_tr, p_tr + dil * hi, mus, dmu, mu_g, step, i0, d_sqrt_rho)
            side = int(0)
            for _it in range(_DILATANT_ITERATIONS):
                if r_hi >= T(0.0) or r_lo <= r_hi:
                    break
                xm = (lo * r_hi - hi * r_lo) / (r_hi - r_lo)
                rm = residual(xm, tau_tr, p_tr + dil * xm, mus, dmu, mu_g, step, i0, d_sqrt_rho)
                if rm > T(0.0):
                    lo = xm
                    r_lo = rm
                    if side == 1:
                        r_hi = T(0.5) * r_hi
                    side = 1
                else:
                    hi = xm
                    r_hi = rm
                    if side == -1:
                        r_lo = T(0.5) * r_lo
                    side = -1
            x = hi
            if r_hi < T(0.0) and r_lo > T(0.0):
                x = (lo * r_hi - hi * r_lo) / (r_hi - r_lo)
            p_new = p_tr + dil * x
        tau_new = wp.max(tau_tr - x, T(0.0))
        scale = tau_new / tau_tr
        sig_new = scale * dev - p_new * eye
        szz_new = scale * dzz - p_new
        return sig_new, szz_new, work(sig_tr, szz_tr, sig_new, szz_new, mu_g, lam)

    return mu_i
