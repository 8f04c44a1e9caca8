# Silo discharge through a flat-bottom orifice: "MPM-SDEM" §5.3, Table 3, Fig. 15-16.
# Dry sand (Drucker–Prager, Granular MPM, APIC) fills a flat-bottomed silo whose walls and floor are
# fixed spheropolygons; it drains through a centred orifice of width D0 into a spheropolygon
# container below. The discharge rate W [kg/(m s)] is compared with the 2D Beverloo law the paper
# plots in Fig. 16 (its ref. 44, Mankoc et al. 2007):
#
#     W = C ρ sqrt(g) (D0 − k r_p)^(3/2),  C = 0.58, k = 2.2, r_p = Table 3's 0.1 cm,
#
# per metre of thickness (ρ = 1500 kg/m³, g = 10 m/s²): 6.5, 12.8, 20.2, 28.8, 38.2 kg/(m s) for
# D0 = 2 ... 6 cm. `mpmdem study beverloo` runs the five orifices at three grids and fits the law.
#
# Geometry (the paper gives none; SI, every number a flag):
# * silo: inner width 0.20 m (--width), fill 0.30 m (--fill-height), walls and floor plates 2 cm
#   thick with Table 3's sphero radius r_d = 0.5 cm (the orifice's edges are rounded by r_d; its
#   narrowest width is D0 exactly). The width is > 2.5 D0 for every D0 ≤ 6 cm, so the walls do not
#   set the rate (an orifice wider than 0.4 × the width is allowed but flagged in the summary).
# * container: 0.5 m wide (inner), its floor 0.25 m below the silo floor (--drop), walls 0.15 m
#   high; the grid covers both, its sides are slip walls far from the sand and its top is free.
# * the sand starts at rest (no gate; the orifice is open at t = 0), filled in 2 × 2 points per
#   cell with the outermost points at r_p from the walls and floor (touching, zero overlap).
#
# Units: Table 3 in mpmdem/study/references/table3.py (1.5 g/cm² read as 1500 kg/m³ over 1 m of thickness; g = 10
# m/s², the experiments' gravity: Table 3's printed 10 cm/s² is discussed in cases/sand_blocks.py;
# at 10 cm/s² every rate would be 10 × smaller and every time 10 × longer).
#
# Departures from Table 3, and why (as in cases/sand_blocks.py):
# * k_n = 1e6 N/m per m (k_t = k_n / 20, Table 3's ratio) instead of 6e8: the coupled step is
#   bounded by the lightest point on a contact spring (MPM-SDEM eq. 51 with the point term,
#   docs/concepts/time-step.md); at 6e8 it is ~1e-6 s, 1.6e6 steps per run. At 1e6 the deepest overlap is a bottom
#   point under the full fill, ρ g H × s = 1500 × 10 × 0.3 × 1.75 mm = 7.9 N/m → 7.9 µm ≪ r_p.
# * r_p: Table 3's 0.1 cm lies below eq. 45's lower bound (the point spacing h/2); the library's
#   default h n^(-1/4) = h/√2 is used. The Beverloo curve keeps the paper's r_p = 0.1 cm (it is the
#   law the paper plots, not a property of our discretisation).
# * Δt: the library's step (CFL 0.4 and eq. 51 with the point term), not Table 3's 2e-4 s.
# * restitution 0.5 for the normal dashpot (the paper's law is elastic; damping not given).
#
# The rate W: the discharged mass M(t) is the mass below the orifice line (the floor's top), summed
# on the device at every frame (Scene.add_mass_probe). W is the slope of a least-squares line through
# M(t) over the steady window [T_START, t_end]: T_START = 0.4 s leaves out the start (the elastic
# settling of the fill, ~H/c = 12 ms, and the establishment of the flow, a few sqrt(D0/g) ≈ 0.06 s,
# with a margin, checked on M(t) of every run), and t_end is the end of the run or the time 40 % of
# the fill has left, whichever is first: 60 % of the fill (≥ 18 cm ≥ 3 D0) then stands over the
# orifice, a head beyond which the rate of a silo does not depend on the fill (Janssen screening;
# Beverloo's law has no head). The summary gives the window, the fit's RMS residual relative to
# the mass discharged in the window, and W from the two halves of the window (a steadiness check).
#
# What it gives (`mpmdem study beverloo` on an H200, bench/results/studies/beverloo/, docs/studies/index.md): on
# the finest grid (2.5 mm) the free power law on the orifices at least 10 cells wide gives β = 1.43 ±
# 0.07 (the 2D law: 3/2; with the 8-cell 2 cm orifice, 1.26 ± 0.06); the dead zone (the intercept of
# W^(2/3) against D0) is set by the grid (19.4, 12.5, 6.8 mm at 5, 3.5, 2.5 mm); W grows under
# refinement and on the finest grid is 1.7 × the paper's curve: C = 1.00 ± 0.02 with k = 2.2 (paper
# 0.58). At 5 mm, about the paper's point count, C = 0.69. Original and stress-free MPM blow up as the
# jet lands.
#
# --sand dem: the same silo and container, the sand as free DEM sphero-disks (Scene.add_grains,
# MPM-SDEM §3's spheropolygons with one core vertex) of mean radius r_p (--grain-radius, default
# the seed's r_p = 1 mm) ±15 %, grain-grain μ = GRAIN_FRICTION, the same k_n, k_t and restitution.
# The grains are placed on a loose lattice in the silo, settled under gravity with the orifice
# closed by a gate plate (mpmdem.sim.packing.settle), then moved into the open silo at t = 0: the flow
# starts from a settled pack, as the MPM fill starts at rest. Grain density: the continuum's
# 1500 kg/m³ over the packing fraction φ = PACKING_FRACTION of a settled pack of these grains
# (0.82, measured by tests/model/test_grains.py, inside Berryman's 2D 0.82 ± 0.02), so that the pack's
# bulk density is the continuum's. M(t) is the same mass probe (it counts free bodies by their
# centroid), and W the same fit; its Beverloo reference uses r_p = the grain radius. (A flowing
# pack dilates a little: its density near the orifice is below the settled 1500 kg/m³.)
#
# What --sand dem gives on a CPU (2 cores, f32): --quick (0.2 m wide, 15 cm fill, D0 = 4 cm, 8568
# grains, 0.6 s: 86 s) W = 44.6 kg/(m s), steady (halves 44.9 and 44.2), 2.2 × the paper's curve
# (C = 1.28 with k = 2.2 r_p); a 4 cm silo with D0 = 6 grain diameters 1.9-2.1 × (pentagons 1.9 ×);
# D0 = 2 diameters jams within 0.05 s (tests/cases/test_silo_dem.py). The grains flow faster than the
# law, as the MPM sand does under refinement (C = 1.0): disks roll freely (no rolling resistance).
"""Silo discharge (MPM-SDEM §5.3): sand drains through an orifice into a container; rate vs 2D Beverloo."""

