"""grain-incline: a layer of DEM grains flowing down a rough incline, periodic along the slope (the
μ(I) calibration of the grains, issue 43 §2).

The grains are the column collapse's and the silo's (``mpmdem.sim.gated_grains``: μ = 0.5 between
grains, e = 0.5, ρs = 1550 / 0.82 kg/m³, ±15 % sizes; k_n = 1e6 N/m, k_t = k_n / 20 as
``cases/_column_grains.py``), so the friction law measured here goes with their angle of repose
(bench/results/studies/grain-calibration). Coordinates follow the slope: x down it (periodic, a strip
``--length`` mean diameters long), y normal to it; gravity (g sin θ, −g cos θ) for ``--angle`` θ.
The base is a row of glued grains of the mean size, one per diameter, at random heights within a
radius (a rough base: no slip), and the layer ``--height`` diameters deep is placed loose above it
and let flow from rest; a frictionless lid 3 layer depths up keeps grains thrown up by an
accelerating layer in the domain.

In a steady uniform flow τ/p = tan θ at every depth (``mpmdem.study.incline_flow``), so the run gives
one point of μ(I): μ = tan θ against the inertial number I = γ̇ d / sqrt(p / ρs) of the layer's
core, read from the depth profiles averaged over the last ``--average`` of the run. Below the
stopping angle the layer comes to rest, above the largest angle of steady flow it accelerates: the
summary says which (``state``), and only a steady run is a point of the law (the study
``grain-incline`` fits Jop et al. 2006's μ(I) to them).
"""

from __future__ import annotations

import math
import sys

import numpy as np

from mpmdem import ContactLaw, InputError, Scene, rounded_rectangle, sphero_disk
from mpmdem.cases._column_grains import KN, KT
from mpmdem.cases._grain_flags import GRAIN_SHAPES
from mpmdem.sim import gated_grains
from mpmdem.study.case import CaseSetup
from mpmdem.study.flag_types import count_at_least, interval, positive

NAME = "grain-incline"
DESCRIPTION = "DEM grains flowing down a rough incline, periodic along it: one point (I, tan θ) of their μ(I)"
#: f64, as the column's grains (cases/_column_grains.py DEFAULTS_DEM)
DEFAULTS = {"precision": "f64"}

GRAVITY = 9.81
BULK_DENSITY = 1550.0  # kg/m³, the column collapse's (grain density ρs = this / PACKING_FRACTION)
GRAIN_RADIUS = 0.5e-3  # m: d = 1 mm, the column collapse's and the calibration's grain
#: the loose lattice the layer is placed on, in units of its height (as cases/_column_grains.py LATTICE)
LATTICE = {"disk": 1.5, "polygon": 2.2}
#: the domain's height above the base (to a frictionless lid), in units of the layer's height (room for a
#: dilated, saltating layer)
HEADROOM = 3.0
#: bins of the depth profiles, in mean diameters
BIN = 1.0
#: the core leaves this many diameters out at the base and at the surface
MARGIN = 3.0


def add_arguments(parser):
    parser.add_argument("--angle", type=interval(0.0, 60.0, open_low=True, open_high=True), default=24.0,
                        help="slope angle θ [deg] in (0, 60)")
    parser.add_argument("--length", type=count_at_least(3), default=None,
                        help="the periodic strip's length in mean grain diameters (default 30; 20 with --quick)")
    parser.add_argument("--height", type=positive(), default=None,
                        help="the layer's depth in mean grain diameters (default 20; 10 with --quick)")
    parser.add_argument("--duration", type=positive(), default=None,
                        help="the run in units of sqrt(d/g) (default 2000; 300 with --quick)")
    parser.add_argument("--average", type=interval(0.0, 1.0, open_low=True), default=0.4,
                        help="the fraction of the run at its end over which the profiles are averaged (default 0.4)")
    parser.add_argument("--grain-radius", type=positive("m"), default=GRAIN_RADIUS,
                        help=f"mean grain radius [m] (default {GRAIN_RADIUS}: the column collapse's grains)")
    parser.add_argument("--grain-shape", default="disk", choices=GRAIN_SHAPES,
                        help="sphero-disks (default) or rounded random pentagons")
    parser.add_argument("--seed", type=count_at_least(0), default=1, help="seed of the grains and the base")


def _sizes(args) -> tuple[int, float, float]:
    """(base grains = the strip's length in diameters, layer depth in diameters, run in sqrt(d/g))."""
    length = args.length or (20 if args.quick else 30)
    height = args.height or (10.0 if args.quick else 20.0)
    duration = args.duration or (300.0 if args.quick else 2000.0)
    if not 0.0 < args.angle < 60.0:
        raise InputError("--angle", args.angle, "a slope angle in (0, 60) deg")
    if not 2.0 <= height <= 500.0:
        raise InputError("--height", height, "a layer depth of 2 to 500 grain diameters")
    return int(length), float(height), float(duration)


