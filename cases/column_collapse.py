# Granular column collapse on a rough floor: "Motion integration" §5 (set-up §5.1, runout eq. 70-73,
# comparison with the literature §5.4). A column of width L0 and height a·L0 stands on the floor
# against the left wall (a symmetry plane) and collapses under gravity from t = 0; the deposit's
# final runout, final height and the time the flow stops are compared with the quasi-2D scaling
# laws of Lube, Huppert, Sparks & Freundt, "Collapses of two-dimensional granular columns",
# Phys. Rev. E 72, 041301 (2005) (the paper's ref. [56]; not their axisymmetric JFM 2004 paper) and
# of Lajeunesse, Monnier & Homsy, "Granular slumping on a horizontal surface", Phys. Fluids 17,
# 103302 (2005) (ref. [61], the experiments of the paper's Fig. 22).
#
# What was read, and what was not. Neither primary paper could be read here: the search corpora
# hold neither text (nor Lagrée, Staron & Popinet 2011, JFM 686, which tabulates both). Two sets of
# coefficients circulate under Lube et al.'s name for the quasi-2D runout, both of the form
#     (L_f − L0)/L0 = λ1 a   (small a),     λ2 a^(2/3)   (large a):
#   set A: λ1 = 1.2 for a ≲ 1.8, λ2 = 1.9 for a ≳ 2.8 (the set this case used, quoted from memory of
#          the abstract; a public code's restatement of LSP 2011's table gives the same);
#   set B: λ1 = 1.6, λ2 = 2.2 (the set issue 45 reports circulating; not found in a text here).
# A public code's restatement attributes λ1 = 1.8, λ2 = 2.3 (a0 ≈ 3) to Lajeunesse et al.'s glass
# beads; it is discontinuous at a0 (5.4 against 4.8), so it is not used. Balmforth & Kerswell 2005
# (JFM 538, abstract, read here) find (L_f − L0)/L0 ∝ a^(0.9 ± 0.1) in wide channels with a
# material-dependent prefactor. The reference band is therefore the spread between sets A and B at
# each a (``runout_band``), labelled as such: it is not the experiments' scatter, which we could not
# read. Between 1.8 and 2.8 both sets leave a transition, bridged by a straight line in log-log. The
# final height, H_f/L0 = a for a ≲ 1.15 and a^(2/5) above, is quoted from memory of Lube's abstract
# as well (a ≲ 1.15: the top of the column does not move, which needs no coefficient).
# Read later (issue 43; mpmdem/studies/column_collapse_dem.py says what and where): a secondary source,
# K. Kumar's 2015 thesis, restates the quasi-2D channel law as 1.2 a for a ≲ 2.3 and 1.9 a^(2/3) above
# (set A's prefactors, one split at 2.3); the primary papers are still unread.
#
# Choices, and differences from the paper's set-up:
# - no settling phase: the column starts stress-free and collapses at once (gravity from t = 0).
#   Settling would only shorten it by ρ g H / M (1e-3 at a = 1) before it fails.
# - E = 2 MPa instead of the paper's 12.8 MPa (Table 2), to keep the CFL step affordable on a CPU.
#   The collapse is a rigid-plastic flow set by gravity and friction: elasticity enters through
#   ρ g H / M, the elastic strain under the column's own weight (M the P-wave modulus), 1.1e-3 at
#   a = 1 and 9e-3 at a = 8, and through the P-wave speed (42 m/s), 7-20 × the flow speed
#   sqrt(2 g H) (2-6 m/s), so waves equilibrate the column faster than it moves. Measured at a = 1,
#   10 cells: --youngs-modulus 1e7 runs out 1.14 L0 against 1.21 at 2 MPa, the same as 2 MPa with
#   half the time step (1.15): the difference is the step count (next item), not the stiffness.
# - a friction angle of 30° (Lube's quartz sand has an angle of repose of about 30°; the paper's
#   Camargue sand 33.75°), ν = 0.3, ρ = 1550 kg/m³ (quartz, 2600 kg/m³, at a solid fraction of
#   0.6), no cohesion and no dilatancy (ψ = 0, as in the paper).
# - transfer FLIPX with a FLIP fraction of 0.999. Pure FLIP (the paper's choice in §5.4) keeps
#   velocities on points that the grid no longer moves, so the kinetic energy never settles (3 % of
#   its peak remains at a = 1) and its noise ejects single points; any PIC share damps per step,
#   so the runout depends on dt (§5.2): at a = 1, 10 cells, halving dt shortens it by 10 % with a
#   1 % PIC share (to 0.90 L0), by 4 % with 0.1 % (1.21 → 1.15), by < 1 % with pure FLIP (1.30).
#   APIC with the linear shape blew up (points thrown out of the box at t = 0.26 s); APIC with
#   bspline2 ran 1.10 L0, 0.96 at dt/2, and lowered the top to 0.84 L0.
# - Granular MPM ("Granular MPM" §3) with the original linear shape: ρ_cr = 0.99 ρ, so the points of
#   the thinning front that loosen turn stress-free and disconnect instead of pulling on the flow
#   (--critical-density-ratio 0.95 gives the same deposit at a = 4; with none, that run blows up).
# - the rough floor is a Coulomb wall with μ = tan φ (the paper: μ = 0.3). A floor of glued grains
#   resists sliding about as much as the grains resist shearing among themselves, so μ = tan φ is
#   the continuum's "rough" floor; --floor fixed (no slip) is the limit of an infinitely rough one.
#   The top of the box is a slip lid two cells above the column, which the flow never reaches; it
#   only keeps a point thrown up by FLIP noise from leaving the box and stopping the run.
#
# The runout is the deposit's front, as the experiments read it: the far edge of the continuous
# deposit, where it thins below FRONT_THICKNESS × L0 (1 %, 2 mm at L0 = 0.2 m); the farthest point,
# which one thrown grain sets, is reported beside it (`runout_farthest_point_m`).
#
# What it gives (`mpmdem study column-collapse` on an H200, bench/results/studies/column-collapse/,
# 10, 20, 40 and 80 cells across L0): the front converges, moving by less than 7 % from 40 to 80
# cells at every a (a = 1: 1.20, 1.62, 1.79, 1.68 L0; a = 4: 5.90, 6.28, 6.44, 6.39), where the
# farthest point did not (a = 8 at 80 cells: 14.3 against a front of 10.1). Converged, it runs
# 1.23-1.44 × Lube's fits, as the paper's MPM runs past the walled experiments (§5.4: 34 % past
# Lajeunesse et al. at a = 3). The final height converges too and matches Lube for a ≤ 1, but stays
# at 1.2-1.5 L0 for a ≥ 2, where Lube has a^(2/5) (1.74 at a = 4, 2.30 at a = 8): the deposits are
# flatter than the experiments'.
#
# --sand dem (cases/_column_grains.py; issue 43): the column as free DEM sphero-disks (Scene.add_grains)
# of mean radius --grain-radius, ±15 %; the default 0.5 mm makes d = GRAIN_DIAMETER = 1 mm, the grain of
# --material mu-i (millimetre grains, the order of the channel experiments'; their sizes were not read).
# The grain material is the silo's (mpmdem.sim.gated_grains: μ = 0.5, e = 0.5, k_n = 1e6 N/m per m,
# k_t = k_n/20), with ρ_s = ρ / 0.82 so that the settled column has the continuum's bulk density ρ. The
# grains are placed on a loose lattice 1.5 a L0 tall, trimmed to the lowest ones whose area is
# 0.82 a L0² (those settle to a L0), settled behind a frictionless gate at x = L0 and released at t = 0
# (the gate gone at once, as the continuum starts). The wall at x = 0 is frictionless (the symmetry
# plane); the floor is a row of glued disks of the mean radius, touching (--floor rough, the default:
# a rough floor, as the experiments'), or a flat plate with μ = tan φ (--floor friction).
# The summary has the MPM run's fields, read from the grains: the front is ``deposit_front`` on the
# grains' masses in bins of two mean diameters (the same threshold thickness), beside the connected
# front (the last grain reached from the wall through gaps under two diameters) and the farthest
# grain; H_f is the top of the grains within two diameters of the wall; the stop time is read from
# the motion of the grains inside the connected front (a disk thrown past it rolls on: disks have no
# rolling resistance). Beside them: the settled column's packing fraction, bulk density and mean
# coordination number, and the angle of the deposit's flank (mpmdem.study.grain_deposit.flank_angle: the
# angle of repose of the grain calibration, bench/grain_calibration.py). What it gives:
# bench/results/studies/column-collapse-dem/ and grain-calibration/.
"""Granular column collapse (Motion integration §5): runout, final height and stop time against Lube et al. 2005."""

