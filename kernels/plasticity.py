"""Return mappings of the granular plasticity models, as ``@wp.func`` laws (plane strain).

Sign convention as in the rest of the code: tension positive, σ the Cauchy stress, mean stress
σ_m = (σ_xx + σ_yy + σ_zz)/3 and pressure p = −σ_m. Plane strain: the in-plane stress is a 2×2
tensor and the out-of-plane stress σ_zz a separate scalar, with ε_zz = 0 (so σ_zz changes by
λ tr(Δε) elastically and by the plastic correction).

Both laws have the signature

    law(sigma: mat22, sigma_zz: T, deps: mat22, dw: mat22, dt: T, prm: vec10)
        -> (sigma_new: mat22, sigma_zz_new: T, dw_p: T)

deps = sym(L) dt is the strain increment [-], dw = skew(L) dt the spin increment [-] (pass zero
when the caller already rotated ``sigma``), dt the step [s] (only the Bagnold term uses it),
``prm`` the packed parameters (layout below, filled by ``mpmdem.model.granular_materials``) and dw_p the
plastic work increment per unit current volume σ_new : Δε^p [J/m³] (≥ 0).

Parameter layout (``PARAM_LEN`` = 10 entries, SI units; slots 0–3 mirror the vec4 of
``constitutive.py``):

    0 μ [Pa]   1 λ [Pa]   2 ρ0 [kg/m³]   3 kind_id   9 ρ_cr [kg/m³] (0: no stress-free state)
    Mohr–Coulomb (kind 2):   4 sin φ   5 cos φ   6 sin ψ   7 c [Pa]   8 η [Pa s²]
    Drucker–Prager (kind 3): 4 α_φ     5 k_c [Pa] 6 α_ψ   7 σ_t [Pa] 8 unused (0)
    μ(I) (kind 4, ``mu_i.py``): 4 μs   5 μ2   6 I0   7 d sqrt(ρs) [m sqrt(kg/m³)]   8 q_ψ

Sources: "Granular MPM" (Seyedan & Sołowski 2021) eq. 13–17, "MPM-SDEM" §2.3 eq. 25, 31–36.
"""

import functools

import warp as wp

from .types import MATERIAL_PARAMS, scalar_types

__all__ = [
    "CRITICAL_DENSITY_TOL",
    "DRUCKER_PRAGER",
    "MODELS",
    "MOHR_COULOMB",
    "MU_I",
    "PARAM_LEN",
    "make_below_critical",
    "make_drucker_prager",
    "make_mohr_coulomb",
    "param_vector",
]

MOHR_COULOMB = 2
DRUCKER_PRAGER = 3
MU_I = 4  # the law lives in ``mu_i.py``
#: model name of ``make_point_driver`` → kind id
MODELS = {"mohr_coulomb": MOHR_COULOMB, "drucker_prager": DRUCKER_PRAGER, "mu_i": MU_I}

PARAM_LEN = MATERIAL_PARAMS
P_MU, P_LAMBDA, P_RHO0, P_KIND, P_RHO_CRIT = 0, 1, 2, 3, 9
MC_SIN_PHI, MC_COS_PHI, MC_SIN_PSI, MC_COHESION, MC_BAGNOLD = 4, 5, 6, 7, 8
DP_ALPHA_PHI, DP_K_C, DP_ALPHA_PSI, DP_TENSION = 4, 5, 6, 7

#: TOL of "Granular MPM" §3.2 (the density check before eq. 13) [kg/m³].
CRITICAL_DENSITY_TOL = 1.0e-6


@functools.cache
def param_vector(precision: str) -> type:
    """The Warp vector type of one packed parameter set (``PARAM_LEN`` scalars)."""
    return scalar_types(precision).params


@functools.cache
def _vec3(precision: str) -> type:
    return wp.types.vector(3, scalar_types(precision).scalar)


@functools.cache
def make_elastic_trial(precision: str):
    """``trial(sigma, szz, deps, dw, mu, lam) -> (sigma_tr, szz_tr)`` [Pa].

    Jaumann rotation of the old stress, then Hooke's law in plane strain (MPM-SDEM eq. 25, 36):
    Δσ = λ tr(Δε) I + 2μ Δε, Δσ_zz = λ tr(Δε) since Δε_zz = 0; σ_zz does not rotate in-plane.
    """
    t = scalar_types(precision)
    T = t.scalar

    @wp.func
    def trial(sigma: t.mat22, szz: T, deps: t.mat22, dw: t.mat22, mu: T, lam: T):
        tr = deps[0, 0] + deps[1, 1]
        rotated = sigma + dw * sigma - sigma * dw
        return rotated + lam * tr * wp.identity(n=2, dtype=T) + T(2.0) * mu * deps, szz + lam * tr

    return trial


