"""Mass probes: boxes whose mass (material points, free DEM bodies and grains) is summed on the
device at every output frame."""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import InputError

__all__ = ["MassProbe", "make_mass_probe"]


@dataclass(frozen=True)
class MassProbe:
    """An axis-aligned box [m] whose mass [kg/m] is summed on the device at every output frame
    (Scene.add_mass_probe): diagnostics ``mass_<name>``. It counts the material points inside it
    (``kernels.reductions.make_probe_mass``) and the free DEM bodies and grains whose centroid lies
    inside it (``make_body_probe_mass``), the same test lo ≤ x < hi for both."""

    name: str
    lo: tuple[float, float]
    hi: tuple[float, float]


def make_mass_probe(name: str, lo, hi, taken: list[str]) -> MassProbe:
    """A validated probe: ``name`` an identifier not in ``taken``, lo < hi [m] in x and y (±inf
    allowed: the mass below a line y = y0 is hi = (inf, y0), a silo's discharge)."""
    if not (isinstance(name, str) and name.isidentifier()):
        raise InputError("name", name, "a probe name made of letters, digits and _ (it names mass_<name>)")
    if name in taken:
        raise InputError("name", name, "a probe name not used by another probe")
    try:
        lo = tuple(float(v) for v in lo)
        hi = tuple(float(v) for v in hi)
    except (TypeError, ValueError):
        raise InputError("lo, hi", (lo, hi), "two (x, y) corners [m]") from None
    if len(lo) != 2 or len(hi) != 2 or any(math.isnan(v) for v in lo + hi) or not all(
            a < b for a, b in zip(lo, hi, strict=True)):
        raise InputError("lo, hi", (lo, hi), "two (x, y) corners [m] with lo < hi in x and y (±inf allowed)")
    return MassProbe(name, lo, hi)