import math
import sys

import numpy as np

from mpmdem import Boundary, MohrCoulomb, MuI, Scene, rectangle
from mpmdem.cases import _column_grains
from mpmdem.cases._grain_flags import add_grain_arguments, add_mu_i_set_argument
from mpmdem.study.case import CaseSetup
from mpmdem.study.flag_types import count_at_least, given, interval, positive
from mpmdem.study.references.grain_calibration import (
    DISK_DIAMETER,
    GLASS_BEAD_SOLID_FRACTION,
    mu_i_law,
)
from mpmdem.study.references.lube2005 import (
    LUBE_RUNOUT_LINEAR,
    LUBE_RUNOUT_POWER,
    SCALING,
    lube_height,
    lube_runout,
    runout_band,
)
from mpmdem.study.validation import Check

NAME = "column-collapse"
DESCRIPTION = "a granular column collapses on a rough floor: runout and final height vs Lube et al. (2005)"
DEFAULTS = {"granular": True, "shape": "linear", "transfer": "FLIPX", "flip_fraction": 0.999, "update": "USL",
            "precision": "f64"}
#: `mpmdem validate`: the converged runout (40 cells across, where the front moves < 7 % to 80) at a = 1
_BAND = ("half the spread between the two coefficient sets circulating under Lube et al.'s name (1.2 a and "
         "1.6 a at a = 1; the primary papers could not be read here, see the header)")
