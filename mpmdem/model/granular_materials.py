"""Elastoplastic granular materials: frozen dataclasses validated on construction (SI units, angles in degrees).

Both models are plane strain and tension positive, like ``materials.py``. Their return mappings live
in ``mpmdem.kernels.plasticity``; ``packed()`` gives the parameter vector those kernels read.

Sources: "Granular MPM" (Seyedan & Sołowski 2021) eq. 13–17; "MPM-SDEM" §2.3 eq. 31–36.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

from ..checks import finite
from ..errors import InputError
from ..kernels.plasticity import DRUCKER_PRAGER, MOHR_COULOMB, MU_I
from .materials import Material

__all__ = ["GRANULAR_MATERIAL_KINDS", "DruckerPrager", "MohrCoulomb", "MuI"]

#: DP matchings: "plane_strain" is MPM-SDEM eq. 35 (with ψ for α_ψ); "plane_strain_nonassociated"
#: makes the plane-strain failure equal Mohr–Coulomb's for the given ψ too (see DruckerPrager).
DP_MATCHES = ("plane_strain", "plane_strain_nonassociated")


@dataclass(frozen=True)
class _Granular(Material):
    """Friction, dilatancy, cohesion and critical density, shared by both models.

    Attributes (after the elastic ones of ``Material``):
        friction_angle: φ [deg], 0 < φ < 90.
        dilatancy_angle: ψ [deg], 0 ≤ ψ ≤ φ.
        cohesion: c [Pa], ≥ 0.
        critical_density: ρ_cr [kg/m³] (keyword only; see ``Material``).
    """

    friction_angle: float
    dilatancy_angle: float = 0.0
    cohesion: float = 0.0

    def _check_granular(self) -> None:
        phi = finite("friction_angle", self.friction_angle)
        if not 0.0 < phi < 90.0:
            raise InputError("friction_angle", phi, "0 < phi < 90 [deg]")
        psi = finite("dilatancy_angle", self.dilatancy_angle)
        if not 0.0 <= psi <= phi:
            raise InputError("dilatancy_angle", psi, f"0 <= psi <= friction_angle = {phi} [deg]")
        if not finite("cohesion", self.cohesion) >= 0.0:
            raise InputError("cohesion", self.cohesion, "c >= 0 [Pa]")

    @property
    def sin_phi(self) -> float:
        """sin φ [-]."""
        return math.sin(math.radians(self.friction_angle))

    @property
    def sin_psi(self) -> float:
        """sin ψ [-]."""
        return math.sin(math.radians(self.dilatancy_angle))

    def _common(self) -> tuple[tuple[float, ...], float]:
        """(μ, λ, ρ0, kind) and ρ_cr (0 when None), the slots every packed vector shares."""
        base = Material.packed(self)
        return base[:4], base[9]


@dataclass(frozen=True)
class MohrCoulomb(_Granular):
    """Non-associated Mohr–Coulomb with the Bagnold rate term ("Granular MPM" eq. 16–17).

    Yield (compression positive in the paper) F = (σ1 − σ3) − (σ1 + σ3) sin φ − 2 (c + η γ̇²) cos φ,
    potential G = (σ1 − σ3) − (σ1 + σ3) sin ψ. The paper's eq. 16 has no cohesion; c is added as the
    usual constant next to the rate term, which it equals in form.

    Attributes (after those of ``_Granular``):
        bagnold: η [Pa s²] ≥ 0, the coefficient of the rate term η γ̇² (γ̇ [1/s] the shear rate). The
            paper's η already lumps the grain density and size of Bagnold's law, so no grain
            diameter is needed.
    """

    bagnold: float = 0.0
    kind_id: ClassVar[int] = MOHR_COULOMB

    def __post_init__(self):
        super().__post_init__()
        self._check_granular()
        if not finite("bagnold", self.bagnold) >= 0.0:
            raise InputError("bagnold", self.bagnold, "eta >= 0 [Pa s^2]")

    @property
    def apex_mean_stress(self) -> float:
        """Mean stress of the cone apex at rest, c cot φ [Pa] (tension positive)."""
        return self.cohesion / math.tan(math.radians(self.friction_angle))

    def packed(self) -> tuple[float, ...]:
        """Parameters for ``kernels.plasticity`` (``PARAM_LEN`` floats, SI):

        (μ, λ, ρ0, kind=2, sin φ, cos φ, sin ψ, c, η, ρ_cr or 0).
        """
        common, rho_cr = self._common()
        phi = math.radians(self.friction_angle)
        return (*common, math.sin(phi), math.cos(phi), self.sin_psi, float(self.cohesion), float(self.bagnold), rho_cr)


def _dp_alpha(angle_deg: float) -> float:
    """tan a / sqrt(9 + 12 tan² a) [-]: α of the I1 form (q = 3α of MPM-SDEM eq. 35)."""
    ta = math.tan(math.radians(angle_deg))
    return ta / math.sqrt(9.0 + 12.0 * ta * ta)


@dataclass(frozen=True)
class DruckerPrager(_Granular):
    """Drucker–Prager with dilatancy and a tension cut-off ("MPM-SDEM" eq. 31–36).

    f_s = sqrt(J2) + α_φ I1 − k_c (eq. 31 with q_φ = 3 α_φ, k_φ = k_c), f_t = σ_m − σ_t (eq. 32),
    potential g = sqrt(J2) + α_ψ I1.

    Attributes (after those of ``_Granular``):
        tension_cutoff: σ_t [Pa], 0 ≤ σ_t ≤ apex mean stress k_c / (3 α_φ); None → the apex.
        match: how (α_φ, k_c) follow from (φ, c):
            "plane_strain": eq. 35 of MPM-SDEM, α_φ = tan φ / sqrt(9 + 12 tan² φ),
                k_c = 3 c / sqrt(9 + 12 tan² φ). Plane-strain failure equals Mohr–Coulomb's exactly
                for associated flow (ψ = φ) only.
            "plane_strain_nonassociated": α_φ, k_c solved from the plane-strain limit state
                (Δε^p_zz = 0) for the given ψ, so the failure equals Mohr–Coulomb's for any ψ
                (α_φ = sin φ / 3, k_c = c cos φ at ψ = 0).
            α_ψ = tan ψ / sqrt(9 + 12 tan² ψ) in both (eq. 35 with ψ for φ).
    """

    tension_cutoff: float | None = None
    match: str = "plane_strain"
    kind_id: ClassVar[int] = DRUCKER_PRAGER

    def __post_init__(self):
        super().__post_init__()
        self._check_granular()
        if self.match not in DP_MATCHES:
            raise InputError("match", self.match, f"one of {DP_MATCHES}")
        if self.tension_cutoff is not None:
            st = finite("tension_cutoff", self.tension_cutoff)
            apex = self.apex_mean_stress
            if not 0.0 <= st <= apex * (1.0 + 1e-12):
                raise InputError(
                    "tension_cutoff",
                    st,
                    f"0 <= sigma_t <= apex mean stress k_c/(3 alpha_phi) = {apex!r} [Pa] or None (the apex); "
                    "above the apex the cut-off never acts, below 0 the stress-free state is not admissible",
                )

    @property
    def alpha_psi(self) -> float:
        """α_ψ [-], the dilatancy coefficient of the potential's I1 term."""
        return _dp_alpha(self.dilatancy_angle)

    @property
    def alpha_phi(self) -> float:
        """α_φ [-], the friction coefficient of the I1 term of f_s."""
        if self.match == "plane_strain":
            return _dp_alpha(self.friction_angle)
        b = self.alpha_psi
        return self.sin_phi / (3.0 * (math.sqrt(1.0 - 3.0 * b * b) + b * self.sin_phi))

    @property
    def k_c(self) -> float:
        """k_c [Pa], the cohesion term of f_s (k_φ of MPM-SDEM eq. 35)."""
        ta = math.tan(math.radians(self.friction_angle))
        if self.match == "plane_strain":
            return 3.0 * self.cohesion / math.sqrt(9.0 + 12.0 * ta * ta)
        a, b = self.alpha_phi, self.alpha_psi
        return self.cohesion * math.cos(math.radians(self.friction_angle)) * (1.0 - 3.0 * a * b) / math.sqrt(
            1.0 - 3.0 * b * b
        )

    @property
    def q_phi(self) -> float:
        """q_φ = 3 α_φ [-] (MPM-SDEM eq. 31, 35: the coefficient of σ_m)."""
        return 3.0 * self.alpha_phi

    @property
    def q_psi(self) -> float:
        """q_ψ = 3 α_ψ [-], its dilatancy counterpart."""
        return 3.0 * self.alpha_psi

    @property
    def apex_mean_stress(self) -> float:
        """Mean stress of the cone apex, k_c / q_φ [Pa]."""
        return self.k_c / self.q_phi

    @property
    def tension_strength(self) -> float:
        """The cut-off σ_t in use [Pa]: ``tension_cutoff``, or the apex when None."""
        return self.apex_mean_stress if self.tension_cutoff is None else min(self.tension_cutoff, self.apex_mean_stress)

    @property
    def plane_strain_friction_angle(self) -> float:
        """The Mohr–Coulomb φ [deg] of this model's plane-strain failure, given its α_φ and α_ψ.

        At the plane-strain limit state Δε^p_zz = 0 fixes σ_zz, and the in-plane Mohr circle obeys
        (σ1 − σ3)/2 = −(σ1 + σ3)/2 sin φ_ps + c_ps cos φ_ps with
        sin φ_ps = 3 α_φ sqrt(1 − 3 α_ψ²) / (1 − 3 α_φ α_ψ).
        """
        a, b = self.alpha_phi, self.alpha_psi
        return math.degrees(math.asin(3.0 * a * math.sqrt(1.0 - 3.0 * b * b) / (1.0 - 3.0 * a * b)))

    def packed(self) -> tuple[float, ...]:
        """Parameters for ``kernels.plasticity`` (``PARAM_LEN`` floats, SI):

        (μ, λ, ρ0, kind=3, α_φ, k_c, α_ψ, σ_t, 0, ρ_cr or 0).
        """
        common, rho_cr = self._common()
        return (*common, self.alpha_phi, self.k_c, self.alpha_psi, self.tension_strength, 0.0, rho_cr)


