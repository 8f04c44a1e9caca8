"""Material models of MPM bodies: frozen dataclasses validated on construction (SI units).

Plane strain throughout: the out-of-plane strain is zero, so λ and μ are the 3D Lamé constants.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import ClassVar

from ..checks import finite
from ..errors import InputError

__all__ = ["LinearElastic", "Material", "NeoHookean"]


@dataclass(frozen=True)
class Material:
    """Common part of isotropic elastic materials.

    Attributes:
        youngs_modulus: E [Pa], > 0.
        poisson_ratio: ν, in (−1, 0.5).
        density: initial mass density ρ0 [kg/m³], > 0.
        critical_density: ρ_cr [kg/m³] (keyword only), 0 < ρ_cr ≤ density, or None (default: the
            material is a continuum that is never stress-free). Below it a point is stress-free
            ("Granular MPM" eq. 13) and, in granular mode, its domain of interaction is its domain
            scaled to the critical volume m/ρ_cr (§3.3).
    """

    youngs_modulus: float
    poisson_ratio: float
    density: float
    critical_density: float | None = field(default=None, kw_only=True)
    kind_id: ClassVar[int] = -1

    def __post_init__(self):
        for name in ("youngs_modulus", "poisson_ratio", "density"):
            finite(name, getattr(self, name))
        if not self.youngs_modulus > 0.0:
            raise InputError("youngs_modulus", self.youngs_modulus, "E > 0 [Pa]")
        if not -1.0 < self.poisson_ratio < 0.5:
            raise InputError("poisson_ratio", self.poisson_ratio, "-1 < nu < 0.5")
        if not self.density > 0.0:
            raise InputError("density", self.density, "rho > 0 [kg/m^3]")
        rho_cr = self.critical_density
        if rho_cr is not None:
            finite("critical_density", rho_cr, "a finite number [kg/m^3] or None")
            if not 0.0 < rho_cr <= self.density:
                raise InputError(
                    "critical_density", rho_cr,
                    f"0 < rho_cr <= density = {self.density} [kg/m^3] or None; a critical density above the "
                    "initial density makes no sense: the material would start below it, i.e. stress-free "
                    "(Granular MPM eq. 13)",
                )

    @property
    def granular(self) -> bool:
        """Whether the material has a critical density (stress-free below it, can disconnect)."""
        return self.critical_density is not None

    @property
    def shear_modulus(self) -> float:
        """μ = E / (2(1+ν)) [Pa]."""
        return self.youngs_modulus / (2.0 * (1.0 + self.poisson_ratio))

    @property
    def lame_lambda(self) -> float:
        """λ = Eν / ((1+ν)(1−2ν)) [Pa]."""
        e, nu = self.youngs_modulus, self.poisson_ratio
        return e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))

    @property
    def p_wave_modulus(self) -> float:
        """λ + 2μ [Pa], the plane-strain constrained modulus that sets the wave speed."""
        return self.lame_lambda + 2.0 * self.shear_modulus

    @property
    def wave_speed(self) -> float:
        """Dilatational wave speed c = sqrt((λ+2μ)/ρ0) [m/s], used by the CFL bound."""
        return math.sqrt(self.p_wave_modulus / self.density)

    def packed(self) -> tuple[float, ...]:
        """The ``PARAM_LEN`` floats the kernels read (``mpmdem.kernels.plasticity`` layout):
        (μ, λ, ρ0, kind, model slots 4–8, ρ_cr or 0)."""
        return (self.shear_modulus, self.lame_lambda, float(self.density), float(self.kind_id),
                0.0, 0.0, 0.0, 0.0, 0.0, float(self.critical_density or 0.0))

    def to_dict(self) -> dict:
        """JSON-serialisable description."""
        return {"model": type(self).__name__, **asdict(self)}


@dataclass(frozen=True)
class LinearElastic(Material):
    """Hypoelastic Hooke's law in rate form with the Jaumann stress rate (MPM-SDEM eq. 25)."""

    kind_id: ClassVar[int] = 0


@dataclass(frozen=True)
class NeoHookean(Material):
    """Compressible Neo-Hookean solid, σ = μ/J (F Fᵀ − I) + λ ln J / J I ("MPM notes", step 8)."""

    kind_id: ClassVar[int] = 1


MATERIAL_KINDS = {0: "LinearElastic", 1: "NeoHookean"}
