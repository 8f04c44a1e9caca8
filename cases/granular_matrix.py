# Uniaxial compression of a granular matrix: "MPM-SDEM" §7, Fig. 22-23, Table 3. A skeleton of random
# convex pentagons (SDEM) with fines (Drucker–Prager, Granular MPM) in its voids fills a 61 × 61 cm
# container; a rigid bar presses on it from the top at constant speed. The paper plots the force on
# the bar against its settlement for several fines contents (Fig. 23) and finds that more fines make
# the matrix less compressible (a higher apparent Young's modulus). It gives the container, the bar
# speed (0.5 cm/s for 22 s), Table 3's constants and the pentagons' density 2.2 g/cm²; the rest is
# chosen here (SI, every number a flag or a constant below).
#
# Geometry:
# * container: inner width W = 0.61 m; floor and side walls are fixed rounded rectangles 2 cm thick
#   (Table 3's sphero radius r_d = 0.5 cm), the walls 0.61 m high. The grid spans the container plus
#   one cell on each side (its sides are slip walls there, never reached: the SDEM walls hold every
#   point at r_p), its top is free; W is a whole number of cells (the cell size is rounded to fit).
# * skeleton (cases/_granular_matrix_sample.py): random convex pentagons, circumradius 2.5 cm ± 10 %
#   (4 cm with --quick), rounded by r_d, placed on a hexagonal lattice with random rotations, pitch
#   twice the largest bounding radius (none overlap), rows up to 0.60 m (0.30 m quick). That lattice is
#   loose (void fraction 0.46) and would collapse by a third of its height under gravity, most of it
#   while the bar comes down, so it is packed first: a DEM-only run (SKELETON_SETTLE = 0.6 s, CPU, a
#   second or two; the kinetic energy left is < 1e-3 of the released potential energy, in the summary)
#   lets it fall and come to rest, and the packed skeleton is the sample: 85 pentagons, top at 0.41 m,
#   void ratio 0.28 (quick: 17, 0.20 m). A rain of pentagons settled from far above would give a
#   looser, more random packing but cost a long free fall; the lattice drop is short and the same seed
#   gives the same skeleton for every fines content (the paper keeps one skeleton across its fines
#   contents). The fines are seeded in the packed voids and settle into their pores while the bar waits
#   (SETTLE, 0.3 s; 0.2 s quick).
# * bar: a kinematic rounded rectangle 2 cm thick, 2 mm clear of each wall (no bar–wall contact) and
#   2 mm above the packed skeleton's top, at rest until SETTLE, then moving down at --bar-speed.
#
# Fines content F (--fines): the fraction of the void area A_v = W × H0 − Σ A_pentagon (H0 the
# packed skeleton's top) that the fines cover; the paper does not define its "fine percentage", and
# by area of the voids it reads directly as how full the voids are (the paper's voids are never full
# in Fig. 23's cases). The summary also gives the fines' share of the solid mass (the
# geotechnical fines content, by mass: 5.5 % at F = 0.3). The fines are whole grid cells of the void
# lattice (2 × 2 points each) taken at random, not the lower part of the voids: a bottom layer of
# fines would make a layered sample (a fines-free top over a filled base, two springs in series),
# while random cells give every height the same share; the clumps fall into the bottoms of their
# pores during the settling, as fines do. Points start r_p (1 + 5 %) clear of every body. Variants:
# 0, 0.1, 0.2, 0.3 (bench/granular_matrix.py); the most that fits clear of the pentagons is printed
# by a refused --fines (0.45 on the 0.5 cm grid, 0.43 on the quick one).
#
# Departures from Table 3, and why (as in cases/silo_discharge.py):
# * k_n = 1e6 N/m per m, k_t = k_n / 20 (Table 3's ratio) instead of 6e8: the coupled step is bounded by
#   the lightest point on a contact spring (MPM-SDEM eq. 51 with the point term, docs/concepts/time-step.md),
#   ~1e-6 s at 6e8. At 1e6 the skeleton's contacts are about as stiff as the fines (k_n ~ E × 1 m,
#   E = 0.79 MPa): the apparent modulus belongs to this k_n and is compared between fines contents, not
#   read as an absolute number. The overlaps grow with the load as F / k_n, and the rounded-body contact
#   holds while they stay below r_d: the summary gives the deepest one at the end. A packed skeleton
#   with these contacts reaches r_d at about 8 % strain, so the bar travels 3 cm (--settlement; 7 % of
#   the 0.41 m sample), not the paper's 11 cm (22 s × 0.5 cm/s, a stiffer skeleton).
# * grid 0.5 cm (W = 122 cells) instead of Table 3's 0.35 cm: half the points and 1.4 × the step, for a
#   study of four contents plus half-rate checks (--cell-size 0.0035 gives Table 3's).
# * r_p: the library's h/√2 (eq. 45's geometric middle; Table 3's 0.1 cm is below eq. 45's bound).
# * loading rate: 5 cm/s (--bar-speed) instead of 0.5 cm/s. It is quasi-static when the kinetic energy
#   of the sample stays small against the work of the bar (over any stretch of the loading the inertial
#   part of the force times the settlement is at most the change of kinetic energy, so KE / W_bar
#   bounds the inertial share of the mean force) and when the force–settlement curve is nearly the same
#   at half the speed (bench/granular_matrix.py runs that check).
# * Δt: the library's step (CFL 0.4 and eq. 51 with the point term), not Table 3's 2e-4 s.
# * restitution 0.5 for the normal dashpot (the paper's law is elastic; damping not given).
# * g = 10 m/s² (mpmdem/study/references/table3.py).
#
# Measured (summary.json): per frame the bar's displacement d (its settlement, from its start), the
# force on it (vertical reaction, compression positive) as sampled at the frame and as the mean over
# the frame interval (ΔW_bar / Δd, W_bar the bar's work `work_driven`: steadier than a DEM contact force
# sampled at one step), the kinetic energy of points and pentagons (the bar's is not counted) and its
# ratio to W_bar. First contact: the first frame whose mean force exceeds 5 % of the sample's weight
# (a few pentagons' weight: the bar presses on the skeleton rather than grazing one top). Apparent
# modulus: σ = F / W against ε = (d − d_c) / H_c (d_c, H_c the bar's displacement and its height above
# the floor at first contact), the least-squares slope over MODULUS_STRAIN = 1-4 % after contact (past
# the seating on the highest pentagons, before the overlaps approach r_d).
#
# What it gives (2 CPU cores; bench/results/granular_matrix/cpu.jsonl/.png, `bench/granular_matrix.py
# --device cpu`): modulus 263, 342, 445, 602 kPa for F = 0, 0.1, 0.2, 0.3 (fines 0, 1.9, 3.7, 5.5 % of
# the solid mass): more fines, stiffer, as the paper finds; force at 3 cm 12.9-24.8 kN/m. Half rate
# (2.5 cm/s): curves within 2.4 % (F = 0) and 1.3 % (F = 0.3) RMS, modulus ratio 1.10 and 1.00; kinetic
# energy below 1.4 % of the bar's work in the second half of every loading; deepest overlap 3.0-4.2 mm
# (< r_d). 18k steps, 23-38 s per run with fines (60 s at half rate). --quick (17 pentagons, 195
# points at F = 0.2, 1.5 cm of travel): ~3 s, modulus 202 kPa.
"""Uniaxial compression of a granular matrix (MPM-SDEM §7): pentagon skeleton + MPM fines; force–settlement, modulus."""

