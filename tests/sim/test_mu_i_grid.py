"""μ(I) on the grid: a heap of glass beads (``MuI.glass_beads``) on a rough floor, MPM on the CPU.

References (Jop, Forterre & Pouliquen 2006's friction law; no fitted number of ours):
* a heap whose sides are flatter than atan μs = 20.9° stays at rest: the largest displacement is the
  elastic settlement, of order ρ g H² / E = 1.2e-5 m here; we allow 10 × that (1.2e-4 m, 2 % of a cell);
* a heap steeper than atan μ2 = 32.8° cannot stand at any rate: its sides run out by more than a cell
  (5 mm) within 0.2 s (free fall over a cell takes 0.03 s);
* the slow, ill-posed end (Barker et al. 2015): a heap at 23°, just above atan μs, creeps at an
  inertial number of order 1e-6; the grid-scale part of its velocity field (the velocity minus its
  average over 1.5 cells, relative to the speed) must not grow once the creep is established, and
  the creep must not accelerate: an ill-posed mode would grow without bound at the shortest
  wavelength the grid carries.
"""

import math

import numpy as np
import pytest

from mpmdem import MuI, Scene, Simulation, SolverConfig, polygon

H_CELL = 0.005  # m
HEIGHT, TOP = 0.04, 0.05  # m: heap height and crest width
E = 2.0e6  # Pa


def heap(theta_deg: float, device: str = "cpu") -> Simulation:
    """A trapezoidal heap with sides at ``theta_deg`` on a no-slip floor, 2 × 2 points per cell."""
    run = HEIGHT / math.tan(math.radians(theta_deg))
    base = TOP + 2.0 * run
    length = math.ceil((base + 0.1) / H_CELL) * H_CELL
    x0 = 0.5 * (length - base)
    scene = Scene(domain=((0.0, 0.0), (length, math.ceil((HEIGHT + 0.02) / H_CELL) * H_CELL)), cell_size=H_CELL,
                  gravity=(0.0, -9.81), boundaries={"bottom": "fixed", "left": "slip", "right": "slip", "top": "free"})
    outline = [(x0, 0.0), (x0 + base, 0.0), (x0 + run + TOP, HEIGHT), (x0 + run, HEIGHT)]
    scene.add_mpm_body(polygon(outline), MuI.glass_beads(youngs_modulus=E), points_per_cell=2)
    return Simulation(scene, SolverConfig(shape="bspline2", transfer="APIC"), device=device)


def largest_displacement(sim: Simulation, x0: np.ndarray) -> float:
    return float(np.linalg.norm(sim.fields()["x"] - x0, axis=1).max())


def roughness(x: np.ndarray, v: np.ndarray, h: float) -> float:
    """rms of (v − its mean over the points within 1.5 h) over the rms speed, on the points moving at
    more than a tenth of the fastest."""
    from scipy.spatial import cKDTree

    near = cKDTree(x).query_ball_point(x, 1.5 * h)
    smooth = np.array([v[i].mean(axis=0) for i in near])
    speed = np.linalg.norm(v, axis=1)
    moving = speed > 0.1 * speed.max()
    return float(np.sqrt(np.mean(np.sum((v - smooth)[moving] ** 2, axis=1)) / np.mean(speed[moving] ** 2)))


def test_glass_bead_limits():
    m = MuI.glass_beads()
    assert math.degrees(math.atan(m.mu_s)) == pytest.approx(20.9)
    assert math.degrees(math.atan(m.mu_2)) == pytest.approx(32.76)


@pytest.mark.parametrize("theta", [15.0, 19.0])
def test_heap_below_atan_mu_s_stays_at_rest(theta):
    sim = heap(theta)
    x0 = sim.fields()["x"].copy()
    sim.advance_to(0.15)
    settle = 1470.0 * 9.81 * HEIGHT**2 / E
    assert largest_displacement(sim, x0) < 10.0 * settle


def test_heap_above_atan_mu_2_flows(device):
    sim = heap(45.0, device)
    x0 = sim.fields()["x"].copy()
    sim.advance_to(0.2)
    assert largest_displacement(sim, x0) > H_CELL


def test_slow_creep_grows_no_grid_scale_noise():
    sim = heap(23.0)
    rough, fastest = [], []
    for t in (0.15, 0.25, 0.35):
        sim.advance_to(t)
        f = sim.fields()
        rough.append(roughness(f["x"], f["v"], H_CELL))
        fastest.append(float(np.linalg.norm(f["v"], axis=1).max()))
    # I of the creep: γ̇ ~ v / H, p ~ ρ g H / 2 (the slow end of μ(I), below 1e-4)
    m = MuI.glass_beads(youngs_modulus=E)
    inertial = fastest[-1] / HEIGHT * m.grain_diameter / math.sqrt(m.density * 9.81 * HEIGHT / 2 / m.grain_density)
    assert inertial < 1e-4
    assert rough[-1] <= 1.2 * rough[0]
    assert fastest[-1] <= 1.2 * fastest[0]
