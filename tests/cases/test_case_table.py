"""Every case's quick run and the figures its summary.json must hold, in one table (``CASE_CHECKS``).

Each row runs one case as a user would (``cases/<name>.py --quick`` on the CPU, ``helpers.run_script``)
and checks its summary against bounds, each with its reference: the analytic solution, the paper's
statement or value, or the margin of a stated measurement. What a bound cannot say (a file written, a
fit over the summary's series, a loop over a case's grids) is the row's ``extra`` check, in this module
too. The cases with many tests of their own over one shared quick run (sand blocks, column collapse,
silo filling and discharge: ``helpers.quick_run``, shared with ``mpmdem validate --quick``) keep their
modules; the validation rows are the cases' declared checks (tests/study/test_validation.py).
"""

from __future__ import annotations

import json
import math
import operator
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest
from helpers import ROOT, run_script

from mpmdem.io import RunFile

RHO_CR = 2235.0  # kg/m³, "Granular MPM" Tables 1 and 3 (slope flow, avalanche)


@dataclass(frozen=True)
class Key:
    """Another figure of the same summary as a bound: ``scale`` × summary[path] + ``offset``."""

    path: str
    scale: float = 1.0
    offset: float = 0.0


def _get(summary: dict, path: str):
    """summary[a][b]... for path "a/b/..."; an integer part indexes a list."""
    value = summary
    for part in path.split("/"):
        value = value[int(part)] if isinstance(value, list) else value[part]
    return value


_OPS: dict[str, Callable] = {"<": operator.lt, "<=": operator.le, ">": operator.gt, ">=": operator.ge,
                             "==": operator.eq}


@dataclass(frozen=True)
class Bound:
    """summary[key] ``op`` value, where the reference says why.

    op: one of ``<``, ``<=``, ``>``, ``>=``, ``==`` (value a number, a bool, a string or a ``Key``),
    ``approx`` (``pytest.approx(value, rel=, abs=)``), ``abs<`` (|summary[key]| < value), ``truthy``,
    ``falsy``, ``finite``, ``in`` (the key is in the summary)."""

    key: str
    op: str
    value: object = None
    reference: str = ""
    rel: float | None = None
    abs: float | None = None

    def verify(self, summary: dict) -> None:
        """Assert the bound on ``summary``; the message names the key, its value and the bound."""
        if self.op == "in":
            assert self.key in summary, f"{self.key} missing ({self.reference})"
            return
        got = _get(summary, self.key)
        want = self.value
        if isinstance(want, Key):
            want = want.scale * _get(summary, want.path) + want.offset
        if self.op == "approx":
            ok = got == pytest.approx(want, rel=self.rel, abs=self.abs)
        elif self.op == "abs<":
            ok = abs(got) < want
        elif self.op == "truthy":
            ok = bool(got)
        elif self.op == "falsy":
            ok = not got
        elif self.op == "finite":
            ok = math.isfinite(got)
        else:
            ok = _OPS[self.op](got, want)
        assert ok, f"{self.key} = {got!r}, want {self.op} {want!r} (rel {self.rel}, abs {self.abs}): {self.reference}"


def B(key: str, op: str, value: object = None, reference: str = "", **tol) -> Bound:
    """A ``Bound`` (short for the table)."""
    return Bound(key, op, value, reference, **tol)


COMPLETED = "the run ends at its end time"


@dataclass(frozen=True)
class CaseCheck:
    """One quick run of a case and what its summary must hold.

    Attributes:
        name: the row's test id.
        case: the module of ``cases/`` (underscores).
        argv: flags after ``--quick`` (``helpers.run_script``).
        bounds: the summary's figures and their bounds.
        extra: ``extra(summary, out)`` for what a bound cannot say (``out``: the run's folder).
    """

    name: str
    case: str
    argv: tuple[str, ...] = ()
    bounds: tuple[Bound, ...] = ()
    extra: Callable[[dict, Path], None] | None = field(default=None, compare=False)


# -- the extra checks ----------------------------------------------------------------------------------