import functools
import math
import sys

import numpy as np

from mpmdem import ContactLaw, InputError, Scene, rounded_rectangle
from mpmdem.cases._granular_matrix_sample import (
    container,
    deepest_overlap,
    pick_fines,
    settle,
    skeleton,
    solid_area,
    void_area,
    void_lattice,
)
from mpmdem.study.case import CaseSetup
from mpmdem.study.flag_types import count_at_least, interval, non_negative, positive
from mpmdem.study.references.table3 import CM, GRAVITY, KN_TABLE, KT_TABLE, MU_TABLE, SPHERO_RADIUS, VERLET, sand

NAME = "granular-matrix"
DESCRIPTION = "uniaxial compression of pentagons (SDEM) with MPM fines in their voids: force–settlement (MPM-SDEM §7)"
# as cases/silo_discharge.py: Table 3's APIC on quadratic B-splines, f32
DEFAULTS = {"granular": True, "shape": "bspline2", "transfer": "APIC", "precision": "f32"}

# -- the paper (§7, Fig. 22) -------------------------------------------------------------------
CONTAINER = 61.0 * CM  # m, inner width and wall height
BAR_SPEED_PAPER = 0.5 * CM  # m/s
LOADING_PAPER = 22.0  # s
SETTLEMENT_PAPER = BAR_SPEED_PAPER * LOADING_PAPER  # 0.11 m
PENTAGON_DENSITY = 2.2e-3 / CM**3  # 2.2 g/cm² read as 2200 kg/m³ over 1 m of thickness