import math
import sys

import numpy as np

from mpmdem import ContactLaw, InputError, MuI, Scene, rectangle, rounded_rectangle
from mpmdem.cases._grain_flags import add_grain_arguments, add_mu_i_set_argument
from mpmdem.sim import gated_grains
from mpmdem.study.case import CaseSetup
from mpmdem.study.flag_types import given, non_negative, positive
from mpmdem.study.references.beverloo import beverloo
from mpmdem.study.references.grain_calibration import GLASS_BEAD_SOLID_FRACTION, mu_i_law
from mpmdem.study.references.table3 import (
    CRITICAL_DENSITY_RATIO,
    DENSITY,
    DILATANCY_ANGLE,
    FRICTION_ANGLE,
    GRAVITY,
    GRID_TABLE,
    KN_TABLE,
    KT_TABLE,
    MU_TABLE,
    POISSON,
    R_P_TABLE,
    SPHERO_RADIUS,
    VERLET,
    YOUNGS,
    sand,
)
from mpmdem.study.validation import Check

NAME = "silo-discharge"
DESCRIPTION = "sand drains from a silo through an orifice into a container: flow rate vs 2D Beverloo (MPM-SDEM §5.3)"
# Table 3: APIC; quadratic B-splines keep APIC stable (cases/column_collapse.py); f32 is enough for
# a rate measured to a few per cent and halves the memory traffic on a GPU
DEFAULTS = {"granular": True, "shape": "bspline2", "transfer": "APIC", "precision": "f32"}
#: `mpmdem validate`: the rate at the paper's D0 = 4 cm (Fig. 15) against its Beverloo curve
VALIDATION = [
    Check("rate", 20.22, "MPM-SDEM Fig. 16: W = 0.58 ρ sqrt(g) (D0 − 2.2 × 1 mm)^(3/2), D0 = 4 cm", 0.2,
          "the scatter of 2D Beverloo prefactors between materials and of the paper's own Fig. 16 points",
          known_gap="W grows under refinement past the paper's curve: the grid sets the orifice's dead zone "
                    "(docs/studies/index.md)",
          gap_bounds=(0.35, 0.50), gap_source="bench/results/studies/beverloo and the H100 validation table: 28.6 and "
          "29.0 kg/(m s) at this grid (3.5 mm), which repeat to 1 %, rounded outward to 5 %; 18.4 and 34.3 at 5 "
          "and 2.5 mm",
          coarser=(("--cell-size", "0.005"),)),
]

