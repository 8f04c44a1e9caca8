# Granular avalanche over two inclines: "Granular MPM" §4.2, Figs. 9-12, Table 3.
# Granular material released with 1 m/s on an upper plane flows over its edge onto a lower plane
# and stops against the end wall. As in the paper the inclination is put into gravity (15°), so
# both planes are horizontal in the model; the upper plane is a ledge of grid nodes
# (Scene.add_obstacle), the lower plane the domain floor, the end and the other walls fixed. The
# planes are rollers (slip) by default: with φ = 30° > 15° a no-slip or Coulomb base would stop the
# mass on the upper plane (our first runs with fixed planes did: 7 % of it reached the lower
# plane), whereas the paper's mass slides down, falls and reaches the end wall by t = 1.2 s;
# `--planes fixed` keeps the no-slip variant.
"""Avalanche over two inclines (Granular MPM §4.2): deposits of original, stress-free and Granular MPM."""

import math
import sys

import numpy as np

from mpmdem import MohrCoulomb, Scene, rectangle
from mpmdem.cases._variants import GRANULAR_VARIANTS, critical_density, plot_variants, read_run
from mpmdem.study.case import CaseSetup

NAME = "avalanche"
DESCRIPTION = "granular avalanche over two inclines (15°): original, stress-free and Granular MPM deposits"
DEFAULTS = {"precision": "f64", "shape": "linear", "transfer": "FLIP", "update": "MUSL", "granular": True,
            "dt": 1.0e-5}

# Table 3 (SI)
H = 0.100  # m, grid spacing
DT = 1.0e-5  # s
INCLINATION = 15.0  # deg
E, NU, PHI, PSI, ETA = 1.0e9, 0.3, 30.0, 0.0, 0.15  # Pa, -, deg, deg, Pa s²
RHO0, RHO_CR = 2250.0, 2235.0  # kg/m³
V0 = 1.0  # m/s, initial speed down the upper plane
T_PAPER = 3.0  # s, the last snapshot of Figs. 11-12
# Fig. 9's dimensions are not in the text: a reconstruction with the paper's 160 points (4 per
# cell, so 40 cells: a 1.0 m × 0.4 m block), an upper plane 3 m long and 1 m above a lower plane
# 3 m long that ends at the wall.
LEDGE = (-1.0, -1.0, 3.0, 1.0)  # m, the upper plane is the top of this obstacle (y = 1 m)
BLOCK = (0.5, 1.0, 1.5, 1.4)  # m
DOMAIN = ((0.0, 0.0), (6.0, 2.5))  # m


PLANES = {"kind": "slip"}


def add_arguments(parser):
    parser.add_argument("--planes", choices=("slip", "fixed"), default="slip",
                        help="boundary condition of the two inclined planes (default slip)")


def _scene(critical: bool) -> Scene:
    th = math.radians(INCLINATION)
    planes = PLANES["kind"]
    scene = Scene(domain=DOMAIN, cell_size=H, gravity=(9.81 * math.sin(th), -9.81 * math.cos(th)),
                  boundaries={"left": "fixed", "right": "fixed", "bottom": planes, "top": "fixed"})
    scene.add_obstacle(rectangle(*LEDGE), kind=planes)
    mat = MohrCoulomb(E, NU, RHO0, PHI, PSI, bagnold=ETA, critical_density=RHO_CR if critical else None)
    scene.add_mpm_body(rectangle(*BLOCK), mat, points_per_cell=2, velocity=(V0, 0.0), name="granular")
    return scene


#: original, stress-free and Granular MPM, each a run of its own (mpmdem.study.variants), compared by ``compare``
VARIANTS = GRANULAR_VARIANTS


def build(args) -> CaseSetup:
    PLANES["kind"] = args.planes
    return CaseSetup(_scene(critical_density(args)), end_time=0.4 if args.quick else T_PAPER,
                     frames=4 if args.quick else 30)


def _deposit(r: dict) -> dict:
    x = r["x"]
    ok = np.isfinite(x).all(axis=1)
    x = x[ok]
    lower = x[:, 0] > LEDGE[2]
    return {
        "status": r["status"],
        "end_time_s": float(r["t"][-1]),
        "mean_density_end": float(r["mean_density"][-1]),
        "mean_density_min": float(r["mean_density"].min()),
        "density_spread_end": float(np.std(r["density"][ok])),  # packing uniformity
        "fraction_on_lower_plane": float(lower.mean()),
        "front_x_m": float(x[:, 0].max()),
        "tail_x_m": float(x[:, 0].min()),
        "deposit_height_m": float(x[lower, 1].max()) if lower.any() else 0.0,
        "max_speed_end": float(np.nanmax(r["speed"])),
    }


def summarize(sim, result, args) -> dict:
    return {"inclination_deg": INCLINATION, "points": int(sim.particle_count), "planes": PLANES["kind"]}


def compare(main, runs, args) -> dict:
    """The deposits of the three variants (``VARIANTS``, each a run of its own)."""
    runs = {name: read_run(run.path) for name, run in runs.items()}
    out = {name: _deposit(r) for name, r in runs.items()}
    if main.path is not None:
        def ledge(ax):
            ax.fill_between([DOMAIN[0][0], LEDGE[2]], 0.0, LEDGE[3], color="0.85")
        plot_variants(runs, main.path.parent / "avalanche.png", title="avalanche, Granular MPM Table 3",
                      extra=ledge)
    return out


if __name__ == "__main__":
    from mpmdem.study.runner import run_case

    sys.exit(run_case(sys.modules[__name__], prog="python cases/avalanche.py"))