# -- our choices (see the header) ---------------------------------------------------------------
KN = 1.0e6  # N/m per m
KT = KN * KT_TABLE / KN_TABLE  # 1/20
RESTITUTION = 0.5
WALL = 2.0 * CM  # m, thickness of walls, floor and bar
BAR_CLEARANCE = 0.2 * CM  # m, from the bar's ends to the walls and from its face to the skeleton
POINTS_PER_CELL = 2
BAR_SPEED = 5.0 * CM  # m/s
FINES = 0.2  # default fines content (fraction of the void area)
FINES_STUDY = (0.0, 0.1, 0.2, 0.3)
CONTACT_FORCE = 0.05  # first contact: mean bar force above this fraction of the sample's weight
MODULUS_STRAIN = (0.01, 0.04)  # strain window of the modulus fit, after first contact
FULL = {"cell_size": 0.5 * CM, "size": 2.5 * CM, "height": 0.60, "settle": 0.3, "settlement": 3.0 * CM}
#: --quick: 17 pentagons, ~290 points at F = 0.3 on a 1.27 cm grid, 1.5 cm of travel
QUICK = {"cell_size": CONTAINER / 48, "size": 4.0 * CM, "height": 0.30, "settle": 0.2, "settlement": 1.5 * CM}
SKELETON_SETTLE = 0.6  # s of the DEM-only packing run (cases/_granular_matrix_sample.py)
FRAME_TRAVEL = 0.5e-3  # m of bar travel between frames


def add_arguments(parser):
    parser.add_argument("--fines", type=interval(0.0, 1.0, open_high=True), default=FINES,
                        help=f"fines content: fraction of the skeleton's void area covered by fines, in [0, 1) "
                             f"(default {FINES}; the study: {', '.join(map(str, FINES_STUDY))})")
    parser.add_argument("--bar-speed", type=positive("m/s"), default=BAR_SPEED,
                        help=f"speed of the bar [m/s] (default {BAR_SPEED}; the paper's {BAR_SPEED_PAPER})")
    parser.add_argument("--settlement", type=positive("m"), default=None,
                        help=f"travel of the bar [m] (default {FULL['settlement']}, the paper's {SETTLEMENT_PAPER:g} "
                             f"is beyond these contacts; {QUICK['settlement']} with --quick)")
    parser.add_argument("--cell-size", type=positive("m"), default=None,
                        help=f"grid spacing [m], rounded so that the container is whole cells (default "
                             f"{FULL['cell_size']}; {QUICK['cell_size']:.4g} with --quick)")
    parser.add_argument("--pentagon-size", type=positive("m"), default=None,
                        help=f"mean circumradius of the pentagons' cores [m] (default {FULL['size']}; "
                             f"{QUICK['size']} with --quick)")
    parser.add_argument("--settle-time", type=non_negative("s"), default=None,
                        help=f"time the bar waits while the sample settles [s] (default {FULL['settle']}; "
                             f"{QUICK['settle']} with --quick)")
    parser.add_argument("--seed", type=count_at_least(0), default=1, help="random seed of the pentagons and the fines")
    parser.add_argument("--normal-stiffness", type=positive("N/m per m"), default=KN,
                        help=f"k_n of every contact [N/m per m] (default {KN:g}; Table 3: {KN_TABLE:g}); k_t = k_n/20")