# -- our geometry and choices (see the header) ---------------------------------------------------
WIDTH = 0.20  # m, inner width of the silo
FILL = 0.30  # m, initial fill height
ORIFICE = 0.04  # m, D0 (the paper's Fig. 15)
WALL = 0.02  # m, thickness of the silo's walls and floor plates and of the container's
DROP = 0.25  # m, from the container's floor up to the silo floor's underside
CONTAINER = 0.50  # m, inner width of the container
CONTAINER_WALL = 0.15  # m, height of the container's walls
HEADROOM = 0.02  # m of grid above the fill
KN = 1.0e6  # N/m per m
KT = KN * KT_TABLE / KN_TABLE  # Table 3's ratio k_t / k_n = 1/20
RESTITUTION = 0.5
POINTS_PER_CELL = 2
T_START = 0.4  # s, start of the steady window
#: a flow that drains DRAINED_END of the fill before T_START + this many frames starts its window earlier,
#: this many frames before its end, but not before T_EARLY [s] (a few sqrt(D0/g) ≤ 0.08 s at D0 ≤ 6 cm to
#: set up the flow, plus the fill's elastic settling): fast silos (D0 = 6 cm with fine sand) keep a rate
MIN_WINDOW_FRAMES = 6
T_EARLY = 0.15
DRAINED_END = 0.4  # fraction of the fill discharged that ends the steady window
END = 1.6  # s, default run length
#: --quick, and the default on a machine without a GPU: 4.7k points, ~40 s on 2 CPU cores
QUICK = {"cell_size": 0.005, "fill_height": 0.15, "end": 0.8}
WALL_MODES = ("sdem", "obstacle-slip", "obstacle-fixed")
MATERIALS = ("drucker-prager", "mu-i")
GRAIN_DIAMETER = 2.0 * R_P_TABLE  # m, d of --material mu-i: Table 3's grain radius r_p = 0.1 cm
SOLID_FRACTION = GLASS_BEAD_SOLID_FRACTION  # ρ / ρs of the glass-bead --material mu-i (ρs 2500 kg/m³)
#: the model choices the method comparison sets (--method), each (MPM variant, coupling, walls):
#: Granular MPM ("Granular MPM" §3: critical density, density control, a grid per component),
#: stress-free MPM (stress-free below the critical density, one grid, no density control), original
#: MPM (a continuum at any density); `grid` coupling (MPM-SDEM's MPM-GRID) is refused with Granular
#: MPM, so it is compared with `imp` on original MPM
METHODS = {
    "granular": ("granular", "imp", "sdem"),
    "stress-free": ("stress-free", "imp", "sdem"),
    "original": ("original", "imp", "sdem"),
    "original-grid": ("original", "grid", "sdem"),
    "obstacle-slip": ("granular", None, "obstacle-slip"),
    "obstacle-fixed": ("granular", None, "obstacle-fixed"),
}
#: --sand dem: grain-grain Coulomb μ (a sand's; a pair with a plate takes the plates' Table 3 μ = 0.2) and
#: the solid fraction of a settled pack of these grains (tests/model/test_grains.py; Berryman 1983: 0.82 ± 0.02),
#: shared with the other cases' grains (mpmdem.sim.gated_grains)
GRAIN_FRICTION = gated_grains.GRAIN_FRICTION
PACKING_FRACTION = gated_grains.PACKING_FRACTION
#: the lattice the grains start on is loose (φ ≈ 0.6): it is this much taller than the fill it settles to
LATTICE_HEIGHT = 1.4
MPM_VARIANTS = {"granular": {"granular": True, "density_control": "revert"},
                "stress-free": {"granular": False, "density_control": "none"},
                "original": {"granular": False, "density_control": "none"}}