def build(args) -> CaseSetup:
    """The periodic strip, its glued base, the loose layer above it, tilted gravity."""
    from mpmdem.model.grains import place_grains

    n_base, height, duration = _sizes(args)
    r = args.grain_radius
    d = 2.0 * r
    L = n_base * d
    theta = math.radians(args.angle)
    top = r + HEADROOM * height * d
    scene = Scene(domain=((0.0, -r), (L, top)), gravity=(GRAVITY * math.sin(theta), -GRAVITY * math.cos(theta)),
                  boundaries={"left": "periodic", "right": "periodic"},
                  contact=ContactLaw(KN, KT, restitution=gated_grains.RESTITUTION))
    # a frictionless lid far above the layer: a steady layer never reaches it, an accelerating one
    # (grains thrown up at growing speeds) stays in the domain and keeps its state readable
    scene.add_rigid_body(rounded_rectangle(L + 4.0 * d, 2.0 * d), density=1000.0, position=(0.5 * L, top - r + d),
                         motion="fixed", friction=0.0, name="lid")
    jitter = np.random.default_rng(args.seed).uniform(0.0, r, n_base)
    for k in range(n_base):
        scene.add_rigid_body(sphero_disk(r), density=1000.0, position=((k + 0.5) * d, float(jitter[k])),
                             motion="fixed", friction=gated_grains.GRAIN_FRICTION, name=f"base{k}")
    y0 = 2.0 * r + 1.2 * r  # (above the highest base grain, with the largest grain's radius)
    region = [(0.0, y0), (L, y0), (L, y0 + LATTICE[args.grain_shape] * height * d), (0.0, y0 + LATTICE[
        args.grain_shape] * height * d)]
    placed = place_grains(region, radius=r, shape=args.grain_shape,
                          density=gated_grains.grain_density(BULK_DENSITY), friction=gated_grains.GRAIN_FRICTION,
                          seed=args.seed, name="layer")
    scene.add_grain_set(gated_grains.lowest_grains(placed, gated_grains.PACKING_FRACTION * height * d * L))
    tau = math.sqrt(d / GRAVITY)
    frames = 100 if args.quick else 200
    return CaseSetup(scene, end_time=duration * tau, frames=frames, config=dict(DEFAULTS))


def summarize(sim, result, args) -> dict:
    """θ, μ = tan θ, the state (stopped, steady, accelerating), the core's I with its scatter, φ,
    the flow height and the depth profiles (module docstring)."""
    from mpmdem.io import RunFile
    from mpmdem.study.incline_flow import core_values, flow_height, flow_state, layer_profiles

    n_base, height, duration = _sizes(args)
    grains = sim.scene.grains[0]
    k0 = len(sim.scene.rigid_bodies)
    d = 2.0 * float(np.mean(np.sqrt(grains.area / math.pi)))  # mean equivalent diameter
    r = args.grain_radius
    L = n_base * 2.0 * r
    base = np.array([b.position[1] for b in sim.scene.rigid_bodies if b.name.startswith("base")])
    base_top = float(base.mean()) + r
    theta = math.radians(args.angle)
    with RunFile(result.path) as rf:
        times = np.asarray(rf.times, float)
        y = [np.asarray(rf.body_field("x", k), float)[k0:, 1] for k in range(rf.frame_count)]
        u = [np.asarray(rf.body_field("v", k), float)[k0:, 0] for k in range(rf.frame_count)]
    mass = grains.mass
    speed = np.array([float(np.sum(mass * uf) / mass.sum()) for uf in u])
    start = (1.0 - args.average) * times[-1]
    state = flow_state(times, speed, start, math.sqrt(GRAVITY * d), GRAVITY * math.sin(theta))
    window = [k for k, t in enumerate(times) if t >= start]
    rho = grains.density
    prof = layer_profiles([y[k] for k in window], [u[k] for k in window], grains.area, mass, base=base_top,
                          bin_width=BIN * d, length=L, grain_density=rho, g_normal=GRAVITY * math.cos(theta),
                          diameter=d)
    h = flow_height(prof)
    core = core_values(prof, h, MARGIN * d)
    steps = int(np.asarray(result.diagnostics["steps"])[-1]) if "steps" in result.diagnostics else None
    out = {
        "angle_deg": args.angle, "mu": math.tan(theta), **state,
        "mu_balance": math.tan(theta) * (1.0 - state["acceleration_over_drive"]), "steady": state["state"] == "steady",
        "I": core["I_core"], "I_std": core["I_core_std"], "phi": core["phi_core"], "phi_std": core["phi_core_std"],
        "shear_rate": core["shear_rate_core"], "core_bins": core["core_bins"], "core_range_m": core["core_range_m"],
        "flow_height_m": h, "flow_height_in_d": h / d, "surface_speed": float(np.nanmax(prof["u"])),
        "base_speed": float(prof["u"][0]), "grain_diameter_mean_m": d, "grain_radius_m": r,
        "grain_shape": args.grain_shape, "grain_density": rho, "grain_friction": grains.friction,
        "normal_stiffness": KN, "tangential_stiffness": KT, "restitution": gated_grains.RESTITUTION,
        "grains": len(grains), "base_grains": n_base, "length_in_d": n_base, "height_in_d_set": height,
        "duration_in_tau": duration, "average_from_s": start, "seed": args.seed, "steps": steps,
        "profiles": {key: [None if not math.isfinite(v) else float(v) for v in prof[key]] for key in prof},
    }
    if not getattr(args, "quiet", False):
        print(f"grain-incline: theta {args.angle:g} deg: {state['state']}, I = {core['I_core']:.4g} "
              f"+- {core['I_core_std']:.2g}, phi = {core['phi_core']:.3f}, h = {h / d:.1f} d", file=sys.stderr)
    return out


if __name__ == "__main__":
    from mpmdem.study.runner import run_case

    sys.exit(run_case(sys.modules[__name__], prog="python cases/grain_incline.py"))
