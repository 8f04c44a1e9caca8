# Domino: a row of standing blocks toppled by a push on the first.
# Seed: "MPM-SDEM" §3 (vertex-edge contacts with friction, eq. 38-43). The toppling front's speed
# is reported as v / sqrt(g h), the form in which domino-wave measurements are usually compared
# (it depends on the spacing-to-height ratio and friction only).
"""A row of dominoes topples after a push on the first: toppled count and front speed."""

import math
import sys

import numpy as np

from mpmdem import ContactLaw, Scene, rounded_rectangle
from mpmdem.study.case import CaseSetup
from mpmdem.study.flag_types import count_at_least, given, positive

NAME = "domino"
DESCRIPTION = "a row of blocks on a floor topples after a push (DEM only): front speed, toppled count"
DEFAULTS = {"precision": "f64"}

HEIGHT = 0.2  # m
THICKNESS = 0.03  # m
ROUNDING = 0.002  # m
DENSITY = 700.0  # kg/m³ (wood)
STIFFNESS = 2.0e7  # N/m per m
FRICTION = 0.4
GRAVITY = 9.81
PUSH = 3.0  # rad/s, initial toppling rate of the first block about its front bottom corner


def add_arguments(parser):
    parser.add_argument("--blocks", type=count_at_least(2), default=None,
                        help="number of dominoes (default 12; quick 5)")
    parser.add_argument("--spacing", type=positive(), default=0.5, help="centre spacing / height, in (0.15, 0.95)")


def build(args) -> CaseSetup:
    from mpmdem import InputError

    n = given(args.blocks, 5 if args.quick else 12)
    if n < 2:
        raise InputError("--blocks", n, "at least 2 dominoes")
    if not 0.15 < args.spacing < 0.95:
        raise InputError("--spacing", args.spacing, "a spacing/height ratio in (0.15, 0.95)")
    pitch = args.spacing * HEIGHT
    length = (n + 1) * pitch + 2 * HEIGHT
    scene = Scene(domain=((0.0, 0.0), (length, 1.5 * HEIGHT)), gravity=(0.0, -GRAVITY),
                  contact=ContactLaw(STIFFNESS, restitution=0.3))
    scene.add_walls(("bottom",), friction=FRICTION, thickness=0.05)
    shape = rounded_rectangle(THICKNESS, HEIGHT, radius=ROUNDING)
    for k in range(n):
        cx = HEIGHT + k * pitch
        centre = np.array([cx, 0.5 * HEIGHT])
        v, w = (0.0, 0.0), 0.0
        if k == 0:
            # rigid rotation about the front bottom corner at rate -PUSH (clockwise, towards +x)
            r = centre - np.array([cx + 0.5 * THICKNESS, 0.0])
            w = -PUSH
            v = (-w * r[1], w * r[0])
        scene.add_rigid_body(shape, density=DENSITY, position=tuple(centre), velocity=v, angular_velocity=w,
                             friction=FRICTION, name=f"domino{k}")
    fall = math.sqrt(HEIGHT / GRAVITY)
    return CaseSetup(scene, end_time=(4.0 + 1.5 * n) * fall, frames=100 if args.quick else 300)


def summarize(sim, result, args) -> dict:
    from mpmdem.io import RunFile

    names = [b.name for b in sim.scene.rigid_bodies]
    idx = [k for k, s in enumerate(names) if s.startswith("domino")]
    with RunFile(result.path) as rf:
        t = rf.times
        angle = np.array([rf.body_field("angle", k)[idx] for k in range(rf.frame_count)])
        x0 = rf.body_field("x", 0)[idx, 0]
    tipped = np.abs(angle) > 0.2  # rad: past the point of no return for these proportions
    toppled = tipped[-1]
    hit = [float(t[np.argmax(tipped[:, k])]) if tipped[:, k].any() else None for k in range(len(idx))]
    times = [(x0[k], hit[k]) for k in range(1, len(idx)) if hit[k] is not None]
    speed = float(np.polyfit([h for _, h in times], [x for x, _ in times], 1)[0]) if len(times) >= 3 else None
    return {
        "blocks": len(idx),
        "toppled": int(toppled.sum()),
        "all_toppled": bool(toppled.all()),
        "tip_times": hit,
        "front_speed": speed,
        "front_speed_over_sqrt_gh": (speed / math.sqrt(GRAVITY * HEIGHT)) if speed else None,
        "final_angles_deg": [float(math.degrees(a)) for a in angle[-1]],
    }


if __name__ == "__main__":
    from mpmdem.study.runner import run_case

    sys.exit(run_case(sys.modules[__name__], prog="python cases/domino.py"))
