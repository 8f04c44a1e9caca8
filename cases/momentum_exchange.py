# Momentum exchange: an elastic MPM disk at 2 m/s hits an equal DEM disk at rest head-on, no gravity.
# Seed: "MPM-SDEM" §5.1.1 (Table 1 parameters, Fig. 6-7): the coupling by identified material
# points (eq. 44-50) must hand the momentum over without creating energy; the paper reports the
# DEM disk leaving at 1.992 m/s (hard disk, 99.2 % of the kinetic energy) and 1.92 m/s (soft).
#
# Units. Table 1 mixes cm, g and kPa in a 2D model; we read it per metre of thickness, SI:
#   k_n 6.0e6 N/cm -> 6.0e8 N/m per m,  k_t 3.0e5 N/cm -> 3.0e7 N/m per m,  μ 0.1
#   sphero (disk) radius 2.0 cm -> 0.02 m,  Verlet distance 0.2 cm -> 0.002 m (the IMP skin)
#   densities 2.0 g/cm² (DEM and MPM) -> 2.0 g/cm³ = 2000 kg/m³ (2D mass per unit thickness)
#   grid 0.3 cm -> 0.003 m,  r_p 0.1 cm -> 0.001 m,  5000 points -> 6×6 per cell (5024 points)
#   K 5.0e2 / 5.0e3 kPa, G 3.7e2 / 3.7e3 kPa (soft / hard) -> Pa.
# E and ν follow from K and G by the 3D relations (plane strain uses the 3D Lamé constants):
# ν = (3K − 2G) / (2(3K + G)) = 0.203, not the 0.278 Table 1 prints (which no (K, G) pair of the
# table satisfies); K and G are kept since they set the wave speeds.
# Table 1's Δt = 1e-4 s is not used: a contact spring of 6e8 N/m on a point of ~5e-4 kg/m is
# stable only below ~2e-6 s, so the coupled step of mpmdem.sim.coupling (eq. 51 with the point-mass
# bound) is taken; it is ~6e-7 s at the paper's resolution.
# Restitution: Table 1 has no contact damping, so e = 1 (the paper calls the collision elastic).
#
# What sets the answer (measured, hard disk, FLIP): the DEM disk's final speed moves by less than
# 0.01 m/s with dt (κ2 0.02-0.3), r_p, f32/f64, the stress-update order or μ (0 or 0.1), but it
# moves with the grid: 1.77 / 1.83 / 1.87 / 1.88 / 1.90 / 1.94 / 1.92 m/s at h = 4 / 3 / 2 / 1.5 /
# 1 / 0.75 / 0.5 mm (B-spline, 2×2 points per cell), 1.858 m/s with this case's --quick set-up and
# 1.868 with Table 1's. What the DEM disk does not get stays in the MPM disk as vibrations (our
# reading: in 2D the contact lasts about as long as the disk's lowest vibration period, so the
# impact is not quasi-static) or is damped by FLIP. A contact spring as soft as the disk
# (k_n ~ E) lengthens the contact and gives 1.97 m/s at h = 3 mm, but with overlaps of the order
# of r_p; with Table 1's k_n the paper's 1.992 m/s is not reached. Transfers (--quick, hard):
# FLIP 1.858, APIC 1.815, PIC 1.256 m/s.
"""Elastic MPM disk hits an equal DEM disk head-on (MPM-SDEM §5.1.1): speed handed over, energy."""

import math
import sys

import numpy as np

from mpmdem import ContactLaw, InputError, LinearElastic, Scene, disk, sphero_disk
from mpmdem.study.case import CaseSetup
from mpmdem.study.flag_types import positive
from mpmdem.study.validation import Check

NAME = "momentum-exchange"
DESCRIPTION = "elastic MPM disk hits an equal DEM disk head-on: speed and kinetic energy handed over (MPM-SDEM §5.1.1)"

# -- Table 1, converted once (see the header) ------------------------------------------------------
CM = 0.01  # m
KN = 6.0e6 / CM  # N/cm -> N/m per m
KT = 3.0e5 / CM
FRICTION = 0.1
VERLET = 0.2 * CM  # m
RADIUS = 2.0 * CM  # m, sphero radius of the DEM disk = radius of the MPM disk
DENSITY = 2.0 / 1000.0 / CM**3  # g/cm² read as g/cm³ -> kg/m³, both bodies
GRID = 0.3 * CM  # m
R_P = 0.1 * CM  # m
POINTS_PER_CELL = 6  # 36 per cell: 5024 points in the disk (Table 1: 5000)
KPA = 1.0e3
MODULI = {"soft": (5.0e2 * KPA, 3.7e2 * KPA), "hard": (5.0e3 * KPA, 3.7e3 * KPA)}  # (K, G) [Pa]
SPEED = 2.0  # m/s
APPROACH = 0.001  # m the disks travel before the first point touches (0.5 ms at 2 m/s)
PAPER_SPEED = {"soft": 1.92, "hard": 1.992}  # m/s, §5.1.1