@functools.cache
def make_eigen2(precision: str):
    """``eig2(sigma) -> (s1, s2, c, s)``: in-plane principal stresses s1 ≥ s2 [Pa] and the
    direction (c, s) = (cos θ, sin θ) of s1; ``compose(s1, s2, c, s)`` builds the tensor back.
    """
    t = scalar_types(precision)
    T = t.scalar

    @wp.func
    def eig2(sigma: t.mat22):
        m = T(0.5) * (sigma[0, 0] + sigma[1, 1])
        h = T(0.5) * (sigma[0, 0] - sigma[1, 1])
        sxy = T(0.5) * (sigma[0, 1] + sigma[1, 0])
        r = wp.sqrt(h * h + sxy * sxy)
        theta = T(0.5) * wp.atan2(sxy, h)
        return m + r, m - r, wp.cos(theta), wp.sin(theta)

    @wp.func
    def compose(s1: T, s2: T, c: T, s: T):
        xy = (s1 - s2) * c * s
        return t.mat22(s1 * c * c + s2 * s * s, xy, xy, s1 * s * s + s2 * c * c)

    return eig2, compose


@functools.cache
def make_plastic_work(precision: str):
    """``work(sig_tr, szz_tr, sig_new, szz_new, mu, lam) -> σ_new : Δε^p`` [J/m³], clamped ≥ 0.

    Δε^p = C⁻¹ (σ_trial − σ_new) (isotropic compliance, all three axes); the clamp removes only
    round-off, since both returns dissipate (see the docstrings of the laws).
    """
    t = scalar_types(precision)
    T = t.scalar

    @wp.func
    def work(sig_tr: t.mat22, szz_tr: T, sig_new: t.mat22, szz_new: T, mu: T, lam: T):
        d = sig_tr - sig_new
        dzz = szz_tr - szz_new
        vol = lam / (T(3.0) * lam + T(2.0) * mu) * (d[0, 0] + d[1, 1] + dzz)
        inv2mu = T(0.5) / mu
        w = sig_new[0, 0] * (d[0, 0] - vol) + sig_new[1, 1] * (d[1, 1] - vol) + szz_new * (dzz - vol)
        w = (w + sig_new[0, 1] * d[0, 1] + sig_new[1, 0] * d[1, 0]) * inv2mu
        return wp.max(w, T(0.0))

    return work


@functools.cache
def make_shear_rate(precision: str):
    """``shear_rate(deps, dt) -> γ̇`` [1/s]: sqrt(2 ė:ė) of the deviatoric strain rate (ε̇_zz = 0).

    Equals the engineering rate γ̇ of a simple shear, the quantity of "Granular MPM" eq. 16.
    Zero when dt ≤ 0.
    """
    t = scalar_types(precision)
    T = t.scalar

    @wp.func
    def shear_rate(deps: t.mat22, dt: T):
        if dt <= T(0.0):
            return T(0.0)
        m = (deps[0, 0] + deps[1, 1]) / T(3.0)
        exy = T(0.5) * (deps[0, 1] + deps[1, 0])
        exx = deps[0, 0] - m
        eyy = deps[1, 1] - m
        ee = exx * exx + eyy * eyy + m * m + T(2.0) * exy * exy
        return wp.sqrt(T(2.0) * ee) / dt

    return shear_rate


@functools.cache
def make_below_critical(precision: str):
    """``below_critical(rho, rho_cr) -> bool``: the stress-free test of "Granular MPM" §3.2.

    True when ρ < ρ_cr − TOL (the condition before eq. 13); then the caller sets σ = 0 (eq. 13)
    and returns F to the previous step (eq. 14, 15). Never true when ρ_cr ≤ 0 (no critical density).
    """
    T = scalar_types(precision).scalar

    @wp.func
    def below_critical(rho: T, rho_cr: T):
        return rho_cr > T(0.0) and rho < rho_cr - T(CRITICAL_DENSITY_TOL)

    return below_critical


