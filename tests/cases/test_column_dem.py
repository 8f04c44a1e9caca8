"""cases/column_collapse.py --sand dem: the column as DEM grains (r = 1 mm, ±15 %) at a quick size, a = 1,
L0 = 4 cm (20 grain diameters, 418 grains settled behind a gate first), about 7 s on 2 CPU cores; and
the deposit readings of mpmdem.study.grain_deposit against deposits of known shape."""

import math

import numpy as np
import pytest
from helpers import quick_run, run_refused

from mpmdem.cases import column_collapse as cc
from mpmdem.model.grains import place_grains
from mpmdem.sim.gated_grains import grain_density, lowest_grains
from mpmdem.study.grain_deposit import connected_front, flank_angle, surface_profile

QUICK = ("--sand", "dem", "--aspect-ratio", "1", "--width", "0.04", "--grain-radius", "0.001")


@pytest.fixture(scope="module")
def quick():
    return quick_run("column_collapse", *QUICK)[0]


def test_the_settled_column_is_a_random_close_packing(quick):
    """The column settled behind the gate, at rest: its packing fraction (``mpmdem.sim.packing``'s window,
    3 diameters off the walls, floor and top) is a 2D random close packing of disks, φ = 0.82 ±
    0.02 (Berryman 1983, Phys. Rev. A 27, 1053), widened by ±0.01 for a window of ~150 grains (the
    seed-to-seed scatter of tests/model/test_grains.py's 400-grain window is 0.002; a crystallised pack
    gives up to 0.907, the lattice it starts from ~0.65); its bulk density φ ρ_s is then the
    continuum's 1550 kg/m³ (ρ_s = 1550 / 0.82) to the same 3 %; its mean coordination number lies
    between the isostatic counts of 2D frictional and frictionless disks, 3 and 4 (van Hecke 2010,
    J. Phys.: Condens. Matter 22, 033101), less a few rattlers (down to 2.7); and the trimmed
    lattice settles to the column's height a L0 within 2 grain diameters (0.1 L0)."""
    s = quick["settled"]
    assert quick["status"] == "completed" and quick["sand"] == "dem"
    assert s["rms_speed"] < 0.01 * math.sqrt(9.81 * 1e-3)
    assert s["window_grains"] > 100
    assert 0.79 <= s["packing_fraction"] <= 0.85
    assert s["bulk_density"] == pytest.approx(cc.DENSITY, rel=0.035)
    assert s["bulk_density"] == pytest.approx(s["packing_fraction"] * grain_density(cc.DENSITY), rel=1e-12)
    assert 2.7 <= s["coordination"] <= 4.0
    assert quick["settled_aspect_ratio"] == pytest.approx(1.0, abs=0.1)


def test_the_grains_keep_their_mass_and_stay_in_the_box(quick):
    """Every grain is counted at every frame (the 'all' mass probe sums them on the device: f32 round-off),
    none reaches the far wall, and the three fronts are ordered: the mass-based front and the
    connected front within 2 grain diameters of each other (on a deposit without holes they read
    the same edge), both at or inside the farthest grain."""
    assert quick["mass_change_relative"] < 1e-6
    assert not quick["reached_far_wall"]
    d = quick["grain_diameter_mean_m"]
    assert abs(quick["runout_m"] - quick["runout_connected_m"]) <= 2.0 * d
    assert max(quick["runout_m"], quick["runout_connected_m"]) <= quick["runout_farthest_point_m"] + 1e-12
    assert quick["stop_time_s"] is not None and quick["stop_time_s"] < quick["end_time"]


def test_the_column_spreads_at_least_as_far_as_its_own_flank_allows(quick):
    """The deposit holds the column's area L0 H0 (grains keep their mass; a pack at rest is no denser
    than the settled column), under a surface no higher than H0 and under the line of slope tan θ
    that ends at the front, θ the steepest secant from the deposit's surface to its front (measured
    on the deposit: the fitted flank angle is a mean, and a deposit steeper near the wall than on its
    flank can lie above the flank's line): the largest area under such a surface with its front at
    L_f is H0 L_f − H0² / (2 tan θ), so L_f − L0 ≥ H0 / (2 tan θ). One grain diameter of slack for the
    front's reading. A column that stood or stopped short with a steep face fails it."""
    a = quick["settled_aspect_ratio"]
    theta = math.radians(quick["surface_secant_angle_deg"])
    slack = quick["grain_diameter_mean_m"] / quick["initial_width_m"]
    assert quick["normalized_runout"] >= a / (2.0 * math.tan(theta)) - slack


@pytest.mark.xfail(strict=True, reason="(L_f - L0)/L0 = 2.29 at a = 1 (L0 = 20 d, seed 1; 1.9-2.3 over "
                   "seeds) against Lube et al.'s 1.2-1.6: sphero-disks without rolling resistance run out past "
                   "sand (their angle of repose is 18.3 +- 0.4 deg, bench/results/studies/grain-calibration, against a "
                   "sand's ~30 deg)")
def test_the_runout_is_in_the_experiments_band(quick):
    low, high = cc.runout_band(1.0)
    assert low <= quick["normalized_runout"] <= high


