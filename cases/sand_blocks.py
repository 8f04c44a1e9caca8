# Block impact: "MPM-SDEM" §6 (validation), Table 3, after the flume experiment of Liu, Sun & Zhou
# (2018; the paper's ref. 25), on the experiment's geometry as an open-source reproduction of it
# gives it (side view, SI):
# * flume floor at y = 0, walls at x = 0 and x = 0.5 m, 0.3 m high;
# * a sand column x ∈ [0, 0.10] m, y ∈ [0, 0.20] m, at rest under gravity at t = 0 (no gate);
# * three wooden blocks, 20 mm wide × 18 mm tall, 500 kg/m³, stacked on the floor with their centres
#   at x = 0.31 m, y = 9, 27, 45 mm; the bottom one fixed ("glued"), the two above free.
# The paper reports, at g = 10 m/s² (its §6 times are printed ×10: its own discussion of the block-2
# angle and the reproduction's 0-0.5 s time axis fix the scale, see below): the sand reaches the
# blocks at about 0.25 s, block 2 (middle) touches the ground at about 0.40 s, block 1 (top) at
# about 0.45 s, and block 2's orientation falls from 90° (upright) to about 0° (on its side).
#
# What "lands" means. MPM-SDEM §6, Fig. 20's discussion, reads: "The block No.2 touches the ground
# after t = 4.0 seconds and block No.1 touches the ground after t = 4.5 seconds." The paper's word is
# *touches*: the validation rows use the first frame at which a block's lowest point reaches the
# floor (``block{1,2}_touch``), whatever face is down. The other reading, the block lying at rest
# on a face on the floor (``block{1,2}_rest``: on a face, on the floor, from that frame to the end
# of the run and for at least REST_FRAMES frames), is reported beside it (an earlier version used
# "lies on a face" for the rows, a definition chosen after the GPU times were known). Both come from
# ``readings()``, which the study analysis also applies to the committed tracks. Block 1 tumbles:
# its first touch and its final pose change with the grid and the start, so one run per grid says
# little; ``--ensemble-seed`` perturbs the start (the free blocks' x by up to ±0.5 mm, the sand
# lattice's points by up to a tenth of their spacing) for the ensemble study
# (`mpmdem study block-impact-ensemble`), whose median, spread and pose distribution are what the
# paper's single times are compared with.
#
# Gravity and time. Table 3 prints g = 10 cm/s², §6 says "g = 10 m/s". A lab-scale collapse scales
# with sqrt(L/g): at 10 cm/s² the same geometry runs 10 × slower, which is exactly the factor between
# §6's printed times (2.5, 4.0, 4.5 s) and those its discussion compares at (0.25, 0.40 s). We run
# at 10 m/s², the experiment's gravity, and compare with 0.25 / 0.40 / 0.45 s.
#
# Sand: Table 3 (mpmdem/study/references/table3.py) with §6's changes: g = 10 m/s², ψ = 0°, φ = 22°, about 8000
# points: the default grid 3.125 mm with 2 × 2 points per cell gives 32 × 64 cells, 8192 points
# (Table 3's 3.5 mm would not put the right wall on a grid line: 0.5 m = 142.9 cells).
#
# Friction (--friction): "paper", Table 3's μ = 0.2 for every contact (the paper's run), or
# "reproduction", the reproduction's values: block–block and block–floor 0.6, sand–block 0.55,
# sand–floor 0.16. The flume's side walls are frictionless grid walls for the sand (slip); the right
# wall is also a fixed spheropolygon, so a block pushed that far is stopped by it.
#
# Corner rounding (--sphero-radius): the paper's r_d = 0.5 cm is more than half the blocks' 18 mm
# height; we take 2 mm (a block stands on a flat face as the real one does) and show in the study
# that 1 mm and 3 mm give the same events.
#
# Departures from Table 3, and why (as in cases/silo_discharge.py):
# * k_n = 1e6 N/m per m (k_t = k_n / 20) instead of 6e8: the coupled step is bounded by the
#   lightest point on a contact spring; at 6e8 it is ~1e-6 s. At 1e6 a bottom point under the full
#   column carries ρ g H s ≈ 3000 Pa × 1.6 mm ≈ 4.7 N/m (overlap 4.7 µm ≪ r_p ≈ 2.2 mm); a block's
#   weight (1.8 N/m) sinks it 1.8 µm.
# * r_p: Table 3's 0.1 cm lies below eq. 45's lower bound (the point spacing); the library's
#   default h n^(-1/4) = h/√2 is used.
# * Δt: the library's step (CFL 0.4 and eq. 51 with the point term), not Table 3's 2e-4 s.
# * restitution 0.5 for the normal dashpot (the paper's law is elastic; damping not given).
# * Drucker–Prager matched with eq. 35, c = 0; ρ_cr = 0.99 ρ (Granular MPM: the loosened front
#   turns stress-free).
# * --quick (tests, CPU): grid 6.25 mm (2048 points), 0.6 s.
#
# What it gives (`mpmdem study block-impact` on an H200, bench/results/studies/, docs/studies/index.md,
# Table 3's friction, grids 6.25 / 3.125 / 2.5 mm): the sand reaches the blocks at 0.23 / 0.22 / 0.22
# s. Block 2 first touches the floor at 0.33 / 0.32 / 0.31 s (a corner, while it tips; paper 0.40
# s) and lies at rest on its side from 0.40 / 0.39 / 0.40 s. When block 2 strikes the floor, block 1
# is still 40-43 mm up: it does not ride block 2 down, it falls after it, tumbling. Its first touch
# is at 0.49 / 0.39 / 0.40 s (paper 0.45 s): at 3.125 mm the 0.39 s is one frame of the tumbling
# block passing face-down, and it comes to rest on a face at about 0.45 s; at 2.5 mm it touches for
# one frame at 0.40 s, then ends 4 mm up, inverted on the sand. Its final pose differs on all three
# grids (upright, on its side, inverted). No sand point ever ends a frame inside a block. --quick
# (CPU): reach 0.23 s, block 2 touches at 0.33 s and rests at 0.40 s, block 1 touches at 0.49 s.
#
# --sand dem (cases/_blocks_grains.py; issue 43): the sand column as free DEM sphero-disks of mean radius
# --grain-radius (default the seed's r_p = 1 mm; Liu, Sun & Zhou's sand size was not read here, so d
# is not matched to it), ±15 %, of the grain material the other cases share (mpmdem.sim.gated_grains:
# grain-grain μ = 0.5, e = 0.5; k_n and k_t as here) with ρ_s = ρ / 0.82 (the settled column has
# Table 3's bulk density). A pair's μ is the smaller of its two bodies' (the DEM's rule), so sand–block
# and sand–floor take the blocks' and the floor's μ of --friction where those are below 0.5 (Table 3's
# 0.2 everywhere: as the MPM run; the reproduction's set gives sand–floor 0.5, not 0.16, and
# sand–block 0.5, not 0.55). The grains are placed on a loose lattice over the column, trimmed to
# the lowest ones whose area is 0.82 × the column's (they settle to its height), settled behind a
# frictionless gate at x = 0.1 m (the flume's floor and walls, no blocks), then moved into the flume
# with the blocks at t = 0: the column starts at rest, as the MPM sand does (no gate). The left wall is
# frictionless, as the grid's slip wall; a frictionless lid closes the top (the grains never reach
# it). The summary has the MPM run's event fields, from the grains (the front: the farthest grain's
# edge).
"""Block impact (MPM-SDEM §6 on the experiment's geometry): a sand column topples two of three stacked blocks."""

