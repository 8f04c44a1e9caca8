"""A test-only case for batched studies: a sand block on a fixed plate in a 0.4 × 0.3 m box, sliding
right at ``--speed`` (20 m/s brings it within reach of the right wall in 4 ms: tests/sim/test_batch.py),
in a box ``--box`` wide (worlds of different widths batch without walls between them)."""

import math

from mpmdem import ContactLaw, DruckerPrager, Scene, rectangle
from mpmdem.model.spheropolygons import rounded_rectangle
from mpmdem.study.case import CaseSetup

NAME = "study-sliding-case"
DESCRIPTION = "a sand block sliding right on a fixed plate"
DEFAULTS = {"precision": "f64", "dt": 2.0e-5}


def add_arguments(parser):
    parser.add_argument("--speed", type=float, default=0.0, help="initial speed of the sand to the right [m/s]")
    parser.add_argument("--box", type=float, default=0.4, help="width of the box [m] (whole cells of 0.02 m)")
    parser.add_argument("--cell-capacity", type=int, default=None,
                        help="points a cell of the point-body search holds (1 overflows at once)")


def build(args) -> CaseSetup:
    scene = Scene(domain=((0.0, 0.0), (args.box, 0.3)), cell_size=0.02, gravity=(0.0, -10.0),
                  contact=ContactLaw(1e5, restitution=0.5),
                  boundaries={"left": "slip", "right": "slip", "bottom": "slip", "top": "free"})
    scene.add_mpm_body(rectangle(0.1, 0.08, 0.25, 0.16), DruckerPrager(1e6, 0.3, 1500.0, friction_angle=30.0),
                       velocity=(args.speed, 0.0))
    scene.add_rigid_body(rounded_rectangle(0.3, 0.02, 0.005), density=1000.0, position=(0.2, 0.05), motion="fixed",
                         name="floor")
    scene.add_mass_probe("low", hi=(math.inf, 0.1))
    config = {"imp_cell_capacity": args.cell_capacity} if args.cell_capacity else {}
    return CaseSetup(scene, end_time=0.004, frames=2, config=config)


def summarize(sim, result, args) -> dict:
    x = sim.fields()["x"]
    return {"right_edge": float(x[:, 0].max()), "low_mass": float(result.diagnostics["mass_low"][-1]),
            "points": sim.particle_count}