def _sulsky_files(s: dict, out: Path) -> None:
    """The run file opens, holds the config and finite positions; the energy log and XDMF are written."""
    with RunFile(Path(s["output"])) as run:
        assert run.frame_count >= 2
        assert run.attrs["config"]["transfer"] == "APIC"
        x = run.field("x", -1)
        assert np.isfinite(x).all()
    assert (out / "energy.csv").read_text().startswith("time,")
    assert (out / "sulsky_disks.xdmf").exists()


def _disk_collision_spin(s: dict, out: Path) -> None:
    """Oblique with friction: both disks spin the same way at the same rate (the friction pair acts at
    the contact point, equal and opposite, and the disks are equal)."""
    w1, w2 = s["oblique_spin"]
    assert w1 == pytest.approx(w2, rel=1e-9) and abs(w1) > 1.0


def _pentagon_pile_file(s: dict, out: Path) -> None:
    """The run file holds the 60 pentagons and the three enclosures, the side walls as fixed bodies."""
    with RunFile(out / "pentagon_pile.h5") as rf:
        assert rf.body_count == 63 and rf.particle_count == 0
        geometry = rf.body_geometry()
        left = geometry["name"].index("wall_left")
        assert geometry["motion"][left] == 1  # the side enclosures are fixed bodies


def _domino_wave(s: dict, out: Path) -> None:
    """The blocks fall towards +x (clockwise: negative angles) one after the other and come to rest
    leaning on each other, the last flat on the floor; the steady wave speed over the second half of
    the row lies in [1.0, 2.0] √(g h).

    Reference: the steady domino-wave speed v = sqrt(g h) G(d/h) by dimensional analysis (McLachlan
    et al. 1983, SIAM Rev. 25, 403, as Efthimiou & Johnson 2007, SIAM Rev. 49, 111, eq. 1), G for
    blocks that topple without sliding and lean on each other after inelastic collisions (van Leeuwen
    2010, Am. J. Phys. 78, 721). Read (issue 45): of van Leeuwen 2010 and its 2004 preprint
    (physics/0401018) the abstract and introduction only (their assumptions, not their figures); of
    van Leeuwen 2013 (arXiv:1301.0615) the introduction: a train of real dominoes runs at about a
    metre per second (for a 4-5 cm domino sqrt(g h) ≈ 0.66 m/s, our assumption: G ≈ 1.5). The band is
    that figure's order of magnitude, a factor 2 around it, set before the run: it rejects the
    transient (0.45-0.97 over the first five blocks) and a gravity or time-unit slip (a factor
    sqrt(10) or more); friction (μ = 0.4) and e = 0.3 slow the wave, so its low half is expected.
    Measured: 1.12. 12 blocks so the front reaches its steady speed (the push accelerates it over ~6
    blocks); 180 frames (10 ms) resolve a tip time to 1/9 of the steady interval."""
    assert all(a < -45.0 for a in s["final_angles_deg"])
    assert s["final_angles_deg"][-1] == pytest.approx(-90.0, abs=1.0)
    assert all(b > a for a, b in zip(s["tip_times"], s["tip_times"][1:], strict=False))
    pitch = 0.5 * 0.2  # m, the case's default spacing/height 0.5 × h = 0.2 m
    t = np.array(s["tip_times"][6:])
    x = pitch * np.arange(6, 6 + len(t))
    steady = np.polyfit(t, x, 1)[0] / math.sqrt(9.81 * 0.2)
    assert 1.0 <= steady <= 2.0, steady


def _slope_flow_variants(s: dict, out: Path) -> None:
    """The plot is written; the variants are runs of their own (mpmdem.study.variants), each in its
    folder, plain MPM without density control; the granular one is the case's own run, not rerun."""
    assert (out / "slope_flow.png").is_file()
    for name in ("original", "stress_free"):
        v = json.loads((out / name / "summary.json").read_text())
        assert v["variant"] == name and v["status"] == "completed" and Path(v["output"]).is_file()
        assert v["config"]["granular"] is False and v["config"]["density_control"] == "none"
    assert not (out / "granular").exists()