import math
import sys

import numpy as np

from mpmdem import ContactLaw, DruckerPrager, InputError, Scene, rounded_rectangle
from mpmdem.cases import _blocks_grains
from mpmdem.cases._grain_flags import add_grain_arguments
from mpmdem.study.case import CaseSetup
from mpmdem.study.flag_types import count_at_least, given, non_negative, positive
from mpmdem.study.references.block_impact import ENSEMBLE_STARTS, T_PAPER, T_PAPER_PRINTED, first_time, readings
from mpmdem.study.references.table3 import GRAVITY, KN_TABLE, KT_TABLE, MU_TABLE, R_P_TABLE, VERLET, sand
from mpmdem.study.validation import Check

NAME = "sand-blocks"
DESCRIPTION = "block impact: a sand column topples two of three stacked wooden blocks (MPM-SDEM §6, the experiment)"
# Table 3: "MPM (APIC)"; quadratic B-splines keep APIC stable (the linear shape does not, see
# cases/column_collapse.py)
DEFAULTS = {"granular": True, "shape": "bspline2", "transfer": "APIC", "precision": "f32"}
#: `mpmdem validate`: the paper's three events at g = 10 m/s², given to 0.05 s (±0.025) with our
#: frames 0.01 s apart: ±0.035 s; also run on the grid twice as coarse, for the trend. The blocks'
#: events are the paper's "touches the ground" (the header): the first touch of the floor. Block 1
#: tumbles, so its row compares the median of ENSEMBLE_STARTS perturbed starts with the paper.
COARSER = (("--cell-size", "0.00625"),)
_FRAME = "the paper's 0.05 s reading resolution plus a frame"
_TRACKS = ("bench/results/studies/block-impact*: the committed runs at this grid (both friction sets, corner "
           "rounding 1-3 mm, imp and grid coupling), widened by a frame")
