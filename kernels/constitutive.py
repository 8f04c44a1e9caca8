"""Stress updates of the material models, as ``@wp.func`` laws shared by every G2P variant.

Plane strain: 2×2 in-plane tensors, zero out-of-plane strain. Material parameters per material
are packed as vec4 (μ, λ, ρ0, kind) with kind = 0 linear elastic, 1 Neo-Hookean.
"""


import functools

import warp as wp

from .types import scalar_types

__all__ = ["LINEAR_ELASTIC", "NEO_HOOKEAN", "make_strain_energy_density", "make_stress_update"]

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
