# Sulsky disks: two elastic disks fly at each other, collide and bounce apart.
# Seed: "MPM notes", "A first simulation" (after Sulsky, Chen & Schreyer 1995, §7.3):
# ρ = 1000 kg/m³, E = 1000 Pa, ν = 0.3, velocities ±(0.1, 0.1) m/s, disks of diameter ~0.4 m.
"""Two Neo-Hookean disks colliding in free space; checks momentum and energy per transfer."""

import sys

import numpy as np

from mpmdem import NeoHookean, Scene, disk
from mpmdem.study.case import CaseSetup
from mpmdem.study.flag_types import count_at_least, given

NAME = "sulsky-disks"
DESCRIPTION = "two elastic disks collide and rebound (MPM notes / Sulsky 1995)"
DEFAULTS = {"shape": "bspline2", "transfer": "APIC", "update": "USL"}

DENSITY = 1000.0  # kg/m³
YOUNGS = 1000.0  # Pa
POISSON = 0.3
SPEED = 0.1  # m/s, each component
RADIUS = 0.2  # m


def add_arguments(parser):
    parser.add_argument("--cells", type=count_at_least(2), default=None,
                        help="cells across the unit square (default 20)")


def build(args) -> CaseSetup:
    cells = given(args.cells, 16 if args.quick else 20)
    # The disks come within 1.5 cells of the walls, where a wall would act on them through the
    # grid; the notes' problem has no boundary condition, so all sides are free.
    scene = Scene(domain=((0.0, 0.0), (1.0, 1.0)), cell_size=1.0 / cells,
                  boundaries=dict.fromkeys(("left", "right", "bottom", "top"), "free"))
    mat = NeoHookean(YOUNGS, POISSON, DENSITY)
    scene.add_mpm_body(disk(center=(0.25, 0.25), radius=RADIUS), mat, velocity=(SPEED, SPEED), name="lower")
    scene.add_mpm_body(disk(center=(0.75, 0.75), radius=RADIUS), mat, velocity=(-SPEED, -SPEED), name="upper")
    return CaseSetup(scene, end_time=2.5 if args.quick else 3.5, frames=25 if args.quick else 70)


def summarize(sim, result, args) -> dict:
    d = result.diagnostics
    f = sim.fields()
    m, v, x, body = f["mass"], f["v"], f["x"], f["body"]
    p_scale = float(np.sum(m * np.linalg.norm(v, axis=1)).clip(min=1e-300))
    p_scale = max(p_scale, float(d["mass"][0]) * SPEED * np.sqrt(2.0))
    drift = np.hypot(d["momentum_x"] - d["momentum_x"][0], d["momentum_y"] - d["momentum_y"][0])
    e0 = d["energy_total"][0]
    lower = body == 0
    v_lower = (m[lower, None] * v[lower]).sum(0) / m[lower].sum()
    x_lower = (m[lower, None] * x[lower]).sum(0) / m[lower].sum()
    x_upper = (m[~lower, None] * x[~lower]).sum(0) / m[~lower].sum()
    return {
        "momentum_drift_relative": float(drift.max() / p_scale),
        "kinetic_energy_final_over_initial": float(d["energy_kinetic"][-1] / d["energy_kinetic"][0]),
        "total_energy_final_over_initial": float(d["energy_total"][-1] / e0),
        "total_energy_min_over_initial": float(d["energy_total"].min() / e0),
        "strain_energy_peak_over_initial": float(d["energy_strain"].max() / e0),
        "lower_disk_velocity_final": v_lower.tolist(),
        "centre_distance_final": float(np.linalg.norm(x_upper - x_lower)),
        "rebounded": bool(v_lower[0] < 0.0 and v_lower[1] < 0.0),
    }


if __name__ == "__main__":
    from mpmdem.study.runner import run_case

    sys.exit(run_case(sys.modules[__name__], prog="python cases/sulsky_disks.py"))