VALIDATION = [
    Check("event_times_s.reach", 0.25, "MPM-SDEM §6: the sand reaches the blocks", 0.035, _FRAME, relative=False,
          coarser=COARSER),
    Check("event_times_s.block2_touch", 0.40, "MPM-SDEM §6: block 2 touches the ground", 0.035, _FRAME,
          relative=False, known_gap="block 2's corner reaches the floor while it tips, before it comes to rest on "
          "its side (the other reading, which meets the paper's time)", gap_bounds=(-0.10, -0.06),
          gap_source=_TRACKS + ": first touch at 0.31-0.32 s (0.33 s at 6.25 mm, the quick grid)",
          quick_gap_bounds=(-0.10, -0.06), coarser=COARSER),
    Check("event_times_s.block1_touch", 0.45, "MPM-SDEM §6: block 1 touches the ground", 0.035, _FRAME,
          relative=False, known_gap="block 1 falls clear of block 2 and tumbles: its first touch is one frame of "
          "the tumbling block passing a face or corner over the floor, and changes with the grid and the start",
          gap_bounds=(-0.07, 0.05), gap_source=_TRACKS + ": first touch at 0.39-0.46 s (0.49 s at 6.25 mm, the "
                                                           "quick grid); single runs, before the ensemble",
          quick_gap_bounds=(-0.07, 0.05), starts=ENSEMBLE_STARTS),
]

# -- §6 --------------------------------------------------------------------------------------
FRICTION_ANGLE = 22.0  # deg
DILATANCY_ANGLE = 0.0  # deg

# -- the experiment's geometry (header) -------------------------------------------------------
FLUME = (0.5, 0.3)  # m, length × wall height
COLUMN = (0.10, 0.20)  # m, width × height
BLOCK = (0.020, 0.018)  # m, width × height of each block
BLOCK_X = 0.31  # m, centre of the stack
WOOD_DENSITY = 500.0  # kg/m³
BLOCK_NAMES = ("block1", "block2", "block3")  # top, middle, bottom (glued)
FRICTION_SETS = {
    # (block–block, block–floor, sand–block, sand–floor)
    "paper": {"block": MU_TABLE, "floor": MU_TABLE, "sand_block": MU_TABLE, "sand_floor": MU_TABLE},
    "reproduction": {"block": 0.6, "floor": 0.6, "sand_block": 0.55, "sand_floor": 0.16},
}