@dataclass(frozen=True)
class MuI(Material):
    """The μ(I) rheology of dense granular flow as an elasto-viscoplastic material (``kernels.mu_i``).

    μ(I) = μs + (μ2 − μs) / (I0 / I + 1) with I = γ̇ᵖ d / sqrt(p / ρs) (Jop, Forterre & Pouliquen
    2006, eq. 1–2; return mapping of Dunatunga & Kamrin 2015 §3). Below μs p the point is
    elastic; at p ≤ 0 it is stress-free. Unlike Drucker–Prager it carries a length, the grain
    diameter d, through I: a slow flow runs at μ ≈ μs and a fast one towards μ2.

    Attributes (after the elastic ones of ``Material``; ``density`` is the bulk density ρ0):
        mu_s: μs [-] > 0, the friction coefficient of the static limit (I → 0).
        mu_2: μ2 [-] > μs, the limit at large I.
        i0: I0 [-] > 0, the inertial number at which μ is halfway between μs and μ2.
        grain_diameter: d [m] > 0.
        grain_density: ρs [kg/m³] ≥ density (the grains are at least as dense as their packing).
        dilatancy_angle: ψ [deg], 0 ≤ ψ < 90: plastic shear dilates by q_ψ = 3 tan ψ / sqrt(9 + 12
            tan² ψ) per unit plastic shear (the Drucker–Prager α_ψ of MPM-SDEM eq. 35); 0 (the
            default, as in Dunatunga & Kamrin 2015) keeps plastic flow isochoric.

    Well-posedness: the incompressible μ(I) equations are ill-posed at low and at high I (Barker
    et al. 2015). This model adds no regulariser: it is compressible and elastic (finite G and K),
    and the grid spacing bounds the shortest wave. ``tests/sim/test_mu_i_grid.py`` runs a slow,
    low-I flow and checks that no grid-scale noise grows (docs/concepts/mu-i.md).
    """

    mu_s: float
    mu_2: float
    i0: float
    grain_diameter: float
    grain_density: float
    dilatancy_angle: float = 0.0
    kind_id: ClassVar[int] = MU_I

    def __post_init__(self):
        super().__post_init__()
        mus = finite("mu_s", self.mu_s)
        if not mus > 0.0:
            raise InputError("mu_s", self.mu_s, "mu_s > 0")
        if not finite("mu_2", self.mu_2) > mus:
            raise InputError("mu_2", self.mu_2, f"mu_2 > mu_s = {mus}")
        if not finite("i0", self.i0) > 0.0:
            raise InputError("i0", self.i0, "I0 > 0")
        if not finite("grain_diameter", self.grain_diameter) > 0.0:
            raise InputError("grain_diameter", self.grain_diameter, "d > 0 [m]")
        if not finite("grain_density", self.grain_density) >= self.density:
            raise InputError("grain_density", self.grain_density,
                             f"rho_s >= the bulk density = {self.density} [kg/m^3]")
        if not 0.0 <= finite("dilatancy_angle", self.dilatancy_angle) < 90.0:
            raise InputError("dilatancy_angle", self.dilatancy_angle, "0 <= psi < 90 [deg]")

    @classmethod
    def glass_beads(cls, youngs_modulus: float = 1.0e7, poisson_ratio: float = 0.3, solid_fraction: float = 0.6,
                    **kwargs) -> MuI:
        """Jop, Forterre & Pouliquen's glass beads (2006, and their 2005 incline fit): μs = tan 20.9°,
        μ2 = tan 32.76°, I0 = 0.279, d = 0.5 mm, ρs = 2450 kg/m³ (as quoted from the paper; not re-read
        from the primary source here); bulk density ρs × solid_fraction.

        E and ν are not part of the rheology: they only set the elastic predictor (keep E large
        enough that the elastic strain ρ g H / E stays small in the scene).
        """
        rho_s = 2450.0
        return cls(youngs_modulus, poisson_ratio, rho_s * solid_fraction, mu_s=math.tan(math.radians(20.9)),
                   mu_2=math.tan(math.radians(32.76)), i0=0.279, grain_diameter=0.5e-3, grain_density=rho_s,
                   **kwargs)

    def friction(self, inertial_number):
        """μ(I) [-] for an inertial number I ≥ 0 (scalar or array; Jop et al. 2006 eq. 2)."""
        import numpy as np  # noqa: PLC0415

        i = np.asarray(inertial_number, dtype=float)
        return self.mu_s + (self.mu_2 - self.mu_s) * i / (self.i0 + i)

    def inertial_number(self, shear_rate, pressure):
        """I = γ̇ d / sqrt(p / ρs) [-] for a shear rate γ̇ [1/s] and pressure p [Pa] > 0."""
        import numpy as np  # noqa: PLC0415

        return np.asarray(shear_rate, dtype=float) * self.grain_diameter / np.sqrt(
            np.asarray(pressure, dtype=float) / self.grain_density)

    @property
    def q_psi(self) -> float:
        """q_ψ = 3 α_ψ [-], the plastic dilation per unit plastic shear."""
        return 3.0 * _dp_alpha(self.dilatancy_angle)

    def packed(self) -> tuple[float, ...]:
        """Parameters for ``kernels.mu_i`` (``PARAM_LEN`` floats, SI):

        (μ_G, λ, ρ0, kind=4, μs, μ2, I0, d sqrt(ρs), q_ψ, ρ_cr or 0).
        """
        base = Material.packed(self)
        return (*base[:4], float(self.mu_s), float(self.mu_2), float(self.i0),
                self.grain_diameter * math.sqrt(self.grain_density), self.q_psi, base[9])


GRANULAR_MATERIAL_KINDS = {MOHR_COULOMB: "MohrCoulomb", DRUCKER_PRAGER: "DruckerPrager", MU_I: "MuI"}