VALIDATION = [
    Check("normalized_runout", 1.4, "Lube et al. 2005, coefficient sets A and B (header): (L_f − L0)/L0 = 1.2-1.6 "
          "at a = 1, the band's middle", 0.2, _BAND, relative=False, flags=("--cells-per-width", "40"),
          known_gap="plane-strain MPM runs past the walled experiments, as 'Motion integration' §5.4 finds against "
                    "Lajeunesse et al.; at the quick size the unconverged front falls short",
          gap_bounds=(0.15, 0.45), gap_source="bench/results/studies/column-collapse: the front at a = 1 is 1.62, "
          "1.79, 1.68 L0 at 20, 40, 80 cells, widened by the 7 % it moves from 40 to 80 cells; quick: 1.06 L0 at "
          "8 cells (CPU), 1.20 at 10 (the study), widened alike",
          quick_flags=("--quick",),
          quick_gap_bounds=(-0.40, -0.15),
          coarser=(("--cells-per-width", "20"),)),
    Check("normalized_final_height", 1.0, "Lube et al. 2005: H_f / L0 = a for a ≤ 1.15 (the top stays), a = 1",
          0.1, "the top of a column with a ≲ 1.15 stays: within a cell and a half at 40 cells, 4 % of L0, and "
          "the reading of the top to a cell at 8 cells (12.5 %) rounded down", flags=("--cells-per-width", "40"),
          quick_flags=("--quick",), coarser=(("--cells-per-width", "20"),)),
]

GRAVITY = 9.81  # m/s²
DENSITY = 1550.0  # kg/m³
YOUNGS_MODULUS = 2.0e6  # Pa
POISSON = 0.3
FRICTION_ANGLE = 30.0  # deg
CRITICAL_DENSITY_RATIO = 0.99
POINTS_PER_CELL = 2  # per direction: 2 × 2 points per cell, as the paper's N_mppc = 4
#: d of --material mu-i [m]: millimetre grains, the order of the channel experiments' (not read from
#: Lube et al. or Lajeunesse et al. here); ρs = ρ / SOLID_FRACTION
GRAIN_DIAMETER = 1.0e-3
#: --sand dem: mean grain radius [m], d = GRAIN_DIAMETER (the header)
GRAIN_RADIUS = 0.5 * GRAIN_DIAMETER
SOLID_FRACTION = GLASS_BEAD_SOLID_FRACTION  # ρ / ρs of the glass-bead set
#: the box holds this many times Lube's runout (--box-runout)
BOX_RUNOUT = 1.5
STOP_FRACTION = 0.01  # the flow has stopped once E_k stays below this fraction of its peak