# -- our choices (header) ---------------------------------------------------------------------
GRID = 0.003125  # m: 32 × 64 cells of column, 8192 points; 160 cells along the flume
GRID_QUICK = 0.00625  # m
SPHERO = 0.002  # m
KN = 1.0e6  # N/m per m
KT = KN * KT_TABLE / KN_TABLE  # Table 3's ratio k_t / k_n = 1/20
RESTITUTION = 0.5
POINTS_PER_CELL = 2
SLAB = 0.02  # m, thickness of the floor slab and the right wall body
END_FULL = 0.6  # s: past the paper's 0.45 s
END_QUICK = 0.6  # s
PERTURB_BLOCK_X = 0.0005  # m: --ensemble-seed moves each free block by up to this along x
PERTURB_SAND = 0.1  # --ensemble-seed moves each sand point by up to this fraction of its spacing


def add_arguments(parser):
    parser.add_argument("--cell-size", type=positive("m"), default=None,
                        help=f"grid spacing [m] (default {GRID}, 8192 points; {GRID_QUICK} with --quick); 0.5 m "
                             "must be a whole number of cells")
    parser.add_argument("--friction", default="paper", choices=tuple(FRICTION_SETS),
                        help="paper: Table 3's 0.2 everywhere; reproduction: block 0.6, sand-block 0.55, sand-floor "
                             "0.16")
    parser.add_argument("--sphero-radius", type=non_negative("m"), default=SPHERO,
                        help=f"corner rounding of the blocks [m] (default {SPHERO})")
    parser.add_argument("--ensemble-seed", type=count_at_least(0), default=None,
                        help="perturb the start for an ensemble: the free blocks' x by up to "
                             f"±{1000 * PERTURB_BLOCK_X:g} mm, the sand points by up to {PERTURB_SAND:g} of their "
                             "spacing, from this seed (default: none, the experiment's start)")
    parser.add_argument("--normal-stiffness", type=positive("N/m per m"), default=KN,
                        help=f"k_n of every contact [N/m per m] (default {KN:g}; Table 3: {KN_TABLE:g}); k_t = k_n/20")
    add_grain_arguments(parser, what="the sand column", radius=R_P_TABLE, radius_note="the seed's r_p")


def _cell(args) -> float:
    return given(args.cell_size, GRID_QUICK if args.quick else GRID)


def _check(args):
    h = _cell(args)
    if not (math.isfinite(h) and 0.001 <= h <= 0.02):
        raise InputError("--cell-size", h, "a grid spacing in [0.001, 0.02] m")
    r = args.sphero_radius
    if not (math.isfinite(r) and 0.0 <= r < 0.5 * min(BLOCK)):
        raise InputError("--sphero-radius", r, f"a rounding in [0, {0.5 * min(BLOCK)}) m (half the blocks' height)")
    if not (math.isfinite(args.normal_stiffness) and args.normal_stiffness > 0.0):
        raise InputError("--normal-stiffness", args.normal_stiffness, "k_n > 0 [N/m per m]")
    if args.ensemble_seed is not None and args.ensemble_seed < 0:
        raise InputError("--ensemble-seed", args.ensemble_seed, "a seed ≥ 0")


def material() -> DruckerPrager:
    return sand(FRICTION_ANGLE, DILATANCY_ANGLE)


def block_positions(seed: int | None = None) -> dict[str, tuple[float, float]]:
    """Centres of the three blocks [m], stacked upright on the floor (y = 0). With ``seed``, the two
    free blocks move along x by independent uniform offsets of up to ±PERTURB_BLOCK_X (x only: a
    vertical offset would open a gap to fall through or press the blocks into each other)."""
    hb = BLOCK[1]
    dx = (0.0, 0.0) if seed is None else tuple(np.random.default_rng([seed, 1]).uniform(-1.0, 1.0, 2) * PERTURB_BLOCK_X)
    return {"block3": (BLOCK_X, 0.5 * hb), "block2": (BLOCK_X + dx[1], 1.5 * hb), "block1": (BLOCK_X + dx[0], 2.5 * hb)}