def add_arguments(parser):
    parser.add_argument("--orifice", type=positive("m"), default=ORIFICE,
                        help=f"orifice width D0 [m] (default {ORIFICE})")
    parser.add_argument("--width", type=positive("m"), default=WIDTH,
                        help=f"inner width of the silo [m] (default {WIDTH})")
    parser.add_argument("--fill-height", type=positive("m"), default=None,
                        help=f"initial fill height [m] (default {FILL}; {QUICK['fill_height']} with --quick or "
                             "without a GPU, whatever other flags are given)")
    parser.add_argument("--cell-size", type=positive("m"), default=None,
                        help=f"grid spacing [m] (default Table 3's {GRID_TABLE:.4g}; {QUICK['cell_size']} with --quick "
                             "or without a GPU, whatever other flags are given)")
    parser.add_argument("--drop", type=positive("m"), default=DROP,
                        help=f"height of the silo floor above the container floor [m] (default {DROP})")
    parser.add_argument("--domain-height", type=positive("m"), default=None,
                        help="height of the grid above the container floor [m] (default: the fill's top + "
                             f"{HEADROOM} m)")
    parser.add_argument("--normal-stiffness", type=positive("N/m per m"), default=KN,
                        help=f"k_n of every contact [N/m per m] (default {KN:g}; Table 3: {KN_TABLE:g}); k_t = k_n/20")
    parser.add_argument("--method", default="granular", choices=tuple(METHODS),
                        help="model of the comparison: granular (Granular MPM, imp coupling, SDEM walls: the "
                             "default), stress-free or original MPM, original-grid (original MPM, MPM-GRID coupling), "
                             "obstacle-slip/-fixed (Granular MPM, walls as grid obstacles, no DEM)")
    parser.add_argument("--critical-density-ratio", type=positive(), default=CRITICAL_DENSITY_RATIO,
                        help="ρ_cr / ρ0 of Granular and stress-free MPM: looser points are stress-free (default "
                             f"{CRITICAL_DENSITY_RATIO})")
    parser.add_argument("--material", default="drucker-prager", choices=MATERIALS,
                        help="the sand's law: drucker-prager (Table 3, the paper's; the default) or mu-i (the "
                             "mu(I) rheology with Jop et al. 2006's friction law and --grain-diameter: the "
                             "continuum then carries the grain length)")
    parser.add_argument("--grain-diameter", type=positive("m"), default=GRAIN_DIAMETER,
                        help=f"d of --material mu-i [m] (default {GRAIN_DIAMETER}: 2 r_p of Table 3, also the "
                             "DEM disks' d)")
    add_mu_i_set_argument(parser)
    parser.add_argument("--walls", default=None, choices=WALL_MODES,
                        help="silo and container as fixed spheropolygons (sdem, the paper's) or as grid obstacles "
                             "(obstacle-slip: rollers, obstacle-fixed: no slip; no DEM stage at all)")
    parser.add_argument("--friction-angle", type=positive("deg"), default=None,
                        help=f"φ of --material drucker-prager [deg] (default Table 3's {FRICTION_ANGLE:g}; the "
                             "beverloo-calibrated study sets the DEM disks' angle of repose)")
    parser.add_argument("--dilatancy-angle", type=non_negative("deg"), default=None,
                        help=f"ψ of --material drucker-prager [deg], 0 <= ψ <= φ (default Table 3's "
                             f"{DILATANCY_ANGLE:g}, which needs φ >= {DILATANCY_ANGLE:g})")
    add_grain_arguments(parser, what="the sand", radius=R_P_TABLE, radius_note="the seed's r_p")


def coarse(args) -> bool:
    """Whether the sizes not given take the coarse preset (QUICK): with --quick, or on a machine
    without a GPU (the README's first command then finishes in about a minute on a laptop CPU
    instead of an hour). A size flag that is given sets that size alone; the others keep the preset."""
    if args.quick:
        return True
    from mpmdem.sim.simulation import default_device

    return (args.device or default_device()) == "cpu"