@functools.cache
def make_mc_principal(precision: str):
    """``mc_return(sig, mu, lam, sf, cf, sp, coh) -> sig_new``: Mohr–Coulomb return in principal space.

    sig = (σ_a, σ_b, σ_c), σ_a ≥ σ_b ≥ σ_c [Pa], trial outside the surface. Written for tension
    positive: the plane f = (σ_a − σ_c) + (σ_a + σ_c) sin φ − 2 c cos φ is "Granular MPM" eq. 16 with
    σ1 = −σ_c, σ3 = −σ_a (the paper counts compression positive) and c the total cohesion; the
    flow direction ∂g/∂σ = (1 + sin ψ, 0, −(1 − sin ψ)) comes from the potential of eq. 17.
    Cascade: one plane; if the order of the principal stresses breaks, the edge where two planes
    meet (two multipliers, a 2×2 linear system); if that lands beyond the apex, the apex
    σ = c cot φ (1, 1, 1). Perfect plasticity, so each branch is closed-form. At the apex
    Δε^p = C⁻¹(σ_trial − σ_apex); for ψ > 0 that lies in the normal cone of g (the tests check it),
    for ψ = 0 the potential is a prism without apex and the apex return acts as a tension cut-off.
    """
    T = scalar_types(precision).scalar
    vec3 = _vec3(precision)

    @wp.func
    def elastic_times(n: vec3, mu: T, lam: T):
        return lam * (n[0] + n[1] + n[2]) * vec3(T(1.0), T(1.0), T(1.0)) + T(2.0) * mu * n

    @wp.func
    def mc_return(sig: vec3, mu: T, lam: T, sf: T, cf: T, sp: T, coh: T):
        k = T(2.0) * coh * cf
        up_f = T(1.0) + sf
        dn_f = -(T(1.0) - sf)
        up_g = T(1.0) + sp
        dn_g = -(T(1.0) - sp)
        # plane a–c (main), a–b and b–c (the two planes meeting it at the edges)
        nf1 = vec3(up_f, T(0.0), dn_f)
        dg1 = elastic_times(vec3(up_g, T(0.0), dn_g), mu, lam)
        f1 = wp.dot(nf1, sig) - k
        out = sig - (f1 / wp.dot(nf1, dg1)) * dg1
        if out[0] >= out[1] and out[1] >= out[2]:
            return out
        nf2 = vec3(up_f, dn_f, T(0.0))
        dg2 = elastic_times(vec3(up_g, dn_g, T(0.0)), mu, lam)
        if out[1] > out[0]:
            nf2 = vec3(T(0.0), up_f, dn_f)
            dg2 = elastic_times(vec3(T(0.0), up_g, dn_g), mu, lam)
        f2 = wp.dot(nf2, sig) - k
        a11 = wp.dot(nf1, dg1)
        a12 = wp.dot(nf1, dg2)
        a21 = wp.dot(nf2, dg1)
        a22 = wp.dot(nf2, dg2)
        det = a11 * a22 - a12 * a21
        g1 = (a22 * f1 - a12 * f2) / det
        g2 = (a11 * f2 - a21 * f1) / det
        out = sig - g1 * dg1 - g2 * dg2
        # on the edge two principal stresses coincide; the return is valid unless it passed the apex
        if out[0] >= out[2]:
            return out
        apex = coh * cf / sf
        return vec3(apex, apex, apex)

    return mc_return


@functools.cache
def make_mohr_coulomb(precision: str):
    """Non-associated Mohr–Coulomb with the Bagnold rate term ("Granular MPM" eq. 16–17).

    ``law(sigma, sigma_zz, deps, dw, dt, prm) -> (sigma_new, sigma_zz_new, dw_p)``; see the module
    docstring for units and ``prm``. The rate term 2 η γ̇² cos φ of eq. 16 enters exactly like a
    cohesion, so the return uses c_eff = c + η γ̇², with γ̇ from the total strain increment of the
    step (``make_shear_rate``). The third principal stress is σ_zz; the in-plane eigenvectors are
    kept, so the return is coaxial. dw_p = Δγ [2 c_eff cos φ − (σ_a + σ_c)(sin φ − sin ψ)] ≥ 0 on
    the surface because ψ ≤ φ.
    """
    t = scalar_types(precision)
    T = t.scalar
    vecp = param_vector(precision)
    vec3 = _vec3(precision)
    trial = make_elastic_trial(precision)
    eig2, compose = make_eigen2(precision)
    work = make_plastic_work(precision)
    shear_rate = make_shear_rate(precision)
    mc_return = make_mc_principal(precision)

    @wp.func
    def mohr_coulomb(sigma: t.mat22, sigma_zz: T, deps: t.mat22, dw: t.mat22, dt: T, prm: vecp):
        mu = prm[P_MU]
        lam = prm[P_LAMBDA]
        sf = prm[MC_SIN_PHI]
        cf = prm[MC_COS_PHI]
        rate = shear_rate(deps, dt)
        coh = prm[MC_COHESION] + prm[MC_BAGNOLD] * rate * rate
        sig_tr, szz_tr = trial(sigma, sigma_zz, deps, dw, mu, lam)
        s1, s2, c, s = eig2(sig_tr)
        # sort (s1, s2, σ_zz) descending; rank = where σ_zz sits (0 major, 1 intermediate, 2 minor)
        rank = wp.int32(1)
        p = vec3(s1, szz_tr, s2)
        if szz_tr >= s1:
            rank = int(0)
            p = vec3(szz_tr, s1, s2)
        elif szz_tr <= s2:
            rank = 2
            p = vec3(s1, s2, szz_tr)
        if (p[0] - p[2]) + (p[0] + p[2]) * sf - T(2.0) * coh * cf <= T(0.0):
            return sig_tr, szz_tr, T(0.0)
        q = mc_return(p, mu, lam, sf, cf, prm[MC_SIN_PSI], coh)
        n1 = q[0]
        n2 = q[2]
        nzz = q[1]
        if rank == 0:
            n1 = q[1]
            nzz = q[0]
        elif rank == 2:
            n2 = q[1]
            nzz = q[2]
        sig_new = compose(n1, n2, c, s)
        return sig_new, nzz, work(sig_tr, szz_tr, sig_new, nzz, mu, lam)

    return mohr_coulomb