def sand_points(h: float, seed: int | None = None) -> np.ndarray:
    """The sand column's point centres [m]: a lattice of spacing s = h / POINTS_PER_CELL, lifted so the
    bottom row's contact reach (r_p) touches the floor. With ``seed``, each point moves by independent
    uniform offsets of up to PERTURB_SAND s along x and y (none below the lifted bottom row, none
    left of the wall)."""
    s = h / POINTS_PER_CELL
    rp = contact_radius(h)
    nx, ny = round(COLUMN[0] / s), round(COLUMN[1] / s)
    gx, gy = np.meshgrid(s * (np.arange(nx) + 0.5), s * (np.arange(ny) + 0.5), indexing="xy")
    lift = max(0.0, rp - 0.5 * s)
    x = np.stack([gx.ravel(), gy.ravel() + lift], axis=1)
    if seed is not None:
        x = x + np.random.default_rng([seed, 2]).uniform(-1.0, 1.0, x.shape) * PERTURB_SAND * s
        x[:, 0] = np.maximum(x[:, 0], 0.5 * s * (1.0 - PERTURB_SAND))
        x[:, 1] = np.maximum(x[:, 1], 0.5 * s + lift)
    return x


def contact_radius(h: float) -> float:
    return h * (POINTS_PER_CELL**2) ** -0.25  # eq. 45's geometric middle h n^(-1/4)


def costly_build(args) -> bool:
    """Whether ``build`` itself simulates (--sand dem settles the grains behind a gate): a study then
    groups these runs for batching without building them first (``mpmdem.study.batch_worker``)."""
    return getattr(args, "sand", "mpm") == "dem"


def build(args) -> CaseSetup:
    _check(args)
    if getattr(args, "sand", "mpm") == "dem":
        return _blocks_grains.build(args)
    h = _cell(args)
    s = h / POINTS_PER_CELL
    mu = FRICTION_SETS[args.friction]
    # the grid: x over the flume (both walls on grid lines), y from inside the floor slab; the top is
    # free (the sand never reaches 0.3 m), so it may end anywhere
    scene = Scene(domain=((0.0, -SLAB), FLUME), cell_size=h, gravity=(0.0, -GRAVITY),
                  boundaries={"left": "slip", "right": "slip", "bottom": "free", "top": "free"},
                  contact=ContactLaw(args.normal_stiffness, args.normal_stiffness * KT / KN, restitution=RESTITUTION))
    rp = contact_radius(h)
    sand_mat = material()
    # the bottom row would overlap the floor by r_p − s/2: sand_points lifts the column to touch it
    scene.add_points(sand_points(h, args.ensemble_seed), sand_mat, size=s, contact_radius=rp, name="sand")
    r = args.sphero_radius
    scene.add_rigid_body(rounded_rectangle(FLUME[0] + 2 * SLAB, SLAB, min(r, 0.4 * SLAB)), density=WOOD_DENSITY,
                         position=(0.5 * FLUME[0], -0.5 * SLAB), motion="fixed", friction=mu["floor"], name="floor")
    scene.add_rigid_body(rounded_rectangle(SLAB, FLUME[1], min(r, 0.4 * SLAB)), density=WOOD_DENSITY,
                         position=(FLUME[0] + 0.5 * SLAB, 0.5 * FLUME[1]), motion="fixed", friction=mu["floor"],
                         name="wall_right")
    for name, pos in block_positions(args.ensemble_seed).items():
        scene.add_rigid_body(rounded_rectangle(*BLOCK, r), density=WOOD_DENSITY, position=pos,
                             motion="fixed" if name == "block3" else "free", friction=mu["block"], name=name)
        scene.set_coupling_friction(sand_mat, name, mu["sand_block"])
    scene.set_coupling_friction(sand_mat, "floor", mu["sand_floor"])
    scene.set_coupling_friction(sand_mat, "wall_right", mu["sand_floor"])
    end = END_QUICK if args.quick else END_FULL
    # points that reach block 3's face gather in a thin layer along it (the contact holds each at
    # r_p from the face while the grid keeps bringing more): more than the default 16 in a cell
    return CaseSetup(scene, end_time=end, frames=round(end / 0.01),
                     config={"imp_skin": VERLET, "imp_cell_capacity": 64})