def geometry(args) -> dict:
    """Every length of the scene [m], from the flags; raises InputError for an impossible silo."""
    small = coarse(args)
    h = given(args.cell_size, QUICK["cell_size"] if small else GRID_TABLE)
    fill = given(args.fill_height, QUICK["fill_height"] if small else FILL)
    # (grains need no grid: a DEM silo of 10⁶ grains of 1 mm is 2 m wide)
    big = 4.0 if getattr(args, "sand", "mpm") == "dem" else 1.0
    for name, v, lo, hi in (("--cell-size", h, 1e-3, 0.02), ("--width", args.width, 0.02, big),
                            ("--fill-height", fill, 0.01, 2.0 * big), ("--drop", args.drop, 0.05, 2.0),
                            ("--orifice", args.orifice, 1e-3, 1.0)):
        if not (math.isfinite(v) and lo <= v <= hi):
            raise InputError(name, v, f"a length in [{lo}, {hi}] m")
    if not args.orifice < args.width:
        raise InputError("--orifice", args.orifice, f"an orifice narrower than the silo (--width {args.width} m)")
    if not (math.isfinite(args.normal_stiffness) and args.normal_stiffness > 0.0):
        raise InputError("--normal-stiffness", args.normal_stiffness, "k_n > 0 [N/m per m]")
    if not (math.isfinite(args.critical_density_ratio) and 0.5 <= args.critical_density_ratio <= 1.0):
        raise InputError("--critical-density-ratio", args.critical_density_ratio, "a ratio ρ_cr / ρ0 in [0.5, 1]")
    rp = h * (POINTS_PER_CELL**2) ** -0.25  # eq. 45's geometric middle h n^(-1/4)
    if args.orifice <= 2.0 * rp and getattr(args, "sand", "mpm") == "mpm":
        raise InputError("--orifice", args.orifice, f"an orifice wider than two contact radii 2 r_p = {2 * rp:.4g} m "
                         "(a finer --cell-size lets a smaller orifice pass)")
    container = max(CONTAINER, args.width + 2.0 * WALL)
    floor = args.drop + WALL  # top of the silo floor = the orifice line
    top_needed = floor + fill + HEADROOM
    top = given(args.domain_height, top_needed)
    if not top >= floor + fill:
        raise InputError("--domain-height", args.domain_height,
                         f"a grid at least as high as the fill's top, {floor + fill:.4g} m above the container floor")
    # grid: x from the container's outer left face, y from the container floor's underside; the
    # right and top sides on grid lines (Scene requires it of walls)
    x_len = h * math.ceil((container + 2.0 * WALL) / h - 1e-9)
    y_len = h * math.ceil((top + WALL) / h - 1e-9)
    xc = 0.5 * x_len
    g = dict(h=h, rp=rp, fill=fill, floor=floor, xc=xc, x_len=x_len, y_len=y_len, container=container,
             width=args.width, orifice=args.orifice, wall_top=fill + HEADROOM)
    if getattr(args, "sand", "mpm") == "dem":
        r = args.grain_radius
        if not (math.isfinite(r) and 1e-5 <= r <= 0.25 * args.orifice):
            raise InputError("--grain-radius", r, f"a grain radius in [1e-05, D0/4 = {0.25 * args.orifice:.4g}] m")
        # the walls reach above the loose lattice the grains start on (no grid: the domain is the box)
        top = floor + LATTICE_HEIGHT * fill + HEADROOM
        g.update(rp=r, wall_top=LATTICE_HEIGHT * fill + HEADROOM, y_len=max(y_len, top + 2.0 * WALL))
    return g


def _solids(g: dict):
    """(name, width, height, centre) of every wall plate [m]: silo walls, silo floor plates either
    side of the orifice, container floor and walls."""
    xc, w, d0, f = g["xc"], g["width"], g["orifice"], g["floor"]
    wall_h = g["wall_top"] + WALL
    plate = 0.5 * (w - d0) + WALL  # from the wall's outer face to the orifice's edge
    c = g["container"]
    return [
        ("silo_left", WALL, wall_h, (xc - 0.5 * w - 0.5 * WALL, f - WALL + 0.5 * wall_h)),
        ("silo_right", WALL, wall_h, (xc + 0.5 * w + 0.5 * WALL, f - WALL + 0.5 * wall_h)),
        ("floor_left", plate, WALL, (xc - 0.5 * d0 - 0.5 * plate, f - 0.5 * WALL)),
        ("floor_right", plate, WALL, (xc + 0.5 * d0 + 0.5 * plate, f - 0.5 * WALL)),
        ("container_floor", c + 2.0 * WALL, WALL, (xc, -0.5 * WALL)),
        ("container_left", WALL, CONTAINER_WALL, (xc - 0.5 * c - 0.5 * WALL, 0.5 * CONTAINER_WALL)),
        ("container_right", WALL, CONTAINER_WALL, (xc + 0.5 * c + 0.5 * WALL, 0.5 * CONTAINER_WALL)),
    ]


def fill_points(g: dict) -> np.ndarray:
    """The fill's points [m]: a lattice of spacing h/2 whose outermost points sit r_p from the walls
    and the floor (touching, no overlap)."""
    s = g["h"] / POINTS_PER_CELL
    rp, w = g["rp"], g["width"]
    nx = int(math.floor((w - 2.0 * rp) / s + 1e-9)) + 1
    x = g["xc"] - 0.5 * (nx - 1) * s + s * np.arange(nx)
    ny = max(1, round(g["fill"] / s))
    y = g["floor"] + rp + s * np.arange(ny)
    gx, gy = np.meshgrid(x, y, indexing="xy")
    return np.stack([gx.ravel(), gy.ravel()], axis=1)