def add_arguments(parser):
    parser.add_argument("--aspect-ratio", type=positive(), default=1.0, help="a = initial height / width, in [0.1, 20]")
    parser.add_argument("--width", type=positive("m"), default=0.2, help="initial width L0 of the column [m]")
    parser.add_argument("--cells-per-width", type=count_at_least(2), default=None,
                        help="grid cells across L0 (default 10; 8 with --quick)")
    parser.add_argument("--floor", choices=("friction", "fixed", "rough", "ledge"), default=None,
                        help="friction: Coulomb floor with mu = tan(phi) (default with --sand mpm); fixed: no-slip "
                             "floor (mpm only); rough: a row of glued grains (dem only, its default); ledge: the rough "
                             "floor ends at the gate, over a pit (dem only: the heap left is the angle of repose)")
    parser.add_argument("--youngs-modulus", type=positive("Pa"), default=YOUNGS_MODULUS,
                        help="E of the grains' continuum [Pa]")
    parser.add_argument("--critical-density-ratio", type=interval(0.0, 1.0), default=CRITICAL_DENSITY_RATIO,
                        help="rho_cr / rho in (0, 1] (stress-free below it); 0: no critical density")
    parser.add_argument("--material", default="mohr-coulomb", choices=("mohr-coulomb", "mu-i"),
                        help="mohr-coulomb (phi = 30 deg, the default) or mu-i (Jop et al. 2006's glass-bead "
                             "mu_s, mu_2, I0 with --grain-diameter)")
    parser.add_argument("--grain-diameter", type=positive("m"), default=None,
                        help=f"d of --material mu-i [m] (default {GRAIN_DIAMETER}; {DISK_DIAMETER} with --mu-i-set "
                             "dem-disks, the disks' own)")
    add_mu_i_set_argument(parser)
    parser.add_argument("--box-runout", type=positive(), default=BOX_RUNOUT,
                        help=f"the box holds this many times Lube's runout plus the column (default {BOX_RUNOUT}; "
                             "the DEM columns' box is 3)")
    parser.add_argument("--friction-angle", type=positive("deg"), default=None,
                        help=f"phi of the Mohr-Coulomb sand and of the floor's mu = tan(phi) [deg] (default "
                             f"{FRICTION_ANGLE}; the grains' angle of repose: bench/results/studies/grain-calibration)")
    add_grain_arguments(parser, what="the column", radius=GRAIN_RADIUS, radius_note="d of --material mu-i")


def _check(args):
    from mpmdem import InputError

    if not 0.1 <= args.aspect_ratio <= 20.0:
        raise InputError("--aspect-ratio", args.aspect_ratio, "an aspect ratio in [0.1, 20]")
    if not (math.isfinite(args.width) and args.width > 0.0):
        raise InputError("--width", args.width, "a width L0 > 0 [m]")
    if args.cells_per_width is not None and not 2 <= args.cells_per_width <= 200:
        raise InputError("--cells-per-width", args.cells_per_width, "an integer in 2..200")
    if not (math.isfinite(args.youngs_modulus) and args.youngs_modulus > 0.0):
        raise InputError("--youngs-modulus", args.youngs_modulus, "E > 0 [Pa]")
    if not (math.isfinite(args.critical_density_ratio) and 0.0 <= args.critical_density_ratio <= 1.0):
        raise InputError("--critical-density-ratio", args.critical_density_ratio, "a ratio in (0, 1], or 0 for none")
    phi = friction_angle(args)
    if not (math.isfinite(phi) and 0.0 < phi < 60.0):
        raise InputError("--friction-angle", phi, "a friction angle in (0, 60) deg")
    dem = getattr(args, "sand", "mpm") == "dem"
    args.floor = given(getattr(args, "floor", None), "rough" if dem else "friction")
    if args.floor in ("rough", "ledge") and not dem:
        raise InputError("--floor", args.floor, "friction or fixed with --sand mpm: rough and ledge (glued grains) "
                         "need --sand dem")


def _cells(args) -> int:
    return given(args.cells_per_width, 8 if args.quick else 10)