# GIMP as Table 1 (uGIMP); FLIP because PIC's smoothing takes most of the impact's energy (see
# the header); f64 so that energy sums over thousands of points are exact to far below 1e-6.
# The Verlet distance of Table 1 is the IMP skin.
DEFAULTS = {"shape": "ugimp", "transfer": "FLIP", "update": "USL", "precision": "f64", "imp_skin": VERLET}

# --quick is Table 1's 3 mm grid and contact springs (3 × 3 points per cell): minutes on a CPU.
_GRID = ("the paper gives no scatter; our discretisation error at this size, estimated by one refinement "
         "(1.852 m/s --quick, 1.868 at Table 1's 6 x 6 points per cell), doubled: 1 % of v0; x 2 for E_k ∝ v²")
VALIDATION = [
    Check("dem_speed_final", 1.992, "MPM-SDEM §5.1.1 (text under Fig. 7): hard disk", 0.02, _GRID, relative=False,
          flags=("--quick",),
          known_gap="with Table 1's k_n the exchange is set by the grid; the rest stays in the MPM disk as "
                    "vibrations (tests/cases/test_coupling_energy.py)", gap_bounds=(-0.15, -0.04),
          gap_source="1.85-1.87 m/s at this size and Table 1's, 1.90-1.94 on grids down to 0.5 mm (the header), "
                     "rounded outward to 0.01 m/s"),
    Check("kinetic_energy_ratio", 0.99202, "MPM-SDEM §5.1.1: 99.202 % of the elastic collision's E_k", 0.02, _GRID,
          relative=False, flags=("--quick",), known_gap="the same grid-limited exchange, E_k share ≈ (v / v0)²",
          gap_bounds=(-0.15, -0.04), gap_source="(v / v0)² of the hard disk's 1.85-1.94 m/s (0.856-0.941), "
                                                "rounded outward to 0.01"),
    Check("dem_speed_final", 1.92, "MPM-SDEM §5.1.1: soft disk (7.84 % of E_k lost)", 0.02, _GRID, relative=False,
          flags=("--quick", "--material", "soft"), known_gap="grid-limited as the hard disk",
          gap_bounds=(-0.12, -0.02), gap_source="1.81 m/s at this size, 1.81-1.89 on grids from 3 to 0.75 mm, rounded "
                                                "outward to 0.01 m/s"),
]


def elastic_constants(material: str) -> tuple[float, float]:
    """(E [Pa], ν) from Table 1's bulk and shear moduli by the 3D relations."""
    k, g = MODULI[material]
    return 9.0 * k * g / (3.0 * k + g), (3.0 * k - 2.0 * g) / (2.0 * (3.0 * k + g))


def table1_material(material: str) -> LinearElastic:
    """The linear elastic MPM material of Table 1, "soft" or "hard"."""
    e, nu = elastic_constants(material)
    return LinearElastic(e, nu, DENSITY)


def contact_law() -> ContactLaw:
    """Table 1's contact springs, undamped (e = 1)."""
    return ContactLaw(KN, KT, restitution=1.0)


def resolution(args) -> tuple[float, int, float | None]:
    """(h [m], points per cell per direction, r_p [m] or None for eq. 45's middle).

    Full: Table 1 (h = 3 mm, 6×6 points, r_p = 1 mm). Quick: the same grid with 3×3 points per
    cell (4 times fewer points, 4 times the smallest point mass, so a 2 times larger step);
    Table 1's r_p = h/3 is eq. 45's lower bound h/√9 there, so r_p is eq. 45's geometric middle
    h/√3. With 2×2 points the disk drop keeps much less of its energy (rebound 0.70 against 0.85
    with 3×3 and 0.90 with 6×6, measured): too few points share the contact.
    """
    if args.quick:
        return GRID, 3, None
    return GRID, POINTS_PER_CELL, R_P


def add_material_argument(parser):
    parser.add_argument("--material", choices=tuple(MODULI), default="hard",
                        help="Table 1's soft (K = 500 kPa) or hard (K = 5000 kPa) elastic disk (default hard)")


def add_arguments(parser):
    add_material_argument(parser)
    parser.add_argument("--speed", type=positive("m/s"), default=SPEED, help=f"MPM disk speed [m/s] (default {SPEED})")


def contact_radius(args) -> float:
    h, ppc, rp = resolution(args)
    return rp if rp is not None else h * ppc**-0.5


