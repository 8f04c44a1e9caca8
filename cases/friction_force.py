# Frictional coupling force: the block of cases/normal_force.py launched along the floor at 2 m/s.
# Seed: "MPM-SDEM" (Jiang et al.) §5.2.2, Figs. 13-14, Table 2: the tangential spring of eq. 43
# capped at μ k_n δ_n. While the bottom row slides every contact sits on the cap, so the floor's
# friction on the block is μ times the normal force, μ W = 0.3 × 25 N = 7.5 N (−0.14706 N per
# bottom point, 51 of them), opposing the motion.
#
# Units, geometry, material and the departures from Table 2 (r_p, Δt, contact damping, --quick)
# are those of cases/normal_force.py; see its header. Here: μ = 0.3 for the (material, floor)
# pair (the paper's §5.2.2 value; the floor keeps Table 2's 0.1 for anything else), the paper's
# grid dg = 0.50 cm (--grid-index 3) and the velocity given to every point at t = 0 (the block
# starts touching the floor with zero overlap, as in the normal test). The block decelerates at
# μ g = 0.3 m/s², so it slides for v/(μ g) = 6.7 s, longer than the paper's 3.5 s: the floor and
# the domain are made long enough for the run's travel.
# In --quick the Cundall damping also acts along x on the sliding block (it opposes each node's
# velocity with a force D |f|) and slows it a little more; the friction force itself is the
# Coulomb cap, μ times the normal force, which equals W once the vertical motion has settled, so
# the check is unchanged (the summary reports the block's speed: it must still be sliding).
"""MPM block sliding on a fixed spheropolygon floor: the coupling's friction force vs μ × weight."""

import math
import sys

import numpy as np

from mpmdem.cases import normal_force as nf
from mpmdem.study.case import CaseSetup
from mpmdem.study.flag_types import count_at_least, positive
from mpmdem.study.validation import Check

NAME = "friction-force"
DESCRIPTION = "elastic MPM block sliding on a fixed spheropolygon: friction force vs μ × weight (MPM-SDEM §5.2.2)"
DEFAULTS = dict(nf.DEFAULTS)  # GIMP-PIC, f64, V_d as the skin of the point–body lists

VALIDATION = [
    Check("friction_over_mu_weight", 1.0, "Coulomb sliding on a level floor: F = μ W (MPM-SDEM §5.2.2, Fig. 14)",
          0.02, "N differs from W by the block's vertical inertia only, which settles to the normal-force case's "
          "late band (2 %, Fig. 12 converged)", relative=False, flags=("--quick",)),
]

SPEED = 2.0  # m/s, V_x of §5.2.2
MU = 0.3  # μ of the (block material, floor) pair in §5.2.2


def add_arguments(parser):
    parser.add_argument("--grid-index", type=count_at_least(0), default=3,
                        help="i of the grid dg = 0.35 + 0.05 i cm, 0..3 "
                        "(default 3: the paper's 0.50 cm)")
    parser.add_argument("--friction", type=positive(), default=MU, help=f"μ of the block-floor pair (default {MU})")
    parser.add_argument("--speed", type=positive("m/s"), default=SPEED, help=f"initial x velocity of the block [m/s] "
                        f"(default {SPEED})")
    parser.add_argument("--contact-radius", type=positive("m"), default=nf.R_P,
                        help=f"r_p of the points [m] (default {nf.R_P}); must lie in eq. 45's interval")


def travel(args) -> float:
    """Distance [m] the block slides in the run (decelerating at μ g, stopping if it must)."""
    from mpmdem import InputError

    if not (math.isfinite(args.speed) and args.speed > 0.0):
        raise InputError("--speed", args.speed, "a sliding speed > 0 [m/s]")
    if not (math.isfinite(args.friction) and args.friction > 0.0):
        raise InputError("--friction", args.friction, "a Coulomb coefficient > 0")
    end, _ = nf.run_length(args)
    t = min(end, args.speed / (args.friction * nf.GRAVITY))
    return args.speed * t - 0.5 * args.friction * nf.GRAVITY * t * t