def material(args, critical_ratio):
    """The sand: Table 3's Drucker–Prager, or μ(I) with the --mu-i-set's μs, μ2, I0 and ρs (Jop et al.
    2006's glass beads, ρs = ρ / SOLID_FRACTION, or our DEM disks' incline fit), Table 3's elasticity and
    density, d = --grain-diameter."""
    if args.material == "drucker-prager":
        phi, psi = sand_angles(args)
        return sand(phi, psi, critical_ratio=critical_ratio)
    if not (math.isfinite(args.grain_diameter) and args.grain_diameter > 0.0):
        raise InputError("--grain-diameter", args.grain_diameter, "d > 0 [m]")
    law, rho_s = mu_i_law(getattr(args, "mu_i_set", "glass-beads"), DENSITY)
    return MuI(YOUNGS, POISSON, DENSITY, **law, grain_diameter=args.grain_diameter, grain_density=rho_s,
               critical_density=critical_ratio * DENSITY if critical_ratio else None)


def sand_angles(args) -> tuple[float, float]:
    """(φ, ψ) [deg] of the Drucker–Prager sand: --friction-angle and --dilatancy-angle, else Table 3's;
    raises InputError unless 0 < φ < 60 and 0 <= ψ <= φ (a dilatancy above the friction angle dissipates
    negative plastic work)."""
    phi = given(getattr(args, "friction_angle", None), FRICTION_ANGLE)
    psi = given(getattr(args, "dilatancy_angle", None), DILATANCY_ANGLE)
    if not (math.isfinite(phi) and 0.0 < phi < 60.0):
        raise InputError("--friction-angle", phi, "a friction angle in (0, 60) deg")
    if not (math.isfinite(psi) and 0.0 <= psi <= phi):
        raise InputError("--dilatancy-angle", psi, f"a dilatancy angle in [0, φ = {phi:g}] deg"
                         + (" (Table 3's default; give --dilatancy-angle with a smaller --friction-angle)"
                            if getattr(args, "dilatancy_angle", None) is None else ""))
    return phi, psi


def walls(args) -> str:
    """The wall model: --walls, else the one --method implies."""
    return args.walls or METHODS[args.method][2]


def _dem_scene(g: dict, args, gate: bool) -> Scene:
    """The silo and container as fixed plates for grains (no grid); ``gate``: a plate closes the orifice."""
    contact = ContactLaw(args.normal_stiffness, args.normal_stiffness * KT / KN, restitution=RESTITUTION)
    scene = Scene(domain=((0.0, -WALL), (g["x_len"], g["y_len"] - WALL)), gravity=(0.0, -GRAVITY), contact=contact)
    solids = _solids(g)
    if gate:
        solids.append(("gate", g["orifice"] + 2.0 * WALL, WALL, (g["xc"], g["floor"] - 0.5 * WALL)))
    for name, w, hh, (cx, cy) in solids:
        scene.add_rigid_body(rounded_rectangle(w, hh, SPHERO_RADIUS), density=DENSITY, position=(cx, cy),
                             motion="fixed", friction=MU_TABLE, name=name)
    return scene


def grain_density() -> float:
    """ρ_s [kg/m³] of the grains: the continuum's bulk density over a settled pack's φ."""
    return DENSITY / PACKING_FRACTION


def build_dem(args, g: dict) -> CaseSetup:
    """--sand dem: grains settled behind a gate, then moved into the open silo (see the header)."""
    from mpmdem.sim.simulation import default_device

    xc, w, f = g["xc"], g["width"], g["floor"]
    region = [(xc - 0.5 * w, f), (xc + 0.5 * w, f), (xc + 0.5 * w, f + LATTICE_HEIGHT * g["fill"]),
              (xc - 0.5 * w, f + LATTICE_HEIGHT * g["fill"])]
    closed = _dem_scene(g, args, gate=True)
    closed.add_grains(region, radius=args.grain_radius, shape=args.grain_shape, density=grain_density(),
                      friction=GRAIN_FRICTION, seed=args.seed, name="sand")
    device = args.device or default_device()
    precision = getattr(args, "precision", None) or DEFAULTS_DEM["precision"]
    # at rest after a free fall through the lattice's height at the least, 8 of them at the most
    packing, seconds = gated_grains.settle_behind_gate(closed, precision=precision, device=device,
                                                       height=LATTICE_HEIGHT * g["fill"], gravity=GRAVITY,
                                                       settle_max=args.settle_max)
    scene = _dem_scene(g, args, gate=False)
    scene.add_grain_set(packing.grains[0])
    inf = math.inf
    scene.add_mass_probe("discharged", hi=(inf, g["floor"]))
    scene.add_mass_probe("silo", lo=(g["xc"] - 0.5 * g["width"], g["floor"]), hi=(g["xc"] + 0.5 * g["width"], inf))
    small = coarse(args)
    end = QUICK["end"] if small else END
    if not getattr(args, "quiet", False):
        print(f"silo-discharge: {len(packing.grains[0])} grains settled in {packing.time:.3g} s (packing fraction "
              f"{packing.packing_fraction:.3f}, bulk density {packing.bulk_density:.0f} kg/m^3)", file=sys.stderr)
    # (for the summary: the case's functions share only the flags)
    args.settled = gated_grains.settled_record(packing, seconds)
    return CaseSetup(scene, end_time=end, frames=round(end / 0.02), config=dict(DEFAULTS_DEM))