def params(args) -> dict:
    """The run's sizes from the flags [m, s]; raises InputError for a bad one (before anything runs)."""
    base = QUICK if args.quick else FULL
    if not (math.isfinite(args.fines) and 0.0 <= args.fines < 1.0):
        raise InputError("--fines", args.fines, "a fraction of the void area in [0, 1)")
    if not (math.isfinite(args.bar_speed) and args.bar_speed > 0.0):
        raise InputError("--bar-speed", args.bar_speed, "a speed > 0 [m/s]")
    p = {k: base[k] for k in base}
    for key, flag in (("cell_size", "cell_size"), ("size", "pentagon_size"), ("settle", "settle_time"),
                      ("settlement", "settlement")):
        v = getattr(args, flag)
        if v is not None:
            p[key] = v
    for name, key, lo, hi in (("--cell-size", "cell_size", 1.0e-3, 0.05), ("--pentagon-size", "size", 0.01, 0.1),
                              ("--settle-time", "settle", 0.0, 5.0), ("--settlement", "settlement", 1.0e-3, 0.3)):
        if not (math.isfinite(p[key]) and lo <= p[key] <= hi):
            raise InputError(name, p[key], f"a value in [{lo}, {hi}]")
    if not (math.isfinite(args.normal_stiffness) and args.normal_stiffness > 0.0):
        raise InputError("--normal-stiffness", args.normal_stiffness, "k_n > 0 [N/m per m]")
    cells = max(4, round(CONTAINER / p["cell_size"]))
    p["h"] = CONTAINER / cells
    p["rp"] = p["h"] * (POINTS_PER_CELL**2) ** -0.25  # eq. 45's geometric middle h n^(-1/4)
    return p


def sample(args, p: dict) -> dict:
    """The packed skeleton, the fines' points and the areas [m, m²] of this run (deterministic in --seed)."""
    from mpmdem.sim.simulation import default_device

    return _sample(args.seed, p["size"], p["height"], p["h"], p["rp"], args.fines, float(args.normal_stiffness),
                   args.device or default_device())


@functools.lru_cache(maxsize=4)
def _sample(seed, size, height, h, rp, fines, kn, device) -> dict:
    rng = np.random.default_rng(seed)
    lattice = skeleton(rng, CONTAINER, height, size, SPHERO_RADIUS)
    pents, residual = settle(lattice, container(CONTAINER, CONTAINER, WALL, SPHERO_RADIUS), CONTAINER, CONTAINER,
                             PENTAGON_DENSITY, MU_TABLE, contact_law(kn), GRAVITY, SKELETON_SETTLE, device)
    top = max(q.top() for q in pents)
    voids = void_area(pents, CONTAINER)
    cand = void_lattice(pents, CONTAINER, top, h, rp)
    chosen = pick_fines(cand, fines, voids, h, np.random.default_rng(seed + 1))
    return {"pentagons": pents, "lattice_top": max(q.top() for q in lattice), "top": top, "void_area": voids,
            "solid_area": solid_area(pents), "fines": chosen, "candidates": len(cand), "settle_residual": residual}


def contact_law(kn: float) -> ContactLaw:
    """Every contact (body–body and point–body): k_n [N/m per m], k_t = k_n / 20, restitution 0.5."""
    return ContactLaw(kn, kn * KT / KN, restitution=RESTITUTION)


