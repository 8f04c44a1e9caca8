# Axial bar: free vibration of an elastic bar, fixed at x = 0 and free at x = L, started with the
# first mode's velocity v(x, 0) = v0 sin(βx), β = π/(2L). Small-strain solution:
# v(x, t) = v0 cos(ωt) sin(βx), ω = β sqrt(E/ρ); centre-of-mass velocity (2 v0/π) cos(ωt).
# Numbers as the common MPM benchmark (e.g. "Motion integration" §4 refs): L = 25 m, E = 100 Pa,
# ρ = 1 kg/m³; v0 = 1e-3 m/s keeps strains ~ v0/c = 1e-4, so the small-strain solution holds
# to well below the discretisation error (at v0 = 0.01 it floors the error at ~2e-4).
"""1D vibration of an elastic bar against its analytic solution (plane strain, ν = 0)."""

import math
import sys

import numpy as np

from mpmdem import LinearElastic, Scene, rectangle
from mpmdem.study.case import CaseSetup
from mpmdem.study.flag_types import count_at_least, given, positive
from mpmdem.study.validation import Check

NAME = "axial-bar"
DESCRIPTION = "1D vibration of an elastic bar vs the analytic first mode (centre-of-mass velocity)"
DEFAULTS = {"shape": "bspline2", "transfer": "APIC", "update": "USL", "precision": "f64"}

VALIDATION = [
    Check("centre_velocity_error_max", 0.0, "analytic first mode: v_cm = (2 v0 / π) cos ωt (MPM notes)", 0.004,
          "the O(h²) spatial error of the discrete mode: 0.7 % of the amplitude at 16 cells gives ≈ 0.18 % at the "
          "default 32 (bench/convergence.py); 2 × that", relative=False, quick_flags=(),
          coarser=(("--cells", "8"), ("--cells", "16"))),
]

LENGTH = 25.0  # m
YOUNGS = 100.0  # Pa
DENSITY = 1.0  # kg/m³
V0 = 1.0e-3  # m/s
BETA = math.pi / (2.0 * LENGTH)
OMEGA = BETA * math.sqrt(YOUNGS / DENSITY)  # rad/s (ν = 0: plane-strain modulus equals E)
PERIOD = 2.0 * math.pi / OMEGA


def exact_centre_velocity(t):
    """Analytic centre-of-mass velocity [m/s] of the first mode."""
    return 2.0 * V0 / math.pi * np.cos(OMEGA * np.asarray(t))


def mode_velocity(x: np.ndarray) -> np.ndarray:
    """Initial velocity field of the first mode."""
    return np.stack([V0 * np.sin(BETA * x[:, 0]), np.zeros(len(x))], 1)


def add_arguments(parser):
    parser.add_argument("--cells", type=count_at_least(2), default=None, help="cells along the bar (default 32)")
    parser.add_argument("--periods", type=positive(), default=None, help="simulated periods (default 1)")


def build(args) -> CaseSetup:
    cells = given(args.cells, 16 if args.quick else 32)
    h = LENGTH / cells
    # bar fills the domain height (one cell): slip walls above and below make the strain uniaxial
    scene = Scene(domain=((0.0, 0.0), (LENGTH + 4 * h, h)), cell_size=h,
                  boundaries={"left": "fixed", "right": "free", "bottom": "slip", "top": "slip"})
    scene.add_mpm_body(rectangle(0.0, 0.0, LENGTH, h), LinearElastic(YOUNGS, 0.0, DENSITY),
                   velocity=mode_velocity, name="bar")
    periods = given(args.periods, 1.0)
    return CaseSetup(scene, end_time=periods * PERIOD, frames=max(1, round(40 * periods)))


def summarize(sim, result, args) -> dict:
    d = result.diagnostics
    v_cm = d["momentum_x"] / d["mass"]
    # The explicit update is a central difference (MPM-SDEM eq. 17-20): the point velocities
    # after a step of length dt are the half-step velocities v^{n+1/2}, i.e. at t − dt/2.
    exact = exact_centre_velocity(result.times - 0.5 * d["dt"])
    amp = 2.0 * V0 / math.pi
    return {
        "cells": round(LENGTH / sim.scene.cell_size),
        "omega_exact": OMEGA,
        "period_exact": PERIOD,
        "centre_velocity_error_max": float(np.abs(v_cm - exact).max() / amp),
        "centre_velocity_error_rms": float(np.sqrt(np.mean((v_cm - exact) ** 2)) / amp),
        "centre_velocity_final": float(v_cm[-1]),
        "centre_velocity_final_exact": float(exact[-1]),
    }


if __name__ == "__main__":
    from mpmdem.study.runner import run_case

    sys.exit(run_case(sys.modules[__name__], prog="python cases/axial_bar.py"))