def build(args) -> CaseSetup:
    nf.check_grid_index(args.grid_index)
    scene, _ = nf.block_scene(args.grid_index, args.quick, contact_radius=args.contact_radius,
                           velocity=(args.speed, 0.0), friction=args.friction, travel=1.05 * travel(args))
    config = {"damping": nf.DAMPING_QUICK} if args.quick else {}
    return CaseSetup(scene, *nf.run_length(args), config=config)


def summarize(sim, result, args) -> dict:
    s = nf.contact_state(sim)
    hist = nf.floor_force_history(result)[1:]  # force on the floor per frame: (+friction, −normal)
    late = hist[len(hist) * 3 // 4:]
    mu_w = args.friction * nf.WEIGHT
    friction = float(s["fc"][:, 0].sum())  # on the block, −x while it slides towards +x
    normal = float(s["fc"][:, 1].sum())
    fields = sim.fields()
    v, x = fields["v"], fields["x"]
    _, dt, _, steps, _ = sim.stage.read_clock()
    # Moment balance about the centroid (equal point masses; gravity and the uniform deceleration
    # act there): the friction at the base, a lever (y_c − y_row) below it, tips the load towards
    # the front, Σ (x_p − x_c) f_y = Σ (y_p − y_c) f_x. The normal resultant sits ahead of the
    # centroid by e = μ (y_c − y_row), 1.47 cm here: the row's loads cannot be equal while it slides.
    fc, c = s["fc"], x.mean(axis=0)
    ratio = -fc[s["touching"], 0] / (args.friction * fc[s["touching"], 1])
    lever = float(c[1] - x[:nf.POINTS, 1].mean())
    tipping = float(((x[:, 0] - c[0]) * fc[:, 1]).sum())
    righting = float(((x[:, 1] - c[1]) * fc[:, 0]).sum())
    return {
        "weight": nf.WEIGHT,
        "friction_coefficient": args.friction,
        "friction_expected": -mu_w,
        "point_friction_expected": -args.friction * nf.POINT_LOAD,
        "friction_force": friction,
        "friction_over_mu_weight": -friction / mu_w,
        "friction_over_mu_normal": -friction / (args.friction * normal) if normal > 0.0 else math.nan,
        "normal_over_weight": normal / nf.WEIGHT,
        "floor_force_over_mu_weight": float(s["floor"][0] / mu_w),
        "friction_late_max_deviation": float(np.abs(late[:, 0] / mu_w - 1.0).max()),
        "points_touching": int(len(s["touching"])),
        "only_bottom_row_touching": s["only_bottom_row"],
        **nf.row_stats(s["bottom"][:, 0], "bottom_friction"),
        **nf.row_stats(s["bottom"][:, 1], "bottom_load"),
        # every touching point on the Coulomb cap: −f_x = μ f_y (f_y also holds the dashpot term)
        "cap_ratio_min": float(ratio.min()) if len(ratio) else math.nan,
        "cap_ratio_max": float(ratio.max()) if len(ratio) else math.nan,
        "load_eccentricity": tipping / normal if normal > 0.0 else math.nan,
        "load_eccentricity_expected": args.friction * lever,
        "moment_residual_relative": (tipping - righting) / (abs(friction) * lever) if friction else math.nan,
        "block_speed_final": float(v[:, 0].mean()),
        "bottom_row_speed_min": float(v[:nf.POINTS, 0].min()),
        "grid_cm": sim.scene.cell_size * 100.0,
        "normal_stiffness": float(sim.coupling.law.normal_stiffness),
        "dt": float(dt),
        "steps_coupled": int(steps),
        "last_step_idle": bool(dt == 0.0),
        "friction_history": (hist[:, 0] / mu_w).tolist(),
    }


if __name__ == "__main__":
    from mpmdem.study.runner import run_case

    sys.exit(run_case(sys.modules[__name__], prog="python cases/friction_force.py"))