def build(args) -> CaseSetup:
    p = params(args)
    s = sample(args, p)
    h = p["h"]
    bar_y = s["top"] + BAR_CLEARANCE + 0.5 * WALL
    top = -h + h * math.ceil((bar_y + 0.5 * WALL + h) / h)
    scene = Scene(domain=((-h, -h), (CONTAINER + h, top)), cell_size=h, gravity=(0.0, -GRAVITY),
                  boundaries={"left": "slip", "right": "slip", "bottom": "slip", "top": "free"},
                  contact=contact_law(args.normal_stiffness))
    if len(s["fines"]):
        scene.add_points(s["fines"], sand(), size=h / POINTS_PER_CELL, contact_radius=p["rp"], name="fines")
    for name, shape, pos in container(CONTAINER, CONTAINER, WALL, SPHERO_RADIUS):
        scene.add_rigid_body(shape, density=PENTAGON_DENSITY, position=pos, motion="fixed", friction=MU_TABLE,
                             name=name)
    for k, q in enumerate(s["pentagons"]):
        scene.add_rigid_body(q.shape, density=PENTAGON_DENSITY, position=q.position, angle=q.angle,
                             friction=MU_TABLE, name=f"pentagon{k}")
    scene.add_rigid_body(rounded_rectangle(CONTAINER - 2.0 * BAR_CLEARANCE, WALL, SPHERO_RADIUS),
                         density=PENTAGON_DENSITY, position=(0.5 * CONTAINER, bar_y), motion="kinematic",
                         velocity=(0.0, -args.bar_speed), active=(p["settle"], math.inf), friction=MU_TABLE,
                         name="bar")
    end = p["settle"] + p["settlement"] / args.bar_speed
    frames = max(10, round(p["settle"] / 0.02) + round(p["settlement"] / FRAME_TRAVEL))
    return CaseSetup(scene, end_time=end, frames=frames,
                     config={"imp_skin": VERLET, "imp_cell_capacity": 64})


def contact_frame(force: np.ndarray, weight: float) -> int | None:
    """Index of the first frame whose mean bar force [N/m] exceeds CONTACT_FORCE × the sample's weight."""
    k = np.flatnonzero(np.nan_to_num(force, nan=-np.inf) >= CONTACT_FORCE * weight)
    return int(k[0]) if len(k) else None


def modulus(strain: np.ndarray, stress: np.ndarray, window=MODULUS_STRAIN) -> float | None:
    """Least-squares slope [Pa] of σ [Pa] against ε over the strain window; None with fewer than 3 frames."""
    sel = np.isfinite(stress) & (strain >= window[0] - 1e-12) & (strain <= window[1] + 1e-12)
    if sel.sum() < 3:
        return None
    return float(np.polyfit(strain[sel], stress[sel], 1)[0])


def loading_curve(times, bar_y, force_y, work, kinetic, bar_speed, weight, bar_half=0.5 * WALL) -> dict:
    """The force–settlement curve and its figures from per-frame arrays: the bar's centre height [m],
    the vertical force on it [N/m], its work W_bar [J/m] and the kinetic energy of the sample [J/m]."""
    d = bar_y[0] - bar_y
    dd = np.diff(d)
    mean = np.full(len(d), np.nan)
    moving = dd > 1e-9 * bar_speed
    mean[1:][moving] = np.diff(work)[moving] / dd[moving]
    # a frame's mean force belongs to the middle of its interval
    d_mid = d.copy()
    d_mid[1:] = 0.5 * (d[1:] + d[:-1])
    ratio = np.where(work > 0.0, kinetic / np.where(work > 0.0, work, 1.0), np.nan)
    out = {"times": times.tolist(), "settlement_m": d.tolist(), "settlement_mid_m": d_mid.tolist(),
           "force_n_per_m": force_y.tolist(), "force_mean_n_per_m": mean.tolist(), "work_bar": work.tolist(),
           "kinetic_energy": kinetic.tolist(), "kinetic_over_work": ratio.tolist()}
    c = contact_frame(mean, weight)
    out["contact_frame"] = c
    if c is None:
        out.update(contact_settlement_m=None, sample_height_m=None, strain=None, stress_pa=None, modulus_pa=None)
        return out
    dc = d_mid[c]
    height = bar_y[c] - bar_half  # the floor's top is y = 0
    strain = (d_mid - dc) / height
    stress = mean / CONTAINER
    out.update(contact_settlement_m=float(dc), sample_height_m=float(height), strain=strain.tolist(),
               stress_pa=stress.tolist(), modulus_pa=modulus(strain, stress))
    after = np.arange(len(d)) >= c
    late = after & (d_mid >= 0.5 * (dc + d[-1]))  # second half of the loading after contact
    out["kinetic_over_work_final"] = float(ratio[-1])
    # the kinetic energy averaged over the loading after contact (slip bursts included) over the
    # bar's whole work: the share of the work that the run kept in motion on average
    out["kinetic_mean_over_work"] = float(np.mean(kinetic[c:]) / work[-1]) if work[-1] > 0.0 else None
    out["kinetic_over_work_max_late"] = float(np.nanmax(ratio[late])) if late.any() else None
    out["force_final_n_per_m"] = float(np.nanmean(mean[-3:]))
    return out