@functools.cache
def make_drucker_prager(precision: str):
    """Drucker–Prager with dilatancy and a tension cut-off ("MPM-SDEM" eq. 31–36).

    Shear surface f_s = τ + q_φ σ_m − k_φ (eq. 31), τ = sqrt(J2) of the 3D deviator (eq. 33),
    σ_m = I1/3 (eq. 34), q_φ = 3 α_φ, k_φ = k_c (eq. 35); tension surface f_t = σ_m − σ_t (eq. 32).
    Flow: g_s = τ + q_ψ σ_m with q_ψ = 3 α_ψ (non-associated) and g_t = f_t. The trial lands in
    one of three regions of the (σ_m, τ) plane, split by the elastic images of the flow directions
    through the corner (σ_t, τ_c), τ_c = k_c − q_φ σ_t ≥ 0:
      shear:   Δλ = f_s / (μ + K q_φ q_ψ); τ −= μ Δλ, σ_m −= K q_ψ Δλ (radial in the deviator),
      tension: σ_m = σ_t, deviator kept (τ ≤ τ_c),
      corner:  σ_m = σ_t, τ = τ_c (the apex when σ_t is the apex value k_c / q_φ).
    ``law(sigma, sigma_zz, deps, dw, dt, prm) -> (sigma_new, sigma_zz_new, dw_p)``; dt is unused.
    dw_p ≥ 0: Δλ (k_c − (q_φ − q_ψ) σ_m) in shear, σ_t Δε_v^p in tension, with 0 ≤ σ_t ≤ apex.
    """
    t = scalar_types(precision)
    T = t.scalar
    vecp = param_vector(precision)
    trial = make_elastic_trial(precision)
    work = make_plastic_work(precision)

    @wp.func
    def drucker_prager(sigma: t.mat22, sigma_zz: T, deps: t.mat22, dw: t.mat22, dt: T, prm: vecp):
        mu = prm[P_MU]
        lam = prm[P_LAMBDA]
        q_phi = T(3.0) * prm[DP_ALPHA_PHI]
        q_psi = T(3.0) * prm[DP_ALPHA_PSI]
        k_c = prm[DP_K_C]
        s_t = prm[DP_TENSION]
        bulk = lam + T(2.0) / T(3.0) * mu
        sig_tr, szz_tr = trial(sigma, sigma_zz, deps, dw, mu, lam)
        sm = (sig_tr[0, 0] + sig_tr[1, 1] + szz_tr) / T(3.0)
        dev = sig_tr - sm * wp.identity(n=2, dtype=T)
        dzz = szz_tr - sm
        j2 = T(0.5) * (dev[0, 0] * dev[0, 0] + dev[1, 1] * dev[1, 1] + dzz * dzz)
        tau = wp.sqrt(j2 + T(0.5) * (dev[0, 1] * dev[0, 1] + dev[1, 0] * dev[1, 0]))
        fs = tau + q_phi * sm - k_c
        if fs <= T(0.0) and sm <= s_t:
            return sig_tr, szz_tr, T(0.0)
        tau_c = k_c - q_phi * s_t
        sm_new = s_t
        tau_new = tau
        if tau > tau_c:
            if sm - s_t >= bulk * q_psi * (tau - tau_c) / mu:
                tau_new = tau_c
            else:
                dl = fs / (mu + bulk * q_phi * q_psi)
                sm_new = sm - bulk * q_psi * dl
                tau_new = tau - mu * dl
        scale = T(0.0)
        if tau > T(0.0):
            scale = tau_new / tau
        sig_new = scale * dev + sm_new * wp.identity(n=2, dtype=T)
        szz_new = scale * dzz + sm_new
        return sig_new, szz_new, work(sig_tr, szz_tr, sig_new, szz_new, mu, lam)

    return drucker_prager