def block_penetration(x: np.ndarray, centre, angle: float, radius: float) -> float:
    """Deepest penetration [m] of point centres x (N, 2) into a rounded rectangle BLOCK at (centre,
    angle) with corner radius ``radius``: radius minus the distance to its core, where positive."""
    c, s = math.cos(angle), math.sin(angle)
    d = x - np.asarray(centre)
    # only points within the block's half diagonal plus its rounding of the centre can be inside it
    # (the others give radius − distance < 0): the rest are skipped, with a factor 2 to spare
    reach = math.hypot(*BLOCK) + radius
    d = d[(np.abs(d[:, 0]) <= reach) & (np.abs(d[:, 1]) <= reach)]
    local = np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]], axis=1)
    core = np.array([0.5 * BLOCK[0] - radius, 0.5 * BLOCK[1] - radius])
    q = np.abs(local) - core
    outside = np.linalg.norm(np.maximum(q, 0.0), axis=1)
    inside = np.minimum(np.max(q, axis=1), 0.0)
    dist = outside + inside  # signed distance to the core rectangle
    return float(max(0.0, (radius - dist).max(initial=-np.inf)))


def block_tracks(times: np.ndarray, bx: np.ndarray, ang: np.ndarray, idx: dict, r: float) -> dict:
    """The summary's per-block fields from the bodies' tracks (positions bx (frames, bodies, 2) [m],
    angles ang (frames, bodies) [rad], ``idx`` body name → index, corner rounding r [m]): the angle,
    orientation, position and lowest point of blocks 1 and 2 per frame, both readings of their landing
    (``readings``), when they first move, and how far block 3 (glued) moved and turned."""
    out = {}
    for n in ("block1", "block2"):
        i = idx[n]
        a = ang[:, i] - ang[0, i]
        deg = np.degrees(a)
        # lowest point of the rounded rectangle: centre height minus the half-extent along y
        core = np.array([0.5 * BLOCK[0] - r, 0.5 * BLOCK[1] - r])
        lowest = bx[:, i, 1] - (np.abs(np.sin(a)) * core[0] + np.abs(np.cos(a)) * core[1]) - r
        wrapped = (deg + 180.0) % 360.0 - 180.0
        out[f"{n}_angle_deg"] = deg.tolist()
        # the reproduction's convention: 90° upright, 0° on its side
        out[f"{n}_orientation_deg"] = (90.0 - np.abs(wrapped)).tolist()
        out[f"{n}_final_orientation_deg"] = float(90.0 - abs(wrapped[-1]))
        out[f"{n}_max_abs_angle_deg"] = float(np.abs(deg).max())
        out[f"{n}_x_m"] = bx[:, i, 0].tolist()
        out[f"{n}_y_m"] = bx[:, i, 1].tolist()
        out[f"{n}_lowest_point_m"] = lowest.tolist()
        # the two readings of "lands" (header): first touch of the floor, at rest on a face
        read = readings(times, lowest, deg)
        out[f"{n}_touch_time"] = read["touch"]
        out[f"{n}_rest_time"] = read["rest"]
        out[f"{n}_final_pose"] = read["pose"]
        out[f"{n}_move_time"] = first_time(times, np.hypot(*(bx[:, i] - bx[0, i]).T) > 1.0e-3)
    i3 = idx["block3"]
    out["block3_displacement_m"] = float(np.abs(bx[:, i3] - bx[0, i3]).max())
    out["block3_rotation_deg"] = float(np.degrees(np.abs(ang[:, i3] - ang[0, i3]).max()))
    return out