def summarize(sim, result, args) -> dict:
    from mpmdem.io import RunFile

    p = params(args)
    with RunFile(result.path) as rf:
        times = rf.times
        names = [str(n) for n in rf.body_geometry()["name"]]
        b = names.index("bar")
        bx = np.array([rf.body_field("x", k)[b] for k in range(rf.frame_count)])
        bf = np.array([rf.body_field("force", k)[b] for k in range(rf.frame_count)])
        last = rf.frame_count - 1
        final_x, final_angle = rf.body_field("x", last), rf.body_field("angle", last)
        diag = rf.diagnostics
    bodies = sim.scene.rigid_bodies
    pent_mass = float(sum(q.mass for q in bodies if q.motion == "free"))
    pts_mass = float(diag["points_mass"][0]) if "points_mass" in diag else 0.0
    weight = (pent_mass + pts_mass) * GRAVITY
    s = sample(args, p)
    voids = s["void_area"]
    fines_area = len(s["fines"]) * (0.5 * p["h"]) ** 2
    out = {
        "fines": args.fines,
        "fines_void_fraction": fines_area / voids,
        "fines_mass_fraction": pts_mass / (pts_mass + pent_mass),
        "points": int(sim.particle_count),
        "pentagons": int(sum(1 for q in bodies if q.motion == "free")),
        "cell_size": p["h"], "contact_radius": p["rp"], "pentagon_size": p["size"],
        "bar_speed": args.bar_speed, "settle_time": p["settle"], "normal_stiffness": float(args.normal_stiffness),
        "lattice_top_m": s["lattice_top"], "skeleton_top_m": s["top"],
        "skeleton_settle_kinetic_over_released": s["settle_residual"],
        "void_area_m2": voids, "solid_area_m2": s["solid_area"],
        "void_ratio_initial": voids / s["solid_area"],
        "sample_weight_n_per_m": weight,
        "modulus_strain_window": list(MODULUS_STRAIN),
    }
    work = np.asarray(diag["work_driven"], dtype=float)
    kinetic = np.asarray(diag["energy_kinetic"], dtype=float)
    out.update(loading_curve(np.asarray(times), bx[:, 1], bf[:, 1], work, kinetic, args.bar_speed, weight))
    moving = np.array([q.motion != "fixed" for q in bodies])
    out["deepest_overlap_final_m"] = deepest_overlap([q.shape for q in bodies], final_x, final_angle, moving)
    out["sphero_radius"] = SPHERO_RADIUS
    if "points_mass" in diag:
        m = np.asarray(diag["points_mass"])
        out["mass_max_relative_change"] = float(np.abs(m / m[0] - 1.0).max())
    else:
        out["mass_max_relative_change"] = 0.0
    out["dt"] = float(diag["dt"][-1])
    return out


if __name__ == "__main__":
    from mpmdem.study.runner import run_case

    sys.exit(run_case(sys.modules[__name__], prog="python cases/granular_matrix.py"))
