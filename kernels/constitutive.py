"""Stress updates of the material models, as ``@wp.func`` laws shared by every G2P variant.

Plane strain: 2×2 in-plane tensors, zero out-of-plane strain. Material parameters per material
are packed as vec4 (μ, λ, ρ0, kind) with kind = 0 linear elastic, 1 Neo-Hookean.
"""


import functools

import warp as wp

from .types import Namespace, kernel, scalar_types

__all__ = [
    "LINEAR_ELASTIC",
    "NEO_HOOKEAN",
    "make_derived_state",
    "make_strain_energy_density",
    "make_stress_update",
    "stress_from_deformation",
]

LINEAR_ELASTIC = 0
NEO_HOOKEAN = 1


@functools.cache
def make_strain_energy_density(precision: str):
    """``psi(F, mu, lam)``: Neo-Hookean stored energy per reference volume [J/m³]."""
    T = scalar_types(precision).scalar
    mat22 = scalar_types(precision).mat22

    @wp.func
    def psi(F: mat22, mu: T, lam: T):
        # "MPM notes" (first simulation): ½λ(ln J)² − μ ln J + ½μ(tr FᵀF − 3), with F33 = 1.
        lnj = wp.log(wp.determinant(F))
        tr = F[0, 0] * F[0, 0] + F[0, 1] * F[0, 1] + F[1, 0] * F[1, 0] + F[1, 1] * F[1, 1]
        return T(0.5) * lam * lnj * lnj - mu * lnj + T(0.5) * mu * (tr - T(2.0))

    return psi


@functools.cache
def make_stress_update(kinds: tuple[int, ...], precision: str):
    """``update(kind, F_new, sigma, L, dt, mu, lam) -> sigma_new``.

    Only the material kinds present in the scene are compiled in (``kinds``).
    """
    T = scalar_types(precision).scalar
    mat22 = scalar_types(precision).mat22
    has_le = LINEAR_ELASTIC in kinds
    has_nh = NEO_HOOKEAN in kinds

    @wp.func
    def update(kind: int, F_new: mat22, sigma: mat22, L: mat22, dt: T, mu: T, lam: T):
        eye = wp.identity(n=2, dtype=T)
        out = sigma
        if wp.static(has_le):
            if kind == LINEAR_ELASTIC:
                # Hypoelastic Hooke law with the Jaumann rate (MPM-SDEM eq. 21, 22, 25):
                # σ̇ = λ tr(ε̇) I + 2μ ε̇ + W σ − σ W, ε̇ = sym(L), W = skew(L).
                eps = T(0.5) * (L + wp.transpose(L))
                W = T(0.5) * (L - wp.transpose(L))
                rate = lam * wp.trace(eps) * eye + T(2.0) * mu * eps + W * sigma - sigma * W
                out = sigma + dt * rate
        if wp.static(has_nh):
            if kind == NEO_HOOKEAN:
                # Compressible Neo-Hookean Cauchy stress ("MPM notes", step 8).
                J = wp.determinant(F_new)
                out = (mu / J) * (F_new * wp.transpose(F_new) - eye) + (lam * wp.log(J) / J) * eye
        return out

    return update


def stress_from_deformation(kinds: tuple[int, ...], critical: bool) -> bool:
    """Whether every point's Cauchy stress and volume follow from its F alone (hyperelastic
    materials only, no stress-free state): then G2P stores only F, and the force P2G computes
    V σ from F (as MLS-MPM does), which saves a point 20 bytes written and read a step (f32)."""
    return tuple(kinds) == (NEO_HOOKEAN,) and not critical


@functools.cache
def make_derived_state(kinds: tuple[int, ...], precision: str):
    """``volume_stress(P, p, m) -> (V, σ)``: the volume [m²/m] V0 det F and the Cauchy stress [Pa]
    of point p from its F (``stress_from_deformation`` scenes), the same arithmetic as the stored
    update, so both give the same bits; and the kernel ``refresh(P, materials)`` that writes them
    into ``P.vol`` and ``P.stress`` for the host (output frames, checkpoints)."""
    t = scalar_types(precision)
    T = t.scalar
    from .state import make_state_structs  # noqa: PLC0415

    Particles = make_state_structs(precision)[0]
    elastic = make_stress_update(kinds, precision)

    @wp.func
    def volume_stress(P: Particles, p: int, m: t.params):
        F = P.F[p]
        vol = P.vol0[p] * wp.determinant(F)
        sigma = elastic(int(m[3]), F, t.mat22(), t.mat22(), T(0.0), m[0], m[1])
        return vol, sigma

    @kernel
    def refresh(P: Particles, materials: wp.array(dtype=t.params)):
        p = wp.tid()
        vol, sigma = volume_stress(P, p, materials[P.material[p]])
        P.vol[p] = vol
        P.stress[p] = sigma

    return Namespace(volume_stress=volume_stress, refresh=refresh)


#: Density control of points below their critical density ("Granular MPM" §3.2): "none" only
#: zeroes the stress (the stress-free MPM of Dunatunga & Kamrin), "revert" also returns F to the
#: previous step (eq. 13–15), "volumetric" removes only the volume change (eq. 18).
DENSITY_CONTROLS = ("none", "revert", "volumetric")


