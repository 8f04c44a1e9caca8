# Rotating disk: an elastic disk spinning freely in empty space, without gravity.
# Seed: "Motion integration" (Duverger et al.), §4.2 (rotating cube; angular momentum eq. 56,
# the stiffness number C_a = ρ ω² R² / E of eq. 51) and appendix B.2 (rotating disk of 0.6 m
# diameter, cells of 0.0625 m and 0.03125 m). With C_a small the disk turns as a rigid body: its
# angular momentum and angular velocity stay constant. Appendix B.2 finds PIC losing nearly all
# the angular momentum at once and APIC keeping it.
"""Free spinning elastic disk: angular momentum and angular velocity per transfer scheme."""

import math
import sys

import numpy as np

from mpmdem import InputError, NeoHookean, Scene, disk
from mpmdem.io import RunFile
from mpmdem.study.case import CaseSetup
from mpmdem.study.flag_types import count_at_least, given, nonzero
from mpmdem.study.validation import Check

NAME = "rotating-disk"
DESCRIPTION = "elastic disk spinning freely without gravity: angular momentum and velocity per transfer"
DEFAULTS = {"shape": "bspline2", "transfer": "APIC", "update": "USL", "precision": "f64"}

VALIDATION = [
    Check("angular_momentum_final_over_initial", 1.0, "analytic: a free body keeps its angular momentum; APIC's "
          "transfer conserves it exactly ('Motion integration' Table 1)", 0.004,
          "the time step's O((ω dt)²) error, (ω dt)² ≈ 4.4e-7 a step at the default size, summed over its ~9400 steps "
          "with one sign at worst", relative=False, coarser=(("--cells", "16"),)),
]

RADIUS = 0.3  # m (diameter 0.6 m, appendix B.2)
DENSITY = 1000.0  # kg/m³
YOUNGS = 1.0e7  # Pa
POISSON = 0.3
OMEGA = 2.0 * math.pi  # rad/s: one turn per second
SIDE = 1.0  # m, square domain centred on the disk
CENTER = (0.5 * SIDE, 0.5 * SIDE)

# Why these numbers: C_a = ρ ω² R² / E = 3.6e-4 at ω = 2π rad/s, so the centrifugal strain is
# ~1e-4 and the disk is rigid to that order (the seed's cube has C_a ≈ 1e-5); the rim speed
# ω R = 1.9 m/s is 1.6 % of the wave speed c = sqrt((λ+2μ)/ρ) = 116 m/s, so dt = 0.4 h / c is set
# by the material, ~2e-4 s at h = 0.0625 m. The disk's rim stays 0.2 m (3 coarse cells) from the
# free domain edges.


def add_arguments(parser):
    parser.add_argument("--cells", type=count_at_least(8), default=None,
                        help="cells across the 1 m domain (default 32, h = 0.03125 m; 16 with --quick)")
    parser.add_argument("--omega", type=nonzero("rad/s"), default=None,
                        help=f"initial angular velocity [rad/s] (default 2π = {OMEGA:.4f})")


def omega0(args) -> float:
    return given(args.omega, OMEGA)


def build(args) -> CaseSetup:
    cells = given(args.cells, 16 if args.quick else 32)
    if cells < 8:
        raise InputError("cells", cells, "an integer >= 8 (cells across the 1 m domain)")
    omega = omega0(args)
    if not math.isfinite(omega) or omega == 0.0:
        raise InputError("omega", omega, "a finite, non-zero angular velocity [rad/s]")
    scene = Scene(domain=((0.0, 0.0), (SIDE, SIDE)), cell_size=SIDE / cells,
                  boundaries=dict.fromkeys(("left", "right", "bottom", "top"), "free"))
    scene.add_mpm_body(disk(center=CENTER, radius=RADIUS), NeoHookean(YOUNGS, POISSON, DENSITY),
                   angular_velocity=omega, points_per_cell=2, name="disk")
    if args.quick:
        return CaseSetup(scene, end_time=0.5, frames=25)
    return CaseSetup(scene, end_time=1.0, frames=50)


def _inertia(m, x):
    """Polar moment of inertia Σ m |x − x_c|² about the mass centroid [kg m²/m]."""
    xc = (m[:, None] * x).sum(0) / m.sum()
    return float(np.sum(m * np.sum((x - xc) ** 2, axis=1))), xc


def rotation_angles(path) -> np.ndarray:
    """Mean rotation angle of the points about the centroid at each frame [rad], unwrapped.

    θ = atan2(Σ m r0 × r, Σ m r0 · r) with r0, r the points' positions relative to the centroid
    at t = 0 and at the frame: the angle of the best-fitting rigid rotation.
    """
    with RunFile(path) as run:
        m = np.asarray(run.field("mass", 0), dtype=np.float64)
        x0 = np.asarray(run.field("x", 0), dtype=np.float64)
        r0 = x0 - (m[:, None] * x0).sum(0) / m.sum()
        angles = []
        for k in range(run.frame_count):
            x = np.asarray(run.field("x", k), dtype=np.float64)
            r = x - (m[:, None] * x).sum(0) / m.sum()
            cross = np.sum(m * (r0[:, 0] * r[:, 1] - r0[:, 1] * r[:, 0]))
            dot = np.sum(m * np.sum(r0 * r, axis=1))
            angles.append(math.atan2(cross, dot))
    return np.unwrap(np.array(angles))


def summarize(sim, result, args) -> dict:
    d = result.diagnostics
    omega = omega0(args)
    # Angular momentum of the points, Σ m x × v ("Motion integration" eq. 56, the "material
    # point" view: the APIC affine matrices are not counted). The diagnostics take it about the
    # origin; the linear momentum is zero, so it is the same about the centroid.
    L = d["momentum_angular"]
    p0 = sim.model.particles
    i0, _ = _inertia(p0["mass"], p0["x"])
    f = sim.fields()
    i1, _ = _inertia(f["mass"].astype(np.float64), f["x"].astype(np.float64))
    mass = float(d["mass"][0])
    p_lin = np.hypot(d["momentum_x"], d["momentum_y"]).max()
    theta = rotation_angles(result.path) if result.path is not None else [float("nan")]
    return {
        "cells": round(SIDE / sim.scene.cell_size),
        "omega_set": omega,
        "cauchy_number": DENSITY * omega**2 * RADIUS**2 / YOUNGS,
        "angular_momentum_initial": float(L[0]),
        "angular_momentum_final_over_initial": float(L[-1] / L[0]),
        "angular_momentum_min_over_initial": float((L / L[0]).min()),
        "first_frame_time": float(result.times[1]),
        "angular_momentum_first_frame_over_initial": float(L[1] / L[0]),
        "kinetic_energy_final_over_initial": float(d["energy_kinetic"][-1] / d["energy_kinetic"][0]),
        "omega_initial": float(L[0] / i0),
        "omega_final": float(L[-1] / i1),
        "linear_momentum_max_relative": float(p_lin / (mass * abs(omega) * RADIUS)),
        "rotation_angle_final": float(theta[-1]),
        "rotation_angle_rigid": float(omega * result.times[-1]),
    }


if __name__ == "__main__":
    from mpmdem.study.runner import run_case

    sys.exit(run_case(sys.modules[__name__], prog="python cases/rotating_disk.py"))