def friction_angle(args) -> float:
    """φ [deg] of the Mohr–Coulomb sand and of the floor's μ = tan φ: --friction-angle, else FRICTION_ANGLE."""
    return given(getattr(args, "friction_angle", None), FRICTION_ANGLE)


def collapse_time(args) -> float:
    """sqrt(a L0 / g) [s], the time scale of eq. 73."""
    return math.sqrt(args.aspect_ratio * args.width / GRAVITY)


def material(args) -> MohrCoulomb | MuI:
    """Mohr–Coulomb (φ = --friction-angle, FRICTION_ANGLE by default), or μ(I) with Jop et al. 2006's
    glass-bead friction law, the same elasticity and density, d = --grain-diameter and ρs = ρ / SOLID_FRACTION."""
    ratio = args.critical_density_ratio
    rho_cr = ratio * DENSITY if ratio > 0.0 else None
    if getattr(args, "material", "mohr-coulomb") == "mu-i":
        law, rho_s, d = mu_i_set(args)
        return MuI(args.youngs_modulus, POISSON, DENSITY, **law, grain_diameter=d, grain_density=rho_s,
                   critical_density=rho_cr)
    return MohrCoulomb(args.youngs_modulus, POISSON, DENSITY, friction_angle(args), 0.0, 0.0, critical_density=rho_cr)


def mu_i_set(args) -> tuple[dict, float, float]:
    """({mu_s, mu_2, i0}, ρs [kg/m³], d [m]) of --material mu-i: Jop et al. 2006's glass beads with
    ρs = ρ / SOLID_FRACTION and d = GRAIN_DIAMETER, or our disks' incline fit
    (``mpmdem.study.references.grain_calibration``) with their grain density and diameter; --grain-diameter
    overrides d."""
    name = getattr(args, "mu_i_set", "glass-beads")
    law, rho_s = mu_i_law(name, DENSITY)
    d = DISK_DIAMETER if name == "dem-disks" else GRAIN_DIAMETER
    return law, rho_s, given(getattr(args, "grain_diameter", None), d)


def costly_build(args) -> bool:
    """Whether ``build`` itself simulates (--sand dem settles the grains behind a gate): a study then
    groups these runs for batching without building them first (``mpmdem.study.batch_worker``)."""
    return getattr(args, "sand", "mpm") == "dem"


def build(args) -> CaseSetup:
    _check(args)
    if args.sand == "dem":
        return _column_grains.build(args)
    a, w = args.aspect_ratio, args.width
    h = w / _cells(args)
    height = a * w
    # the box holds --box-runout (1.5) × Lube's runout (plane-strain simulations run past the walled experiments)
    # plus 4 cells, and the column plus 2 cells
    reach = (1.0 + args.box_runout * max(1.2 * a, 1.9 * a ** (2.0 / 3.0))) * w
    nx = math.ceil(reach / h) + 4
    ny = math.ceil(height / h - 1e-9) + 2
    floor = (Boundary("friction", friction=math.tan(math.radians(friction_angle(args)))) if args.floor == "friction"
             else Boundary("fixed"))
    scene = Scene(domain=((0.0, 0.0), (nx * h, ny * h)), cell_size=h, gravity=(0.0, -GRAVITY),
                  boundaries={"left": "slip", "right": "slip", "bottom": floor, "top": "slip"})
    scene.add_mpm_body(rectangle(0.0, 0.0, w, height), material(args), points_per_cell=POINTS_PER_CELL, name="column")
    # the flow stops by t̃ = t / sqrt(a L0 / g) ≈ 3-4 (eq. 73; Lube et al.); run to t̃ = 7 (6 with
    # --quick), a frame every 0.1 t̃
    tau = collapse_time(args)
    end = (6.0 if args.quick else 7.0) * tau
    # (points gather in single cells at the top of the deposit near the wall for a >= 4, up to 35 in
    # a cell seeded with 4, each still at ρ_cr with det F ≈ 1.01: the cloud compacts while the points'
    # F does not; plain MPM does it too. The interaction search has no per-cell limit.)
    # Tall columns (a >= 4) throw up a spray of single points where the flow leaves the wall: at a = 8
    # with 40 cells across, more than the automatic 16 components met at one node at t = 0.30 s
    config = {"granular_layers": 32} if a >= 4.0 else {}
    return CaseSetup(scene, end_time=end, frames=60 if args.quick else 70, config=config)