@functools.cache
def make_point_update(kinds: tuple[int, ...], precision: str, density_control: str = "revert",
                      critical: bool = False, derived: bool = False):
    """``point_update(P, p, m, L, dt) -> (dissipated, V)``: the stress update of point p, the
    energy it dissipated [J/m, ≤ 0] and the new volume [m²/m].

    Updates F = (I + L dt) F ("MPM notes" step 8), the volume V = V0 det F, the Cauchy stress by
    the law of the point's material (row ``m`` of the material table), σ_zz for the plastic laws,
    and the stored elastic energy (trapezoidal stress power minus plastic work). Returns the
    energy dissipated this step: the plastic work σ : Δε^p V, and the stored energy released when
    the point turns stress-free. ``critical``: some material has a critical density, so the
    density check of "Granular MPM" §3.2 is compiled in (eq. 13 with the chosen control).
    Only the material kinds present (``kinds``) are compiled in. ``derived``: σ and V follow from
    F (``stress_from_deformation``), so only F is stored (``make_derived_state`` recomputes them).
    """
    from .plasticity import (  # noqa: PLC0415 (plasticity imports this module's types only)
        DRUCKER_PRAGER,
        MOHR_COULOMB,
        MU_I,
        P_RHO_CRIT,
        make_below_critical,
        make_drucker_prager,
        make_mohr_coulomb,
    )

    if density_control not in DENSITY_CONTROLS:
        raise ValueError(f"density_control={density_control!r}: one of {DENSITY_CONTROLS}")
    t = scalar_types(precision)
    T = t.scalar
    from .state import make_state_structs  # noqa: PLC0415

    Particles = make_state_structs(precision)[0]
    elastic = make_stress_update(kinds, precision)
    has_mc = MOHR_COULOMB in kinds
    has_dp = DRUCKER_PRAGER in kinds
    has_mu_i = MU_I in kinds
    plastic = has_mc or has_dp or has_mu_i
    rate_form = LINEAR_ELASTIC in kinds or plastic
    mohr_coulomb = make_mohr_coulomb(precision) if has_mc else None
    drucker_prager = make_drucker_prager(precision) if has_dp else None
    mu_i = None
    if has_mu_i:
        from .mu_i import make_mu_i  # noqa: PLC0415

        mu_i = make_mu_i(precision)
    below_critical = make_below_critical(precision)
    revert = density_control == "revert"
    volumetric = density_control == "volumetric"

    @wp.func
    def point_update(P: Particles, p: int, m: t.params, L: t.mat22, dt: T):
        kind = int(m[3])
        F_old = P.F[p]
        F_new = (wp.identity(n=2, dtype=T) + dt * L) * F_old
        sigma_old = t.mat22()
        vol_old = T(0.0)
        energy = T(0.0)
        if wp.static(rate_form):
            sigma_old = P.stress[p]  # only the rate-form laws need the previous state
            vol_old = P.vol[p]
            energy = P.strain_energy[p]
        sigma_new = elastic(kind, F_new, sigma_old, L, dt, m[0], m[1])
        szz_new = T(0.0)
        w_plastic = T(0.0)
        deps = (T(0.5) * dt) * (L + wp.transpose(L))
        if wp.static(plastic):
            if kind >= 2:
                spin = (T(0.5) * dt) * (L - wp.transpose(L))
                szz_old = P.szz[p]
                if wp.static(has_mc):
                    if kind == MOHR_COULOMB:
                        sigma_new, szz_new, w_plastic = mohr_coulomb(sigma_old, szz_old, deps, spin, dt, m)
                if wp.static(has_dp):
                    if kind == DRUCKER_PRAGER:
                        sigma_new, szz_new, w_plastic = drucker_prager(sigma_old, szz_old, deps, spin, dt, m)
                if wp.static(has_mu_i):
                    if kind == MU_I:
                        sigma_new, szz_new, w_plastic = mu_i(sigma_old, szz_old, deps, spin, dt, m)
        vol_new = P.vol0[p] * wp.determinant(F_new)
        dissipated = wp.float64(0.0)
        energy_old = energy
        vol_avg = T(0.5) * (vol_old + vol_new)
        if wp.static(rate_form):
            if kind != NEO_HOOKEAN:
                # stored energy: trapezoidal stress power (exact for a linear law; Δε_zz = 0 so σ_zz
                # does no work) minus the plastic work σ : Δε^p V, which is dissipated
                w = T(0.5) * wp.ddot(sigma_old + sigma_new, deps) * vol_avg
                energy = energy + w - w_plastic * vol_new
                dissipated = -wp.float64(w_plastic * vol_new)
        if wp.static(critical):
            rho_cr = m[P_RHO_CRIT]
            if below_critical(P.mass[p] / vol_new, rho_cr):
                # "Granular MPM" eq. 13: stress-free. The law's update of this step is discarded;
                # the stored energy, plus the work the old stress did over the step (the forces of
                # this step used it), is released: all of it is booked as dissipated.
                sigma_new = t.mat22()
                szz_new = T(0.0)
                released = energy_old
                if wp.static(rate_form):
                    released = released + T(0.5) * wp.ddot(sigma_old, deps) * vol_avg
                dissipated = -wp.float64(released)
                energy = T(0.0)
                if wp.static(revert):
                    # eq. 14: F = (I + L dt)⁻¹ F_new is F of the previous step; eq. 15: V = V0 det F
                    F_new = F_old
                    vol_new = P.vol0[p] * wp.determinant(F_old)
                if wp.static(volumetric):
                    # eq. 18: F = sqrt(V_cr / V) F keeps rotation and shear, and V becomes V_cr
                    v_cr = P.mass[p] / rho_cr
                    F_new = wp.sqrt(v_cr / vol_new) * F_new
                    vol_new = v_cr
        P.F[p] = F_new
        if wp.static(not derived):
            P.stress[p] = sigma_new
            P.vol[p] = vol_new
        if wp.static(plastic):
            P.szz[p] = szz_new
        if wp.static(rate_form):
            P.strain_energy[p] = energy
        return dissipated, vol_new

    return point_update