def summarize(sim, result, args) -> dict:
    if getattr(args, "sand", "mpm") == "dem":
        return _blocks_grains.summarize(sim, result, args)
    from mpmdem.io import RunFile

    with RunFile(result.path) as rf:
        times = rf.times
        names = [str(n) for n in rf.body_geometry()["name"]]
        bx = np.array([rf.body_field("x", k) for k in range(rf.frame_count)])
        ang = np.array([rf.body_field("angle", k) for k in range(rf.frame_count)])
        px = [np.asarray(rf.field("x", k), dtype=float) for k in range(rf.frame_count)]
        diag = rf.diagnostics
    idx = {n: names.index(n) for n in ("floor", *BLOCK_NAMES)}
    h = sim.scene.cell_size
    r = args.sphero_radius
    rp = contact_radius(h)
    pile_left = BLOCK_X - 0.5 * BLOCK[0]
    front = np.array([float(np.nanmax(x[:, 0])) for x in px])
    # the flow reaches the blocks when a point's contact reach (r_p) touches block 3's left face
    reach = first_time(times, front + rp >= pile_left)
    out = {
        "gravity": GRAVITY, "paper_times_printed_s": T_PAPER_PRINTED, "paper_times_s": T_PAPER,
        "cell_size": h, "points": int(sim.particle_count), "friction_set": args.friction, "sphero_radius": r,
        "normal_stiffness": float(args.normal_stiffness), "coupling": sim.config.coupling,
        "ensemble_seed": args.ensemble_seed,
        "block_start_x_m": {n: p[0] for n, p in block_positions(args.ensemble_seed).items()},
        "granular": sim.config.granular, "times": times.tolist(), "flow_front_x": front.tolist(),
        "reach_time": reach,
    }
    out.update(block_tracks(times, bx, ang, idx, r))
    # no sand point may end a frame inside a block
    deepest = 0.0
    for k, x in enumerate(px):
        x = x[np.isfinite(x[:, 0])]
        for n in BLOCK_NAMES:
            i = idx[n]
            deepest = max(deepest, block_penetration(x, bx[k, i], ang[k, i] - ang[0, i], r))
    out["deepest_penetration_m"] = deepest
    out["event_times_s"] = {"reach": reach, "block2_touch": out["block2_touch_time"],
                            "block1_touch": out["block1_touch_time"], "block2_rest": out["block2_rest_time"],
                            "block1_rest": out["block1_rest_time"]}
    out["event_errors_s"] = {k: (out["event_times_s"][k] - t) if out["event_times_s"][k] is not None else None
                             for k, t in T_PAPER.items()}
    known = [abs(v) for v in out["event_errors_s"].values() if v is not None]
    out["event_error_max_s"] = max(known) if len(known) == 3 else None
    mass = diag["points_mass"]
    out["mass_initial"] = float(mass[0])
    out["mass_max_relative_change"] = float(np.abs(mass / mass[0] - 1.0).max())
    released = float(diag["points_energy_gravity"][0] - diag["points_energy_gravity"].min())
    out["released_potential_energy"] = released
    wn = diag["work_numerical"]
    out["work_numerical_final"] = float(wn[-1])
    out["work_numerical_max"] = float(wn.max())
    out["energy_kinetic_final"] = float(diag["energy_kinetic"][-1])
    out["dt"] = float(diag["dt"][-1])
    return out


if __name__ == "__main__":
    from mpmdem.study.runner import run_case

    sys.exit(run_case(sys.modules[__name__], prog="python cases/sand_blocks.py"))
