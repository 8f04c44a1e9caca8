# Elastic column settling under its own weight, in uniaxial strain (roller side walls, fixed
# base). Static solution: σ_yy(y) = −ρ g (H − y). Gravity is ramped over a whole number of the
# column's first-mode periods T1 = 4H/c (c = sqrt((λ+2μ)/ρ)); for a linear ramp over n T1 every
# odd mode (ω_k = (2k−1) ω1) ends the ramp at rest, so the column reaches the static state
# without damping.
"""Elastic column under gravity vs the analytic stress profile σ_yy = −ρ g (H − y)."""

import sys

import numpy as np

from mpmdem import LinearElastic, Scene, rectangle
from mpmdem.study.case import CaseSetup
from mpmdem.study.flag_types import count_at_least, given
from mpmdem.study.validation import Check

NAME = "elastic-column"
DESCRIPTION = "elastic column settling under gravity vs sigma_yy = -rho g (H - y)"
DEFAULTS = {"shape": "bspline2", "transfer": "APIC", "update": "USL", "precision": "f64"}

VALIDATION = [
    Check("base_stress", "base_stress_exact", "analytic: σ_yy = −ρ g H at the base", 0.05,
          "the points nearest the base sit a quarter cell above it and the profile is read from them: 1/64 of "
          "ρ g H at 16 cells, with the fixed base's boundary error of the same order: 5 % as in the tests",
          relative=True, coarser=(("--cells", "8"),)),
]

HEIGHT = 1.0  # m
WIDTH = 0.25  # m
YOUNGS = 1.0e6  # Pa
POISSON = 0.3
DENSITY = 1000.0  # kg/m³
GRAVITY = 9.81  # m/s²
RAMP_PERIODS = 4


def material() -> LinearElastic:
    return LinearElastic(YOUNGS, POISSON, DENSITY)


def first_period() -> float:
    """T1 = 4H/c [s], first axial mode of a column fixed at the base and free at the top."""
    return 4.0 * HEIGHT / material().wave_speed


def add_arguments(parser):
    parser.add_argument("--cells", type=count_at_least(2), default=None, help="cells over the height (default 16)")


def build(args) -> CaseSetup:
    cells = given(args.cells, 8 if args.quick else 16)
    h = HEIGHT / cells
    t1 = first_period()
    scene = Scene(domain=((0.0, 0.0), (WIDTH, HEIGHT + 4 * h)), cell_size=h, gravity=(0.0, -GRAVITY),
                  gravity_ramp=RAMP_PERIODS * t1,
                  boundaries={"left": "slip", "right": "slip", "bottom": "fixed", "top": "free"})
    scene.add_mpm_body(rectangle(0.0, 0.0, WIDTH, HEIGHT), material(), name="column")
    return CaseSetup(scene, end_time=(RAMP_PERIODS + 1) * t1, frames=20)


def summarize(sim, result, args) -> dict:
    f = sim.fields()
    y0 = sim.model.particles["x"][:, 1]  # reference heights of the points
    exact = -DENSITY * GRAVITY * (HEIGHT - y0)
    syy = f["stress"][:, 1, 1]
    scale = DENSITY * GRAVITY * HEIGHT
    return {
        "cells": round(HEIGHT / sim.scene.cell_size),
        "stress_error_max": float(np.abs(syy - exact).max() / scale),
        "stress_error_rms": float(np.sqrt(np.mean((syy - exact) ** 2)) / scale),
        "base_stress": float(syy[np.argmin(y0)]),
        "base_stress_exact": float(exact[np.argmin(y0)]),
    }


if __name__ == "__main__":
    from mpmdem.study.runner import run_case

    sys.exit(run_case(sys.modules[__name__], prog="python cases/elastic_column.py"))