def _disconnection_plot(s: dict, out: Path) -> None:
    """The plot of point 3's motion is written."""
    assert (out / "point3.png").is_file()


def _normal_force_grids(s: dict, out: Path) -> None:
    """Each of the four grids of MPM-SDEM §5.2.1 (0.35-0.5 cm) carries the weight through the bottom
    row of points."""
    assert sorted(s["grids"]) == ["0", "1", "2", "3"]
    for i, g in s["grids"].items():
        assert g["grid_cm"] == pytest.approx(0.35 + 0.05 * int(i), rel=1e-12)
        assert not g["last_step_idle"]  # the forces read are those of a real step
        # eq. 45's lower bound is the point spacing (0.196 cm) on every grid: the paper's r_p = 0.1 cm
        # is outside it, the case's 0.25 cm inside
        lo, hi = g["eq45_interval_cm"]
        assert not g["paper_contact_radius_in_eq45"] and lo < g["contact_radius_cm"] < hi
        # Statics: the settled floor load is the weight whatever k_n or the grid. The quick run's damped
        # vibration leaves < 2e-4 of it at the end (measured 0.8-1.3e-5 on all four grids); 0.5 % at
        # the last step, and the paper's 2 % over the last quarter of the frames (Fig. 12 converged).
        assert g["normal_over_weight"] == pytest.approx(1.0, abs=0.005), i
        assert g["normal_late_max_deviation"] < 0.02, i
        # action = reaction: the floor's load is minus the sum of the point forces of the same step
        assert g["contact_sum_over_weight"] == pytest.approx(g["normal_over_weight"], rel=1e-9)
        # the bottom row, and only it, is in contact (the next row is a spacing farther than r_p)
        assert g["points_touching"] == 51 and g["only_bottom_row_touching"], i
        # Equal shares: not exactly. The base friction (μ = 0.1, at its cap near the ends) restrains the
        # block's Poisson spreading, so the 2-3 end points carry up to 14-19 % more (as at the corners
        # of a bonded elastic block), and MPM's free-edge error bows the rest by ~2 % (a pure-MPM block
        # on a slip floor, no coupling, shows a like bow in its bottom σ_yy). Measured: spread
        # 3.4-3.9 %, interior (3 end points left out) within 2.1 %; the bounds leave ~1.5x room.
        assert g["bottom_load_spread_relative"] < 0.06, i
        assert g["bottom_load_interior_max_deviation_relative"] < 0.03, i
        assert g["bottom_load_max_deviation_relative"] < 0.3, i


# -- the table -----------------------------------------------------------------------------------------

_DENSITY_STEP = ("density control returns F when ρ < ρ_cr, so the mean stays at ρ_cr to within one step's "
                 "change (ρ |tr L| dt ~ 2235 × 10 /s × 7e-6 s ~ 0.2 kg/m³ a point; 1 kg/m³ margin)")

