"""Runout and final height of a collapsing granular column against its aspect ratio a: the scaling laws
of Lube, Huppert, Sparks & Freundt (2005, quasi-2D channel), as the two coefficient sets that circulate
under that name (``SCALING``), and the band between them."""

import math

__all__ = ["LUBE_HEIGHT_SPLIT", "LUBE_RUNOUT_LINEAR", "LUBE_RUNOUT_POWER", "LUBE_SETS", "SCALING", "lube_height",
           "lube_runout", "runout_band"]

# Lube et al. (2005), quasi-2D channel: the two circulating coefficient sets (cases/column_collapse.py says why)
LUBE_SETS = {
    "A": {"linear": (1.2, 1.8), "power": (1.9, 2.0 / 3.0, 2.8)},  # (λ1, upper a), (λ2, exponent, lower a)
    "B": {"linear": (1.6, 1.8), "power": (2.2, 2.0 / 3.0, 2.8)},
}
LUBE_RUNOUT_LINEAR = LUBE_SETS["A"]["linear"]  # (prefactor, upper end of the linear regime in a)
LUBE_RUNOUT_POWER = LUBE_SETS["A"]["power"]  # (prefactor, exponent, lower end of the power regime)
LUBE_HEIGHT_SPLIT = 1.15  # H_f/L0 = a below, a^(2/5) above
SCALING = ("Lube, Huppert, Sparks & Freundt 2005, Phys. Rev. E 72, 041301 (quasi-2D channel), as the two "
           "coefficient sets that circulate under its name (the paper was not read here): (L_f-L0)/L0 = 1.2-1.6 a "
           "for a <= 1.8, 1.9-2.2 a^(2/3) for a >= 2.8 (log-log interpolation between); H_f/L0 = a for a <= 1.15, "
           "a^(2/5) above")


def lube_runout(a: float, coefficients: str = "A") -> float:
    """Normalized runout (L_f − L0)/L0 at aspect ratio a of one coefficient set circulating under Lube
    et al. (2005)'s name ("A": 1.2 a / 1.9 a^(2/3), "B": 1.6 a / 2.2 a^(2/3); see ``SCALING``)."""
    k1, a1 = LUBE_SETS[coefficients]["linear"]
    k2, n, a2 = LUBE_SETS[coefficients]["power"]
    if a <= a1:
        return k1 * a
    if a >= a2:
        return k2 * a**n
    s = math.log(a / a1) / math.log(a2 / a1)  # transition: straight line in log-log
    return math.exp((1.0 - s) * math.log(k1 * a1) + s * math.log(k2 * a2**n))


def runout_band(a: float) -> tuple[float, float]:
    """The reference band of the normalized runout at aspect ratio a: the lowest and highest of the
    coefficient sets (the spread between them, not the experiments' scatter; see ``SCALING``)."""
    values = [lube_runout(a, k) for k in LUBE_SETS]
    return min(values), max(values)


def lube_height(a: float) -> float:
    """Normalized final height H_f/L0 of Lube et al. (2005) at aspect ratio a."""
    return a if a <= LUBE_HEIGHT_SPLIT else a**0.4