def build(args) -> CaseSetup:
    if not (math.isfinite(args.speed) and 0.0 < args.speed <= 20.0):
        raise InputError("--speed", args.speed, "an impact speed in (0, 20] m/s")
    h, ppc, _ = resolution(args)
    rp = contact_radius(args)
    # the MPM disk is centred on a grid node (the domain's corner is a whole number of cells away),
    # so its points are symmetric about the line of impact and nothing makes it turn
    n0 = math.ceil(RADIUS / h) + 4
    lo = (-n0 * h, -n0 * h)
    scene = Scene(domain=(lo, (n0 * h + 2 * RADIUS + 0.035, n0 * h)), cell_size=h,
                  boundaries=dict.fromkeys(("left", "right", "bottom", "top"), "free"), contact=contact_law())
    scene.add_mpm_body(disk(center=(0.0, 0.0), radius=RADIUS), table1_material(args.material), points_per_cell=ppc,
                   velocity=(args.speed, 0.0), contact_radius=rp, name="mpm_disk")
    # the DEM disk's outline starts APPROACH beyond the contact reach r_p of the front point
    front = float(scene.particles()["x"][:, 0].max())
    scene.add_rigid_body(sphero_disk(RADIUS), density=DENSITY, position=(front + rp + APPROACH + RADIUS, 0.0),
                         friction=FRICTION, name="dem_disk")
    # the exchange takes ~1.5 ms (hard) to ~4.3 ms (soft, slower waves; measured); the rest shows
    # the DEM disk coasting at its final speed (the domain has room for ~30 ms of it)
    end = APPROACH / args.speed + (3.0e-3 if args.material == "hard" else 6.0e-3)
    return CaseSetup(scene, end_time=round(end, 4), frames=100 if args.quick else 200)


def contact_window(t: np.ndarray, body_px: np.ndarray) -> tuple[float, float]:
    """(start of the first, end of the last) frame interval in which the DEM disk's momentum
    changed, i.e. the points pushed it; NaN without any. (The IMP count of a frame says less:
    the front points touch, leave and touch again within a frame.)"""
    on = np.flatnonzero(np.abs(np.diff(body_px)) > 1.0e-9 * np.abs(body_px).max())
    if len(on) == 0:
        return math.nan, math.nan
    return float(t[on[0]]), float(t[on[-1] + 1])


def summarize(sim, result, args) -> dict:
    d = result.diagnostics
    t = result.times
    body = sim.body_fields()
    e0 = float(d["energy_total"][0])
    ek0 = float(d["energy_kinetic"][0])
    rel = (d["energy_total"] - e0) / e0
    m_pts = float(d["points_mass"][0])
    m_body = float(d["bodies_mass"][0])
    v_pts = d["points_momentum_x"] / m_pts
    v_body = float(body["v"][0, 0])
    start, last = contact_window(t, d["bodies_momentum_x"])
    # energy left in the MPM disk: its kinetic energy beyond that of its centroid, plus strain
    internal = d["points_energy_kinetic"] - 0.5 * m_pts * (v_pts**2 + (d["points_momentum_y"] / m_pts) ** 2)
    internal = (internal + d["energy_strain"]) / e0
    e, nu = elastic_constants(args.material)
    h, ppc, _ = resolution(args)
    px0 = float(d["momentum_x"][0])
    return {
        "material": args.material,
        "youngs_modulus": e,
        "poisson_ratio": nu,
        "wave_speed": sim.scene.bodies[0].material.wave_speed,
        "cell_size": h,
        "points_per_cell": ppc,
        "contact_radius": contact_radius(args),
        "normal_stiffness": KN,
        "mass_ratio_mpm_over_dem": m_pts / m_body,
        "dem_speed_final": v_body,
        "dem_speed_paper": PAPER_SPEED[args.material],
        "dem_speed_over_impact_speed": v_body / args.speed,
        "mpm_centroid_speed_final": float(v_pts[-1]),
        # the paper's figure: the DEM disk's kinetic energy against all the energy brought in
        # (a perfectly elastic exchange between equal masses hands over all of it)
        "kinetic_energy_ratio": float(d["bodies_energy_kinetic"][-1] / ek0),
        "mpm_internal_energy_final_over_initial": float(internal[-1]),
        "energy_final_over_initial": float(d["energy_total"][-1] / e0),
        "energy_max_gain_relative": float(rel.max()),
        "contact_energy_max_over_initial": float(d["energy_contact_points"].max() / e0),
        "momentum_drift_relative": float(np.abs(d["momentum_x"] - px0).max() / abs(px0)),
        "work_imp_friction": float(d["work_imp_friction"][-1]),
        "work_imp_damping": float(d["work_imp_damping"][-1]),
        "contact_start": start,
        "contact_end": last,
        # pushed during the last frame interval: the exchange was not over at the end
        "contact_at_end": bool(last >= t[-1]),
        "dt": float(d["dt"][-1]),
    }


if __name__ == "__main__":
    from mpmdem.study.runner import run_case

    sys.exit(run_case(sys.modules[__name__], prog="python cases/momentum_exchange.py"))
