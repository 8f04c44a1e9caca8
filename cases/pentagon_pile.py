# Pentagon pile: random convex pentagons poured into a box settle under gravity.
# Seed: "MPM-SDEM" §3 (spheropolygons, eq. 37-43) and eq. 51 for the time step.
"""Random spheropolygon pentagons fall into a box and settle into a pile."""

import math
import sys

import numpy as np

from mpmdem import ContactLaw, Scene, random_convex_polygon
from mpmdem.study.case import CaseSetup
from mpmdem.study.flag_types import count_at_least, given

NAME = "pentagon-pile"
DESCRIPTION = "random pentagons poured into a box settle (DEM only): packing, contacts, rest"
DEFAULTS = {"precision": "f32"}

SIZE = 0.02  # m, mean circumradius of the pentagon cores
ROUNDING = 0.25  # sphero radius as a fraction of the circumradius
DENSITY = 2600.0  # kg/m³
STIFFNESS = 5.0e6  # N/m per m
FRICTION = 0.5
RESTITUTION = 0.3
GRAVITY = 9.81


def add_arguments(parser):
    parser.add_argument("--bodies", type=count_at_least(1), default=None,
                        help="number of pentagons (default 400; quick 60)")
    parser.add_argument("--columns", type=count_at_least(1), default=None,
                        help="pentagons per row of the release lattice")
    parser.add_argument("--seed", type=count_at_least(0), default=1, help="random seed of shapes and positions")


def build(args) -> CaseSetup:
    from mpmdem import InputError

    n = given(args.bodies, 60 if args.quick else 400)
    if n < 1:
        raise InputError("--bodies", n, "a number of pentagons >= 1")
    cols = given(args.columns, max(2, int(round(math.sqrt(n) * 0.8))))
    rows = math.ceil(n / cols)
    rng = np.random.default_rng(args.seed)
    pitch = 2.0 * SIZE * (1.2 + ROUNDING) * 1.1
    width = cols * pitch
    height = (rows + 2) * pitch
    scene = Scene(domain=((0.0, 0.0), (width, height)), gravity=(0.0, -GRAVITY),
                  contact=ContactLaw(STIFFNESS, restitution=RESTITUTION))
    scene.add_walls(("left", "right", "bottom"), friction=FRICTION, thickness=4 * SIZE)
    for k in range(n):
        i, j = k % cols, k // cols
        r = SIZE * rng.uniform(0.8, 1.2)
        shape = random_convex_polygon(rng, 5, r, radius=ROUNDING * r)
        x = (i + 0.5 + rng.uniform(-0.1, 0.1)) * pitch
        y = (j + 1.0) * pitch
        scene.add_rigid_body(shape, density=DENSITY, position=(x, y), angle=float(rng.uniform(0, 2 * np.pi)),
                             velocity=tuple(rng.normal(0.0, 0.05, 2)), friction=FRICTION, name=f"pentagon{k}")
    fall = math.sqrt(2.0 * height / GRAVITY)
    return CaseSetup(scene, end_time=(1.5 if args.quick else 3.0) * fall + 0.3, frames=30 if args.quick else 60)


def summarize(sim, result, args) -> dict:
    d = result.diagnostics
    f = sim.body_fields()
    bodies = sim.scene.rigid_bodies
    free = np.array([b.motion == "free" for b in bodies])
    x = f["x"][free]
    reach = np.array([b.shape.bounding_radius for b in bodies])[free]
    area = sum(b.shape.area for b in bodies if b.motion == "free")
    (x0, _), (x1, _) = sim.scene.domain
    top = float(np.max(x[:, 1] + reach))
    # solid fraction in the lower half of the pile, away from the rough top surface
    mid = x[:, 1] < 0.5 * top
    solid_lower = sum(b.shape.area for b, m in zip([b for b in bodies if b.motion == "free"], mid, strict=True) if m)
    dem = sim.dem
    energy = dem.C.energy.numpy()
    touching = int(np.count_nonzero(energy > 0.0))
    released = float(d["energy_gravity"][0] - d["energy_gravity"][-1])
    return {
        "bodies": int(free.sum()),
        "pile_height": top,
        "solid_fraction_overall": float(area / ((x1 - x0) * top)),
        "solid_fraction_lower_half": float(solid_lower / ((x1 - x0) * 0.5 * top)),
        "kinetic_over_released": float(d["energy_kinetic"][-1] / max(released, 1e-300)),
        "contacts_per_body": float(2.0 * touching / free.sum()),
        "list_rebuilds": int(d["list_rebuilds"][-1]),
        "steps": int(d["steps"][-1]),
        "steps_per_rebuild": float(d["steps"][-1] / max(d["list_rebuilds"][-1], 1.0)),
        "dissipated_over_released": float(-(d["work_contact_damping"][-1] + d["work_contact_friction"][-1])
                                          / max(released, 1e-300)),
        "energy_balance_residual": float(d["work_numerical"][-1] / max(released, 1e-300)),
    }


if __name__ == "__main__":
    from mpmdem.study.runner import run_case

    sys.exit(run_case(sys.modules[__name__], prog="python cases/pentagon_pile.py"))