#: --sand dem: the solver choices (no grid: the MPM defaults of DEFAULTS do not apply)
DEFAULTS_DEM = {"precision": "f32"}


def costly_build(args) -> bool:
    """Whether ``build`` itself simulates (--sand dem settles the grains behind a gate): a study then
    groups these runs for batching without building them first (``mpmdem.study.batch_worker``)."""
    return getattr(args, "sand", "mpm") == "dem"


def build(args) -> CaseSetup:
    g = geometry(args)
    if getattr(args, "sand", "mpm") == "dem":
        return build_dem(args, g)
    h = g["h"]
    variant, coupling, wall_mode = METHODS[args.method]
    wall_mode = walls(args)
    sdem = wall_mode == "sdem"
    contact = ContactLaw(args.normal_stiffness, args.normal_stiffness * KT / KN, restitution=RESTITUTION)
    scene = Scene(domain=((0.0, -WALL), (g["x_len"], g["y_len"] - WALL)), cell_size=h, gravity=(0.0, -GRAVITY),
                  boundaries={"left": "slip", "right": "slip", "bottom": "slip", "top": "free"},
                  contact=contact if sdem else None)
    x = fill_points(g)
    ratio = None if variant == "original" else args.critical_density_ratio
    scene.add_points(x, material(args, ratio), size=h / POINTS_PER_CELL,
                     contact_radius=g["rp"] if sdem else None, name="sand")
    for name, w, hh, (cx, cy) in _solids(g):
        if sdem:
            scene.add_rigid_body(rounded_rectangle(w, hh, SPHERO_RADIUS), density=DENSITY, position=(cx, cy),
                                 motion="fixed", friction=MU_TABLE, name=name)
        else:
            # the same plates as grid obstacles: the nodes inside them are fixed or rollers
            scene.add_obstacle(rectangle(cx - 0.5 * w, cy - 0.5 * hh, cx + 0.5 * w, cy + 0.5 * hh),
                               kind=wall_mode.removeprefix("obstacle-"))
    inf = math.inf
    scene.add_mass_probe("discharged", hi=(inf, g["floor"]))
    scene.add_mass_probe("silo", lo=(g["xc"] - 0.5 * g["width"], g["floor"]), hi=(g["xc"] + 0.5 * g["width"], inf))
    small = coarse(args)
    end = QUICK["end"] if small else END
    if small and not args.quick and not getattr(args, "quiet", False):
        preset = [flag for flag, v in (("--cell-size", args.cell_size), ("--fill-height", args.fill_height),
                                       ("--end-time", args.end_time)) if v is None]
        print(f"silo-discharge: no GPU, so the coarse preset for {', '.join(preset) or 'no size (all given)'}: "
              f"runs grid {100 * h:g} cm, fill {100 * g['fill']:g} cm, {given(args.end_time, end):g} s, {len(x)} points"
              + ("; about a minute on 2 cores" if len(preset) == 3 else "")
              + f"; the paper's size: --cell-size {GRID_TABLE:.4g} --fill-height {FILL} --end-time {END}",
              file=sys.stderr)
    config = dict(MPM_VARIANTS[variant])
    if sdem:
        # the sand landing in the container packs in thin layers against its plates (each point held
        # r_p off a face while the grid keeps bringing more): more than 64 points in a cell at the
        # 2.5 and 3.5 mm grids with D0 ≥ 5 cm, against the default 16
        config.update(imp_skin=VERLET, imp_cell_capacity=256, coupling=coupling)
    return CaseSetup(scene, end_time=end, frames=round(end / 0.02), config=config)