CASE_CHECKS: list[CaseCheck] = [
    # -- MPM, analytic references ---------------------------------------------------------------------
    CaseCheck("axial_bar_matches_analytic_first_mode", "axial_bar", (), (
        B("status", "==", "completed", COMPLETED),
        # the bar's centre-of-mass velocity follows (2 v0/π) cos(ωt) over one period
        B("centre_velocity_error_max", "<", 0.02,
          "16 cells, quadratic B-splines, APIC/USL: the O(h²) spatial error of the discrete mode (measured "
          "0.7 %; 0.19 % at 32 cells, bench/convergence.py); 2 % leaves room for f64 platform differences "
          "but fails on a first-order defect (7-12 % before the wall image points)"),
    )),
    CaseCheck("elastic_column_matches_static_stress", "elastic_column", (), (
        # σ_yy = −ρ g (H − y) after gravity is ramped on over whole periods
        B("stress_error_rms", "<", 0.03,
          "8 cells over the height: the interpolation error of a linear field sampled by points near the free "
          "top and the fixed base (measured 0.9 % of ρgH); a residual oscillation or a wrong base gives ≥ 10 %"),
        B("stress_error_max", "<", 0.06, "as the rms error, its largest point"),
        B("base_stress", "approx", Key("base_stress_exact"), "ρ g H at the base", rel=0.05),
    )),
    CaseCheck("sulsky_disks_rebound_and_conserve_momentum", "sulsky_disks", (), (
        B("rebounded", "truthy", None, "the disks collide and part (Sulsky et al. 1995 §7.3)"),
        B("momentum_drift_relative", "<", 1e-5,
          "f32: Σ m v of ~250 points summed each frame; round-off ~1e-7 relative a step"),
        B("total_energy_final_over_initial", "<=", 1.0 + 1e-5,
          "the elastic collision conserves energy (\"MPM notes\", Sulsky et al. 1995 §7.3); an explicit "
          "APIC + USL step may lose energy, never create it (up to f32 round-off of the sums, 1e-5)"),
    ), _sulsky_files),
    # -- "Motion integration" §4.1-4.2, appendix B -----------------------------------------------------
    CaseCheck("bouncing_disk_flip_usf_rebounds_to_drop_height", "bouncing_disk",
              ("--transfer", "FLIP", "--update", "USF"), (
        B("status", "==", "completed", COMPLETED),
        B("drop_height", "approx", 0.5, "the case's drop height", abs=1e-3),
        B("contact_times/0", ">", 0.25,
          "free fall: the floor reaches the disk's bottom at sqrt(2 (H − R)/g) = 0.286 s; the grid feels "
          "the floor ~1.5 cells (14 ms at 2.8 m/s) earlier, and a contact is dated by the start of its 7 ms "
          "frame interval (measured 0.271 s)"),
        B("contact_times/0", "<", 0.29, "as above"),
        B("rebound_ratio_first", ">", 0.93,
          "walls as in \"Motion integration\" eq. 28 (V and Ṽ constrained at wall nodes): measured 0.968; "
          "0.93 separates FLIP/USF from APIC (0.87-0.89) and PIC (0.66-0.70), the ordering of §4.1 (with "
          "the wall impulse kept in FLIP's Ṽ − V it measured 0.864: FLIP then loses energy like PIC)"),
        B("rebound_ratio_first", "<", 1.03, "no more than the drop height, with FLIP's slight gain"),
        B("energy_total_final_over_initial", ">", 0.97,
          "FLIP + USF slightly gains energy, as in §4.1 (measured 1.012, range 0.996-1.024)"),
        B("energy_total_final_over_initial", "<", 1.05, "as above"),
        B("energy_min_over_initial", ">", 0.97, "as above"),
        B("energy_max_over_initial", "<", 1.05, "as above"),
    )),
    CaseCheck("bouncing_disk_pic_usl_dissipates", "bouncing_disk", ("--transfer", "PIC", "--update", "USL"), (
        B("status", "==", "completed", COMPLETED),
        B("rebound_ratio_first", "<", 0.8,
          "PIC damping loses ~30 % in the impact (measured rebound 0.657, final energy 0.725)"),
        B("energy_total_final_over_initial", "<", 0.85, "as above"),
        B("energy_max_over_initial", "<", 1.0 + 1e-6, "PIC never creates energy (measured maximum 1 to round-off)"),
    )),
    CaseCheck("rotating_disk_apic_keeps_angular_momentum", "rotating_disk",
              ("--transfer", "APIC", "--update", "USL"), (
        B("status", "==", "completed", COMPLETED),
        B("omega_initial", "approx", 2.0 * math.pi, "the case's spin, one turn a second", rel=1e-9),
        B("angular_momentum_final_over_initial", "approx", 1.0,
          "APIC is exact for the rigid rotation up to O((ω dt)²) (measured 1.0000045 after 0.5 s, f64): 1e-3 "
          "is 200× the drift and 10× tighter than the 0.99 that rejects FLIP (0.943)", abs=1e-3),
        B("angular_momentum_min_over_initial", ">", 0.999, "as above (measured 0.9999994)"),
        B("omega_final", "approx", Key("omega_set"),
          "ω = L/I: measured 6.2826 vs 6.2832 (I grows ~1e-4 from the centrifugal strain)", rel=2e-3),
        B("rotation_angle_final", "approx", Key("rotation_angle_rigid"),
          "the points turned with the disk: measured π − 3e-4 rad vs ω t = π", rel=5e-3),
        B("kinetic_energy_final_over_initial", "approx", 1.0, "measured 0.99991", abs=2e-3),
    )),
    CaseCheck("rotating_disk_pic_loses_rotation_at_once", "rotating_disk", ("--transfer", "PIC", "--update", "USL"), (
        B("status", "==", "completed", COMPLETED),
        B("angular_momentum_first_frame_over_initial", "<", 0.1,
          "appendix B.2: PIC damps the rigid field at a rate ~1/(few steps) (measured 1.4 % of L0 after the "
          "first 0.02 s, ~2e-7 at 0.5 s)"),
        B("angular_momentum_final_over_initial", "abs<", 0.01, "as above"),
        B("kinetic_energy_final_over_initial", "<", 1e-3, "as above (measured 8e-14)"),
    )),
    # -- "Granular MPM" §2.3, §4.1, §4.2 ------------------------------------------------------------------
    CaseCheck("slope_flow_density", "slope_flow", (), (
        B("granular/status", "==", "completed", COMPLETED),
        B("original/status", "==", "completed", COMPLETED),
        B("stress_free/status", "==", "completed", COMPLETED),
        B("granular/mean_density_min", ">", RHO_CR - 1.0, _DENSITY_STEP),
        B("original/mean_density_end", "<", RHO_CR - 1.0,
          "§2.3 Fig. 2: original and stress-free MPM lose density as the material flows, below ρ_cr already "
          "at the quick run's end (0.05 s)"),
        B("stress_free/mean_density_end", "<", RHO_CR - 1.0, "as above"),
    ), _slope_flow_variants),
    CaseCheck("avalanche_density_and_packing", "avalanche", (), (
        B("granular/status", "==", "completed", COMPLETED),
        B("original/status", "==", "completed", COMPLETED),
        B("stress_free/status", "==", "completed", COMPLETED),
        B("granular/mean_density_min", ">", RHO_CR - 1.0, _DENSITY_STEP),
        B("original/mean_density_end", "<", Key("granular/mean_density_end", offset=-50.0),
          "§4.2 Fig. 10: by 0.4 s the front of the original and stress-free runs has stretched by several per "
          "cent; 50 kg/m³ is 2 % and well clear of round-off"),
        B("stress_free/mean_density_end", "<", Key("granular/mean_density_end", offset=-50.0), "as above"),
        B("granular/density_spread_end", "<", Key("original/density_spread_end", scale=0.1),
          "Figs. 11-12: the original run's packing is uneven where Granular MPM's stays uniform"),
    )),
    CaseCheck("disconnection_1d_case", "disconnection_1d", (), (
        # §4.1 as the paper sketches it (positions reconstructed so that its two events fall at 3.92 and
        # 6.7 ms: inputs here, not results); dt = 2e-5 s, the case's step
        B("stress_free_original/onsets_s/0", "<=", 2.0e-5,
          "stress-free MPM lets point 3 feel point 2 at once through their common node"),
        B("granular_displacement_difference_before_onset_m", "<", 1e-12,
          "Granular original MPM and cpGIMP move point 3 identically until the domains touch"),
        B("granular_onset_s", "approx", Key("domains_touch_s"),
          "point 3 reacts only when the domains of interaction touch (one step's margin)", abs=1.01 * 2.0e-5),
        B("stress_free_onset_s", "approx", Key("node_sharing_s"),
          "stress-free MPM: when the points share a node (one step's margin)", abs=1.01 * 2.0e-5),
        B("granular_cpgimp/onsets_s/0", "approx", Key("granular_onset_s"),
          "§4.1: the start of interaction does not depend on the shape function", abs=1.01 * 2.0e-5),
    ), _disconnection_plot),
    # -- DEM ------------------------------------------------------------------------------------------------
    CaseCheck("disk_collision_case", "disk_collision", (), (
        B("status", "==", "completed", COMPLETED),
        B("bodies", "==", 4, "two pairs of disks"),
        B("restitution_head_on", "approx", Key("restitution_set"),
          "head-on: e of the spring-dashpot; κ2 = 0.002 puts ~70 steps in a contact, the leapfrog error "
          "O((ω dt)²) is ~1e-3 (measured 0.14 %)", rel=0.005),
        B("work_friction", "<", 0.0, "friction dissipates"),
        B("momentum_drift_relative", "<", 1e-12, "momenta: f64 round-off"),
        B("angular_momentum_drift_relative", "<", 1e-12, "as above"),
        B("energy_balance_residual", "abs<", 1e-3, "the energy balance closes to O((ω dt)²)"),
    ), _disk_collision_spin),
    CaseCheck("block_on_incline_case-30.0-0.3-True", "block_on_incline", ("--angle", "30.0", "--friction", "0.3"), (
        B("sliding_expected", "==", True, "tan 30° > 0.3"),
        B("acceleration", "approx", Key("acceleration_expected"),
          "steady Coulomb sliding: a = g (sin θ − μ cos θ), fitted over the frames after the contact settled "
          "(measured error 1e-12)", rel=0.005),
    )),
    CaseCheck("block_on_incline_case-15.0-0.4-False", "block_on_incline", ("--angle", "15.0", "--friction", "0.4"), (
        B("sliding_expected", "==", False, "tan 15° < 0.4"),
        B("sticks", "truthy", None, "static friction holds the block"),
        B("travel_final", "abs<", 1e-5, "as above"),
    )),
    CaseCheck("pentagon_pile_case", "pentagon_pile", (), (
        B("status", "==", "completed", COMPLETED),
        B("bodies", "==", 60, "the case's pentagons"),
        B("kinetic_over_released", "<", 1e-4,
          "settled: kinetic energy a vanishing part of the released potential energy"),
        B("dissipated_over_released", ">", 0.9,
          "most of it went into damping and friction, the rest the O((ω dt)²) leapfrog residual (measured 2 %)"),
        B("dissipated_over_released", "<", 1.05, "as above"),
        B("energy_balance_residual", "abs<", 0.05, "as above"),
        B("solid_fraction_lower_half", ">", 0.5431 - 0.0022,
          "a pile whose bodies rest on each other is denser than the saturated random sequential adsorption "
          "deposit of regular pentagons, 0.5431 ± 0.0022 (Shubin 2025, Russ. Metall./Rasplavy no. 1, 10-23, "
          "DOI 10.31857/S0235010625010025); tolerance its scatter (measured 0.754)"),
        B("solid_fraction_lower_half", "<", 0.8381 + 0.0020,
          "and no denser than their random close packing, 0.8381 ± 0.0020 (ibid.), unless it orders"),
        B("contacts_per_body", ">", 2.0, "about 3-4 contacts a body at rest (isostatic frictional packs: 3)"),
        B("contacts_per_body", "<", 5.0, "as above"),
        B("list_rebuilds", ">=", 10, "the pile moves: the Verlet lists are rebuilt"),
        B("steps_per_rebuild", ">", 5, "but not every step (the skin)"),
    ), _pentagon_pile_file),
    CaseCheck("domino_case", "domino", ("--blocks", "12", "--frames", "180", "--end-time", "1.8"), (
        B("all_toppled", "truthy", None, "the whole row falls"),
        B("toppled", "==", Key("blocks"), "as above"),
        B("blocks", "==", 12, "the row asked for"),
        B("front_speed", "finite", None, "the case's own front speed is a number"),
    ), _domino_wave),
    # -- coupling, MPM-SDEM §5.2 ----------------------------------------------------------------------------
    # The paper's 25 N/m, 0.4902 N a bottom point (§5.2.1) and μ W = 7.5 N (§5.2.2) are the case's inputs
    # multiplied out: not asserted. What is: the floor load against the weight, friction against μ × load.
    CaseCheck("normal_force_on_all_four_grids", "normal_force", ("--all-grids",), (
        B("status", "==", "completed", COMPLETED),
        B("poisson_ratio", "approx", Key("poisson_ratio_table"),
          "E, ν from Table 2's K and G by the 3D relations give back its ν = 0.2558 (to its 4 digits)", abs=5e-5),
    ), _normal_force_grids),
    CaseCheck("friction_force_sliding_block", "friction_force", (), (
        B("status", "==", "completed", COMPLETED),
        B("last_step_idle", "falsy", None, "the forces read are those of a real step"),
        B("grid_cm", "approx", 0.5, "the paper's grid of Fig. 14", rel=1e-12),
        B("block_speed_final", ">", 1.9, "still sliding, decelerating from 2 m/s: every contact on the Coulomb cap"),
        B("block_speed_final", "<", 2.0, "as above"),
        B("bottom_row_speed_min", ">", 1.9, "as above"),
        B("cap_ratio_min", ">", 0.99,
          "each touching point: −f_x = μ f_y; f_y also holds the normal dashpot term (measured 0.9992-1.00002)"),
        B("cap_ratio_min", "<=", Key("cap_ratio_max"), "as above"),
        B("cap_ratio_max", "<", 1.01, "as above"),
        B("friction_over_mu_normal", "approx", 1.0, "the total (measured 9e-6)", abs=1e-3),
        B("friction_over_mu_weight", "approx", 1.0,
          "Coulomb sliding on a level floor, F = μ N, N = W (MPM-SDEM §5.2.2, Fig. 14); 2 %: N differs from W "
          "by the block's vertical inertia and the settling as the slide starts (measured N = 0.9986 W), the "
          "normal-force case's late bound (Fig. 12); measured 0.14 %", abs=0.02),
        B("friction_late_max_deviation", "<", 0.02, "as above"),
        B("floor_force_over_mu_weight", "approx", Key("friction_over_mu_weight"), "action = reaction", rel=1e-9),
        B("only_bottom_row_touching", "truthy", None, "the bottom row alone touches"),
        B("points_touching", ">=", 45, "as above"),
        B("load_eccentricity", "approx", Key("load_eccentricity_expected"),
          "friction at the base, a lever (H − spacing)/2 below the centroid, puts the normal resultant "
          "e = μ × lever = 1.47 cm ahead of the centroid (measured +0.5 %)", rel=0.05),
        B("moment_residual_relative", "abs<", 0.02, "the contact forces' moment about the centroid vanishes (0.5 %)"),
        B("bottom_friction_spread_relative", "finite", None, "reported"),
    )),
]


@pytest.mark.parametrize("check", CASE_CHECKS, ids=[c.name for c in CASE_CHECKS])
def test_case_quick_run(check: CaseCheck, tmp_path):
    """Verify a case's quick run: every bound of its row, then its extra check."""
    s = run_script(check.case, tmp_path, *check.argv)
    for bound in check.bounds:
        bound.verify(s)
    if check.extra is not None:
        check.extra(s, tmp_path)


def test_the_table_names_each_row_once_and_each_case_exists():
    """Verify the rows' ids are unique and every case module exists."""
    names = [c.name for c in CASE_CHECKS]
    assert len(names) == len(set(names))
    cases = ROOT / "cases"
    for c in CASE_CHECKS:
        assert (cases / f"{c.case}.py").is_file(), c.case


def test_a_bound_fails_with_its_reference():
    """Verify a bound that does not hold raises with the key, the value and the reference."""
    with pytest.raises(AssertionError, match="x = 2.*the reference"):
        B("x", "<", Key("y", scale=0.5), "the reference").verify({"x": 2, "y": 2})
    B("a/1", "approx", 1.0, "", rel=1e-3).verify({"a": [0, 1.0005]})