#: the deposit's front is where its continuous part thins below this fraction of L0 (see deposit_front)
FRONT_THICKNESS = 0.01


def deposit_front(x: np.ndarray, mass: np.ndarray, density: float, spacing: float, x_wall: float,
                  min_thickness: float) -> float:
    """Position [m] of the deposit's front as the experiments read it: the far edge of the
    continuous deposit, leaving out grains thrown beyond it.

    The points' mass is binned along x in bins of the initial point spacing (a one-point-thick layer
    puts a point in every bin); a bin's equivalent thickness is its mass / (ρ × bin width). Walking
    from the wall, the deposit continues while the thickness stays at least ``min_thickness`` [m]; the
    front is the far edge of the last such bin. A fixed physical thickness (not a number of points)
    makes the front converge under refinement: a foot one point thick counts at a coarse grid only
    while a point is thicker than the threshold.
    """
    nb = max(1, int(math.ceil((float(x[:, 0].max()) - x_wall) / spacing)) + 1)
    k = np.clip(((x[:, 0] - x_wall) / spacing).astype(int), 0, nb - 1)
    thickness = np.bincount(k, weights=mass, minlength=nb) / (density * spacing)
    thin = np.flatnonzero(thickness < min_thickness)
    last = (thin[0] if len(thin) else nb)  # first bin that is too thin ends the deposit
    return x_wall + last * spacing


def stop_time(times: np.ndarray, kinetic: np.ndarray, fraction: float = STOP_FRACTION) -> float | None:
    """The first frame time from which the kinetic energy stays below ``fraction`` of its peak
    (None while it is still above at the last frame)."""
    peak = float(np.max(kinetic))
    if not peak > 0.0:
        return None
    last = int(np.nonzero(kinetic >= fraction * peak)[0][-1])
    return float(times[last + 1]) if last + 1 < len(times) else None


def motion_energy(times: np.ndarray, positions: list[np.ndarray], mass: np.ndarray) -> np.ndarray:
    """½ Σ m |Δx/Δt|² per frame [J/m] from the points' displacement since the previous frame
    (0 at the first frame): the kinetic energy of the motion that actually happens."""
    out = np.zeros(len(times))
    for k in range(1, len(times)):
        u = (positions[k] - positions[k - 1]) / (times[k] - times[k - 1])
        out[k] = 0.5 * float(np.sum(mass * np.sum(u * u, axis=1)))
    return out