def steady_rate(times: np.ndarray, mass: np.ndarray, fill_mass: float, t_start: float = T_START) -> dict:
    """Slope of M(t) [kg/(m s)] by least squares over the steady window (see the header), with the
    window [s], the RMS residual relative to the mass discharged in it, and the slopes of its halves."""
    drained = np.flatnonzero(mass >= DRAINED_END * fill_mass)
    end = int(drained[0]) if len(drained) else len(times) - 1
    t_end = float(times[end])
    sel = (times >= t_start - 1e-9) & (times <= t_end + 1e-9)
    if sel.sum() < MIN_WINDOW_FRAMES and end >= MIN_WINDOW_FRAMES:
        # earlier, never later, and not before T_EARLY unless the caller's start already was
        t_start = min(t_start, max(min(t_start, T_EARLY), float(times[end - MIN_WINDOW_FRAMES])))
        sel = (times >= t_start - 1e-9) & (times <= t_end + 1e-9)
    out = {"window_s": [t_start, t_end], "window_frames": int(sel.sum())}
    if sel.sum() < 4:
        out.update(rate=None, rate_residual=None, rate_halves=None)
        return out
    t, m = times[sel], mass[sel]
    slope, icpt = np.polyfit(t, m, 1)
    resid = m - (slope * t + icpt)
    span = max(m[-1] - m[0], 1e-30)
    half = len(t) // 2
    halves = [float(np.polyfit(t[a], m[a], 1)[0]) for a in (slice(0, half + 1), slice(half, None))]
    out.update(rate=float(slope), rate_residual=float(np.sqrt(np.mean(resid**2)) / span), rate_halves=halves)
    return out


def summarize(sim, result, args) -> dict:
    g = geometry(args)
    d = result.diagnostics
    times = result.times
    discharged = np.asarray(d["mass_discharged"])
    in_silo = np.asarray(d["mass_silo"])
    fill_mass = float(in_silo[0])
    out = {
        "orifice_m": g["orifice"], "width_m": g["width"], "fill_height_m": g["fill"], "cell_size": g["h"],
        "contact_radius": g["rp"], "walls": walls(args), "method": args.method, "points": int(sim.particle_count),
        "sand": getattr(args, "sand", "mpm"), "grains": sum(len(s) for s in sim.scene.grains),
        "fill_mass": fill_mass, "critical_density_ratio": args.critical_density_ratio,
        "material": args.material,
        "grain_diameter_m": args.grain_diameter if args.material == "mu-i" else None,
        "mu_i_set": getattr(args, "mu_i_set", "glass-beads") if args.material == "mu-i" else None,
        "friction_angle_deg": sand_angles(args)[0] if args.material == "drucker-prager" else None,
        "dilatancy_angle_deg": sand_angles(args)[1] if args.material == "drucker-prager" else None,
        "walls_may_set_rate": bool(g["width"] < 2.5 * g["orifice"]),
        "times": times.tolist(),
        "discharged_mass": discharged.tolist(),
        # equivalent fill level: the mass still in the silo over ρ0 × width
        "fill_level_m": (in_silo / (DENSITY * g["width"])).tolist(),
        "beverloo_paper": beverloo(g["orifice"]),
        # the same law with the grains' r_p (--sand dem), or the paper's for points
        "beverloo_rp": beverloo(g["orifice"], r_p=g["rp"]) if getattr(args, "sand", "mpm") == "dem" else None,
    }
    # (--sand dem at a quick size: a run shorter than 3 T_START starts its window at a third of it;
    # the grains start settled, and the flow is set up in a few sqrt(D0/g) ~ 0.05 s)
    dem = getattr(args, "sand", "mpm") == "dem"
    t_start = min(T_START, float(times[-1]) / 3.0) if dem else T_START
    out.update(steady_rate(times, discharged, fill_mass, t_start))
    if out["rate"] is not None:
        out["rate_over_paper"] = out["rate"] / out["beverloo_paper"] if out["beverloo_paper"] > 0 else None
        if dem and out["beverloo_rp"]:
            out["rate_over_beverloo_rp"] = out["rate"] / out["beverloo_rp"]
    # no point may end beyond a plate of the silo or container: the deepest penetration of a point
    # centre into a plate's core rectangle (rounded corners ignored: conservative) at the last frame
    x = sim.fields()["x"] if sim.particle_count else sim.body_fields()["x"][len(sim.scene.rigid_bodies):]
    x = x[np.isfinite(x[:, 0])]
    deepest = 0.0
    for _, w, hh, (cx, cy) in _solids(g):
        dx = 0.5 * w - np.abs(x[:, 0] - cx)
        dy = 0.5 * hh - np.abs(x[:, 1] - cy)
        inside = np.minimum(dx, dy)
        deepest = max(deepest, float(inside.max(initial=0.0)))
    out["deepest_penetration_m"] = deepest
    mass = d.get("points_mass", d["mass"])
    out["mass_max_relative_change"] = float(np.abs(np.asarray(mass) / mass[0] - 1.0).max())
    if dem and getattr(args, "settled", None):
        out["settled"] = args.settled  # time [s], RMS speed [m/s], φ, bulk density [kg/m³], Z of the settled pack
    out["dt"] = float(d["dt"][-1])
    return out


if __name__ == "__main__":
    from mpmdem.study.runner import run_case

    sys.exit(run_case(sys.modules[__name__], prog="python cases/silo_discharge.py"))
