# Disk collision: two rigid disks meet head-on, and two more obliquely with friction.
# Seed: "MPM-SDEM" §3 (eq. 38-43): a disk is a spheropolygon of one vertex, so disk-disk contact
# reduces to vertex-vertex; the linear spring-dashpot has closed-form duration and restitution.
"""Two pairs of DEM disks collide (head-on and oblique): restitution, contact time, momenta."""

import math
import sys

import numpy as np

from mpmdem import ContactLaw, Scene, sphero_disk
from mpmdem.study.case import CaseSetup
from mpmdem.study.flag_types import interval, non_negative
from mpmdem.study.validation import Check

NAME = "disk-collision"
DESCRIPTION = "rigid disks collide head-on and obliquely (spring-dashpot DEM vs its closed form)"
# eq. 51 with the paper's κ2 = 0.1 resolves a contact in ~4 steps; this case measures the contact
# itself, so it takes 50 times smaller steps (still inside the stable bound)
DEFAULTS = {"precision": "f64", "dem_kappa": 0.002}

VALIDATION = [
    Check("restitution_head_on", "restitution_set", "analytic: the spring-dashpot law's e (MPM-SDEM eq. 38-40)",
          0.005, "the leapfrog's O((ω dt)²) error with ~70 steps a contact (κ2 = 0.002): ~1e-3; 5 × that",
          coarser=(("--dem-kappa", "0.02"),)),
]

RADIUS = 0.05  # m
DENSITY = 2500.0  # kg/m³
STIFFNESS = 1.0e6  # N/m per m
SPEED = 1.0  # m/s, each disk towards the other
OFFSET = 0.05  # m, impact parameter of the oblique pair (= one radius)


def add_arguments(parser):
    parser.add_argument("--restitution", type=interval(0.0, 1.0), default=0.7,
                        help="coefficient of restitution e in [0, 1]")
    parser.add_argument("--friction", type=non_negative(), default=0.3, help="Coulomb μ of the oblique pair")


def _law(args) -> ContactLaw:
    return ContactLaw(STIFFNESS, restitution=args.restitution)


def contact_time(args) -> float:
    """π / ω_d of the linear spring-dashpot with m_eff = m/2 [s]."""
    m = DENSITY * math.pi * RADIUS**2
    zeta = _law(args).damping_ratio
    return math.pi / (math.sqrt(STIFFNESS / (0.5 * m)) * math.sqrt(1.0 - zeta**2))


def build(args) -> CaseSetup:
    scene = Scene(domain=((-1.0, -1.0), (1.0, 1.0)), contact=_law(args))
    gap = 0.02  # m between the surfaces at t = 0: contact starts at gap / (2 v)
    x0 = RADIUS + 0.5 * gap
    disk = sphero_disk(RADIUS)
    for name, y, dy, mu in (("head_on", 0.5, 0.0, 0.0), ("oblique", -0.5, OFFSET, args.friction)):
        scene.add_rigid_body(disk, density=DENSITY, position=(-x0, y - 0.5 * dy), velocity=(SPEED, 0.0),
                             friction=mu, name=f"{name}_left")
        scene.add_rigid_body(disk, density=DENSITY, position=(x0, y + 0.5 * dy), velocity=(-SPEED, 0.0),
                             friction=mu, name=f"{name}_right")
    end = gap / (2 * SPEED) + 3.0 * contact_time(args)
    return CaseSetup(scene, end_time=end, frames=100 if args.quick else 400)


def summarize(sim, result, args) -> dict:
    f = sim.body_fields()
    v, w = f["v"], f["omega"]
    d = result.diagnostics
    m = DENSITY * math.pi * RADIUS**2
    # oblique pair: normal velocity ratio along the final line of centres (the contact normal
    # turns while the disks roll on each other, so this is not e itself)
    n = f["x"][3] - f["x"][2]
    n /= np.linalg.norm(n)
    approach = np.dot(np.array([-2 * SPEED, 0.0]), n)  # relative normal velocity before, right − left
    separate = np.dot(v[3] - v[2], n)
    p_scale = 2 * m * SPEED
    return {
        "contact_time_analytic": contact_time(args),
        "restitution_set": args.restitution,
        "restitution_head_on": float((v[1, 0] - v[0, 0]) / (2 * SPEED)),
        "oblique_normal_velocity_ratio": float(-separate / approach),
        "oblique_spin": [float(w[2]), float(w[3])],
        "momentum_drift_relative": float(max(np.abs(d[k] - d[k][0]).max() for k in ("momentum_x", "momentum_y"))
                                         / p_scale),
        "angular_momentum_drift_relative": float(np.abs(d["momentum_angular"] - d["momentum_angular"][0]).max()
                                                 / (p_scale * RADIUS)),
        "energy_final_over_initial": float(d["energy_total"][-1] / d["energy_total"][0]),
        "work_friction": float(d["work_contact_friction"][-1]),
        "energy_balance_residual": float(d["work_numerical"][-1] / d["energy_total"][0]),
    }


if __name__ == "__main__":
    from mpmdem.study.runner import run_case

    sys.exit(run_case(sys.modules[__name__], prog="python cases/disk_collision.py"))