@pytest.mark.xfail(strict=True, reason="H_f/L0 = 0.76 at a = 1 (the settled column 1.03 L0): the disks' top "
                   "falls where Lube et al. find that a column with a <= 1.15 keeps its top")
def test_the_top_of_a_short_column_stays(quick):
    d = quick["grain_diameter_mean_m"] / quick["initial_width_m"]
    assert quick["normalized_final_height"] >= quick["settled_aspect_ratio"] - 2.0 * d


def test_connected_front_leaves_out_a_thrown_grain():
    """Touching grains of radius 1 mm from the wall to x = 0.3 m, then one at 0.6 m: the front is the
    last touching grain's edge, 0.3 m; the thrown grain's gap (0.3 m) is far above 2 diameters."""
    r = 1e-3
    x = np.column_stack([np.r_[np.arange(r, 0.3, 2 * r), 0.6], np.full(151, r)])
    radius = np.full(len(x), r)
    assert connected_front(x, radius, 0.0, 4 * r) == pytest.approx(0.3, abs=1e-9)
    assert connected_front(x, radius, 0.0, 0.4) == pytest.approx(0.6 + r)


@pytest.mark.parametrize("angle", [15.0, 30.0])
def test_flank_angle_reads_a_wedge(angle):
    """Grains placed under a plateau 5 cm high to x = 5 cm, then a straight flank at ``angle`` down to
    the floor (a deposit of known shape): the fitted flank angle is the wedge's to 1° (the profile
    follows the line to a grain diameter, 2 mm, over a flank 9-19 cm long: atan(2/90) = 1.3° at the
    worst, and the fit averages the lattice's steps), and its standard error is below 1°."""
    h, x1 = 0.05, 0.05
    run = h / math.tan(math.radians(angle))
    surface = [(0.0, 0.0), (x1 + run, 0.0), (x1, h), (0.0, h)]
    g = place_grains(surface, radius=1e-3, density=2000.0, seed=1)
    centres, top = surface_profile(g.position, g.bounding_radius, 0.0, 4e-3)
    got = flank_angle(centres, top)
    assert got["angle_deg"] == pytest.approx(angle, abs=1.0)
    assert got["angle_stderr_deg"] < 1.0 and got["bins"] >= 5


def test_lowest_grains_fill_the_area_from_the_bottom():
    """``lowest_grains`` keeps the lowest grains up to an area: their areas add up to it within one
    grain, and none kept lies above one left out."""
    g = place_grains([(0.0, 0.0), (0.05, 0.0), (0.05, 0.05), (0.0, 0.05)], radius=1e-3, density=2000.0, seed=2)
    kept = lowest_grains(g, 0.3 * g.total_area)
    assert 0.3 * g.total_area - kept.area.max() <= kept.total_area <= 0.3 * g.total_area
    left = np.setdiff1d(g.position[:, 1], kept.position[:, 1])
    assert kept.position[:, 1].max() <= left.min()


@pytest.mark.parametrize(("flags", "name"), [
    (("--sand", "dem", "--grain-radius", "0.015"), "--grain-radius"),  # L0/20 = 1 cm at most with 0.2 m
    (("--sand", "dem", "--floor", "fixed"), "--floor"),
    (("--floor", "rough"), "--floor"),  # glued grains are a DEM floor
    (("--friction-angle", "75"), "--friction-angle"),  # (0, 60) deg
])
def test_bad_dem_flags_are_one_line(tmp_path, flags, name):
    code, lines = run_refused("column_collapse", tmp_path, *flags)
    assert code == 2 and len(lines) == 1 and name in lines[0]


LEDGE = ("--sand", "dem", "--floor", "ledge", "--aspect-ratio", "0.3", "--width", "0.06", "--grain-radius", "0.001")


@pytest.fixture(scope="module")
def heap():
    return quick_run("column_collapse", *LEDGE)[0]


def test_the_heap_on_a_ledge_keeps_its_top_and_a_trapezoid(heap):
    """--floor ledge (the angle of repose by discharge): a column a = 0.3 (9 grains tall) whose floor ends
    at the gate. Grains slide off the ledge until the slope from the ledge's edge stands at the angle
    of repose θ; if θ > atan(a) = 16.7° the slope meets the top inside the box, so the grains at the
    wall keep the column's height (to 2 diameters: the pack rearranges by a grain) and the heap left is
    a trapezoid holding 1 − a / (2 tan θ) of the column: between 0.5 (θ = atan a) and 0.85 (θ = 45°,
    steeper than any cohesionless pack). The fitted flank is steeper than atan(a) (measured 29°), every
    grain is kept (the pit holds those that fall) and the heap comes to rest before the end."""
    d = heap["grain_diameter_mean_m"]
    h0 = heap["settled_aspect_ratio"] * heap["initial_width_m"]
    assert heap["mass_change_relative"] < 1e-6
    assert heap["final_height_m"] >= h0 - 2.0 * d
    assert 0.5 <= heap["heap_mass_fraction"] <= 0.85
    assert heap["flank_angle_deg"] > math.degrees(math.atan(heap["aspect_ratio"]))
    assert heap["stop_time_s"] is not None and heap["stop_time_s"] < heap["end_time"]
