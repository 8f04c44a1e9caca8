# Granular flow down a slope: "Granular MPM" §2.3, Fig. 1-2, Table 1.
# A block of granular material on a 30° slope (gravity turned by the inclination, the slope is the
# floor), fixed walls. The paper shows that the mean density of the points falls steadily in
# original MPM and in stress-free MPM, while the packing of a moderate flow should stay about
# constant; Granular MPM keeps it at the critical density (eq. 13-15).
"""Slope flow (Granular MPM §2.3): does the mean density of a flowing block stay put?"""

import math
import sys

import numpy as np

from mpmdem import MohrCoulomb, Scene, rectangle
from mpmdem.cases._variants import GRANULAR_VARIANTS, critical_density, plot_variants, read_run
from mpmdem.study.case import CaseSetup

NAME = "slope-flow"
DESCRIPTION = "a granular block flows down a 30° slope: mean density in original, stress-free and Granular MPM"
DEFAULTS = {"precision": "f64", "shape": "linear", "transfer": "FLIP", "update": "MUSL", "granular": True,
            "dt": 7.0e-6}

# Table 1 (SI)
H = 0.010  # m, grid spacing
DT = 7.0e-6  # s
T_TOTAL = 0.25  # s
INCLINATION = 30.0  # deg
E, NU, PHI, PSI = 1.0e9, 0.3, 30.0, 0.0  # Pa, -, deg, deg
RHO0, RHO_CR = 2250.0, 2235.0  # kg/m³
# 120 points at 4 per cell: a block of 10 × 3 cells. Its place on the slope is not given; it
# starts 5 cells from the upper wall of a 60 cells long, 10 cells high stretch of slope.
BLOCK = (0.05, 0.0, 0.15, 0.03)  # m
DOMAIN = ((0.0, 0.0), (0.60, 0.10))  # m


def _scene(critical: bool) -> Scene:
    th = math.radians(INCLINATION)
    scene = Scene(domain=DOMAIN, cell_size=H, gravity=(9.81 * math.sin(th), -9.81 * math.cos(th)),
                  boundaries={s: "fixed" for s in ("left", "right", "bottom", "top")})
    mat = MohrCoulomb(E, NU, RHO0, PHI, PSI, critical_density=RHO_CR if critical else None)
    scene.add_mpm_body(rectangle(*BLOCK), mat, points_per_cell=2, name="granular")
    return scene


#: original, stress-free and Granular MPM, each a run of its own (mpmdem.study.variants), compared by ``compare``
VARIANTS = GRANULAR_VARIANTS


def build(args) -> CaseSetup:
    return CaseSetup(_scene(critical_density(args)), end_time=0.05 if args.quick else T_TOTAL,
                     frames=10 if args.quick else 25)


def summarize(sim, result, args) -> dict:
    return {"inclination_deg": INCLINATION, "points": int(sim.particle_count), "end_time_s": float(result.times[-1])}


def compare(main, runs, args) -> dict:
    """The three variants (``VARIANTS``, each a run of its own): density, front and speed at the end."""
    runs = {name: read_run(run.path) for name, run in runs.items()}
    out = {}
    for name, r in runs.items():
        out[name] = {
            "status": r["status"],
            "mean_density_start": float(r["mean_density"][0]),
            "mean_density_end": float(r["mean_density"][-1]),
            "mean_density_min": float(r["mean_density"].min()),
            "front_x_end_m": float(np.nanmax(r["x"][:, 0])),
            "max_speed_end": float(np.nanmax(r["speed"])),
        }
    if main.path is not None:
        plot_variants(runs, main.path.parent / "slope_flow.png", title="slope flow, Granular MPM Table 1")
    return out


if __name__ == "__main__":
    from mpmdem.study.runner import run_case

    sys.exit(run_case(sys.modules[__name__], prog="python cases/slope_flow.py"))