def summarize(sim, result, args) -> dict:
    if getattr(args, "sand", "mpm") == "dem":
        return _column_grains.summarize(sim, result, args)
    a, w = args.aspect_ratio, args.width
    h = sim.scene.cell_size
    half = 0.5 * h / POINTS_PER_CELL  # half the initial point spacing: a point's domain reaches that far
    positions = None
    if result.path is not None:
        from mpmdem.io import RunFile

        with RunFile(result.path) as rf:
            times = rf.times
            diag = rf.diagnostics
            positions = [np.asarray(rf.field("x", k), dtype=float) for k in range(rf.frame_count)]
            point_mass = np.asarray(rf.field("mass", 0), dtype=float)
        x0, x1 = positions[0], positions[-1]
    else:
        times, diag = result.times, result.diagnostics
        x0, x1 = None, sim.fields()["x"]
    # When the flow stops: the kinetic energy of the energy diagnostics (from the point velocities)
    # overstates the motion late in the run, because FLIP keeps velocities on points that the grid no
    # longer moves (a point resting on the floor can hold v_p ~ 0.4 m/s while it stays put). The
    # stop time is therefore read from the motion the points actually make between frames; the
    # time from the diagnostics' E_k is reported next to it.
    kinetic = diag["energy_kinetic"]
    stop_diag = stop_time(times, kinetic)
    stop = stop_time(times, motion_energy(times, positions, point_mass)) if positions is not None else None
    tau = collapse_time(args)
    # the deposit's front (the edge of the continuous deposit, as the experiments measure it) and,
    # for comparison, the farthest point (which a single thrown grain sets)
    if positions is not None:
        length = deposit_front(x1, point_mass, DENSITY, 2.0 * half, 0.0, FRONT_THICKNESS * w)
    else:
        length = float(x1[:, 0].max()) + half
    length_farthest = float(x1[:, 0].max()) + half
    length_p99 = float(np.percentile(x1[:, 0], 99.0)) + half
    height_max = float(x1[:, 1].max()) + half
    near_wall = x1[:, 0] < h  # the deposit is highest at the wall; ejected points may lie elsewhere
    height = float(x1[near_wall, 1].max()) + half if near_wall.any() else 0.0
    # eq. 70-71: the "voxelized" width, whole cells up to the furthest point
    lx = math.floor(float(x1[:, 0].max()) / h + 1.0) * h
    lx0 = math.floor(float(x0[:, 0].max()) / h + 1.0) * h if x0 is not None else w
    mass = diag["mass"]
    pred_runout, pred_height = lube_runout(a), lube_height(a)
    runout = (length - w) / w
    out = {
        "aspect_ratio": a,
        "initial_width_m": w,
        "initial_height_m": a * w,
        "cell_size_m": h,
        "cells_per_width": _cells(args),
        "floor": args.floor,
        "youngs_modulus_pa": args.youngs_modulus,
        "friction_angle_deg": friction_angle(args),
        "material": getattr(args, "material", "mohr-coulomb"),
        **({"mu_i_set": args.mu_i_set, "mu_i": mu_i_set(args)[0], "grain_density": mu_i_set(args)[1],
            "grain_diameter_m": mu_i_set(args)[2]} if getattr(args, "material", "") == "mu-i" else {}),
        "box_runout": args.box_runout,
        "runout_m": length - w,
        "normalized_runout": runout,
        "runout_p99_m": length_p99 - w,
        "runout_farthest_point_m": length_farthest - w,
        "normalized_runout_farthest_point": (length_farthest - w) / w,
        "front_thickness_m": FRONT_THICKNESS * w,
        "runout_voxel_m": lx - lx0,
        "normalized_runout_voxel": (lx - lx0) / w,
        "final_height_m": height,
        "normalized_final_height": height / w,
        "final_height_max_m": height_max,
        "stop_time_s": stop,
        "stop_time_normalized": stop / tau if stop is not None else None,
        "stop_time_energy_diagnostic_s": stop_diag,
        "collapse_time_scale_s": tau,
        "kinetic_energy_peak": float(kinetic.max()),
        "kinetic_energy_final": float(kinetic[-1]),
        "mass_initial": float(mass[0]),
        "mass_final": float(mass[-1]),
        "mass_change_relative": float(abs(mass[-1] - mass[0]) / mass[0]),
        "scaling": SCALING,
        "scaling_regime": "linear" if a <= LUBE_RUNOUT_LINEAR[1] else
                          ("power" if a >= LUBE_RUNOUT_POWER[2] else "transition"),
        "predicted_normalized_runout": pred_runout,
        "predicted_normalized_final_height": pred_height,
        "runout_ratio_to_prediction": runout / pred_runout,
        "reference_runout_band": list(runout_band(a)),
        "height_ratio_to_prediction": (height / w) / pred_height,
    }
    if result.path is not None:
        _plot(x0, x1, w, a, h, result.path.parent / "profile.png")
    return out


def _plot(x0, x1, w, a, h, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 3.5))
    ax.scatter(x0[:, 0] / w, x0[:, 1] / w, s=2, color="0.7", label="initial")
    ax.scatter(x1[:, 0] / w, x1[:, 1] / w, s=2, color="C0", label="final")
    xr = 1.0 + lube_runout(a)
    ax.axvline(xr, color="C3", ls="--", lw=1, label="Lube et al. 2005: $L_f$")
    ax.axhline(lube_height(a), color="C3", ls=":", lw=1, label="Lube et al. 2005: $H_f$")
    ax.set_xlabel("x / L0")
    ax.set_ylabel("y / L0")
    ax.set_aspect("equal")
    ax.set_xlim(0.0, max(float(x1[:, 0].max()) / w, xr) + h / w)
    ax.set_ylim(0.0, a + h / w)
    ax.set_title(f"column collapse, a = {a:g}")
    ax.legend(fontsize=7, loc="center right")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    from mpmdem.study.runner import run_case

    sys.exit(run_case(sys.modules[__name__], prog="python cases/column_collapse.py"))
