# Block on an incline: a rigid block released on a fixed inclined plank, under gravity.
# Seed: "MPM-SDEM" eq. 43: the tangential spring with the Coulomb cap k_t δ_t ≤ μ k_n δ_n. The
# block slides with a = g (sin θ − μ cos θ) when tan θ > μ and sticks otherwise.
"""A block on a fixed incline: sliding acceleration or sticking, against Coulomb's law."""

import math
import sys

import numpy as np

from mpmdem import ContactLaw, Scene, rounded_rectangle
from mpmdem.study.case import CaseSetup
from mpmdem.study.flag_types import non_negative, positive
from mpmdem.study.validation import Check

NAME = "block-on-incline"
DESCRIPTION = "a block slides (or sticks) on a fixed incline: acceleration vs g(sin θ − μ cos θ)"
DEFAULTS = {"precision": "f64"}
#: `mpmdem validate`: the sliding block's acceleration against Newton's law for a Coulomb block
VALIDATION = [
    Check("acceleration", "acceleration_expected", "analytic: a = g (sin θ − μ cos θ)", 0.005,
          "a fitted to x(t) over the run's frames resolves a to about 0.1 %; 5 × that"),
]

GRAVITY = 9.81  # m/s²
PLANK = (3.0, 0.1)  # m, length and thickness of the incline
BLOCK = (0.2, 0.1)  # m, the block's outer width and height
ROUNDING = 0.005  # m, sphero radius of the block
DENSITY = 2000.0  # kg/m³
STIFFNESS = 1.0e7  # N/m per m


def add_arguments(parser):
    parser.add_argument("--angle", type=positive("deg"), default=30.0, help="incline angle θ [deg], in (0, 80)")
    parser.add_argument("--friction", type=non_negative(), default=0.3, help="Coulomb μ of block and incline")


def _check(args):
    from mpmdem import InputError

    if not 0.0 < args.angle < 80.0:
        raise InputError("--angle", args.angle, "an incline angle in (0, 80) degrees")
    if args.friction < 0.0:
        raise InputError("--friction", args.friction, "a Coulomb coefficient >= 0")


def build(args) -> CaseSetup:
    _check(args)
    th = math.radians(args.angle)
    along = np.array([math.cos(th), math.sin(th)])  # down-slope is −along
    normal = np.array([-math.sin(th), math.cos(th)])
    length, thick = PLANK
    centre = np.zeros(2)
    top = centre + 0.5 * thick * normal
    # the block starts near the upper end, resting on the plank (no overlap)
    start = top + 0.35 * length * along + 0.5 * BLOCK[1] * normal
    pts = np.array([centre + s * 0.5 * length * along + q * normal for s in (-1, 1) for q in (-1, 1)])
    lo = pts.min(axis=0) - 0.3
    hi = np.maximum(pts.max(axis=0), start) + 0.3
    scene = Scene(domain=(tuple(lo), tuple(hi)), gravity=(0.0, -GRAVITY),
                  contact=ContactLaw(STIFFNESS, restitution=0.2))
    scene.add_rigid_body(rounded_rectangle(length, thick), density=DENSITY, position=tuple(centre), angle=th,
                         motion="fixed", friction=args.friction, name="incline")
    scene.add_rigid_body(rounded_rectangle(*BLOCK, radius=ROUNDING), density=DENSITY, position=tuple(start),
                         angle=th, friction=args.friction, name="block")
    return CaseSetup(scene, end_time=0.4 if args.quick else 0.8, frames=40 if args.quick else 80)


def summarize(sim, result, args) -> dict:
    th = math.radians(args.angle)
    expected = GRAVITY * (math.sin(th) - args.friction * math.cos(th))
    sliding_expected = math.tan(th) > args.friction
    with_path = result.path is not None
    # velocity along the slope from the run file's frames (the block is body 1)
    if with_path:
        from mpmdem.io import RunFile

        with RunFile(result.path) as rf:
            t = rf.times
            v = np.array([rf.body_field("v", k)[1] for k in range(rf.frame_count)])
            x = np.array([rf.body_field("x", k)[1] for k in range(rf.frame_count)])
    down = -np.array([math.cos(th), math.sin(th)])
    speed = v @ down
    travel = (x - x[0]) @ down
    late = t >= 0.25 * t[-1]  # after the contact springs have settled
    accel = float(np.polyfit(t[late], speed[late], 1)[0])
    return {
        "angle_deg": args.angle,
        "friction": args.friction,
        "sliding_expected": bool(sliding_expected),
        "acceleration_expected": expected if sliding_expected else 0.0,
        "acceleration": accel,
        "acceleration_error_relative": (abs(accel - expected) / expected) if sliding_expected else None,
        "travel_final": float(travel[-1]),
        "sticks": bool(abs(travel[-1]) < 1e-5),
    }


if __name__ == "__main__":
    from mpmdem.study.runner import run_case

    sys.exit(run_case(sys.modules[__name__], prog="python cases/block_on_incline.py"))
