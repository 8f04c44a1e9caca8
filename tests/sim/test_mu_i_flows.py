"""μ(I) (``MuI``) on the grid against the analytic flows of the rheology, in a cell periodic in x
(``kernels/periodic.py``), on the CPU in f64. Derivations in docs/concepts/mu-i.md.

The material is Jop, Forterre & Pouliquen 2006's glass beads (μs = tan 20.9°, μ2 = tan 32.76°,
I0 = 0.279, ρs = 2450 kg/m³, solid fraction φ = 0.6, so ρ = 1470 kg/m³) with a grain of d = 2 mm
(the seed's grain): the flows' relaxation time scales as h^{3/2} / d, and 2 mm lets a 1 cm layer
reach its steady state in under a second of flow. E = 2e5 Pa: the elastic strain ρ g h / E is
7e-4 on the incline and p0 / E = 1 % in the shear cell.

References and tolerances:
* homogeneous simple shear between rough walls moving at ±U (no gravity, confined at p0): the
  steady state is u = U (2y/H − 1), p = p0 and τ/p = μ(I) with I = (2U/H) d / sqrt(p0/ρs), uniform.
  A linear velocity field is in the span of every shape function and of the moving walls' images,
  so the grid adds no error: both grids must give it to what the elastic predictor leaves, the
  Jaumann rotation's normal stresses, of relative order (τ/G)² ≤ 3e-4; we allow 1e-3 (the issue
  asks 1 %). The cell starts at rest, so the walls must drive the flow through the seam;
* steady flow down a rough incline at θ = 25° (between atan μs and atan μ2): the Bagnold profile
  u(z) = (2/3) (I_θ / d) sqrt(φ g cos θ) (h^{3/2} − (h − z)^{3/2}), μ(I_θ) = tan θ. The grid error
  is judged by two grids (h/8, h/16): it must shrink, and the fine grid's error must be within the
  difference of the two grids, which is what at least first-order convergence towards the
  analytic value implies (e_h/2 = e_h / 2^p with p ≥ 1 gives |e_h/2| ≤ |u_h/2 − u_h|);
* below atan μs there is no steady flow: a layer launched at the 25° profile on an 18° slope stops,
  and a layer at rest stays at rest; what is left is elastic, displacements of order τ h / G.
"""

import dataclasses
import math

import numpy as np
import pytest

from mpmdem import MuI, Scene, Simulation, SolverConfig, rectangle
from mpmdem.model.boundaries import Boundary

G_ACC = 9.81  # m/s²
DEPTH = 0.01  # m: the incline's layer, and the shear cell's gap
GRAIN = 2.0e-3  # m
E = 2.0e5  # Pa
PERIODIC = {"left": "periodic", "right": "periodic"}


def beads() -> MuI:
    """Jop et al. 2006's glass beads with a 2 mm grain (module docstring)."""
    return dataclasses.replace(MuI.glass_beads(youngs_modulus=E), grain_diameter=GRAIN)


def config() -> SolverConfig:
    return SolverConfig(shape="bspline2", transfer="APIC", precision="f64")


def point_szz(sim: Simulation) -> np.ndarray:
    """σ_zz [Pa] of every point, scene order (the out-of-plane stress of the plastic laws)."""
    P = sim.mpm.points
    out = np.empty(len(P.szz))
    out[P.pid.numpy()] = P.szz.numpy()
    return out


def pressure_and_tau(sim: Simulation) -> tuple[np.ndarray, np.ndarray]:
    """p = −σ_m and τ = sqrt(J2) of the 3D deviator [Pa] per point (the law's own measures)."""
    s, szz = sim.fields()["stress"], point_szz(sim)
    sm = (s[:, 0, 0] + s[:, 1, 1] + szz) / 3.0
    j2 = 0.5 * ((s[:, 0, 0] - sm) ** 2 + (s[:, 1, 1] - sm) ** 2 + (szz - sm) ** 2) + s[:, 0, 1] ** 2
    return -sm, np.sqrt(j2)


# -- homogeneous simple shear ---------------------------------------------------------------------

P0 = 2.0e3  # Pa: the confining pressure


def shear_cell(cells: int, inertial: float) -> tuple[Simulation, float]:
    """A gap of DEPTH between rough walls at ∓U, U set for the inertial number ``inertial`` at p0;
    4 cells wide, periodic in x, at rest and at p0 (written into the points) at t = 0."""
    mat = beads()
    rate = inertial * math.sqrt(P0 / mat.grain_density) / mat.grain_diameter
    speed = 0.5 * rate * DEPTH
    h = DEPTH / cells
    scene = Scene(domain=((0.0, 0.0), (4 * h, DEPTH)), cell_size=h,
                  boundaries={**PERIODIC, "bottom": Boundary("fixed", velocity=-speed),
                              "top": Boundary("fixed", velocity=speed)})
    scene.add_mpm_body(rectangle(0.0, 0.0, 4 * h, DEPTH), mat, points_per_cell=2)
    sim = Simulation(scene, config(), device="cpu")
    n = sim.mpm.particle_count  # (an isotropic state: the points' order does not matter)
    sim.mpm.points.stress.assign(np.tile(-P0 * np.eye(2), (n, 1, 1)))
    sim.mpm.points.szz.assign(np.full(n, -P0))
    return sim, speed


@pytest.mark.parametrize("cells, inertial", [(8, 0.1), (16, 0.1), (8, 1.0)])
def test_simple_shear_has_tau_over_p_of_mu_i(cells, inertial):
    """Verify a sheared periodic cell reaches τ/p = μ(I) at the imposed rate, on two grids."""
    sim, speed = shear_cell(cells, inertial)
    # the start-up transient decays at least as fast as the rheology's own relaxation,
    # exp(−t/t_e) with t_e = H² ρ / (π² η) ≤ 0.08 s (η = μ'(I) d sqrt(ρs p0), I ≤ 1), and faster by
    # the transfers' damping of non-affine velocities; after 0.2 s the first check below asks the
    # flow to be steady (linear to 1 % of U) before τ/p is compared
    sim.advance_to(0.2)
    mat = beads()
    f = sim.fields()
    y, u = f["x"][:, 1], f["v"][:, 0]
    assert np.abs(u - speed * (2.0 * y / DEPTH - 1.0)).max() < 1e-2 * speed
    p, tau = pressure_and_tau(sim)
    np.testing.assert_allclose(p, P0, rtol=1e-3)  # (isochoric plastic flow between walls)
    expected = mat.friction(mat.inertial_number(2.0 * speed / DEPTH, p))
    np.testing.assert_allclose(tau / p, expected, rtol=1e-3)
    assert expected[0] == pytest.approx(mat.friction(inertial), rel=1e-3)


# -- flow down a rough incline ----------------------------------------------------------------------

THETA = 25.0  # deg: atan μs = 20.9° < θ < atan μ2 = 32.76°


def bagnold(mat: MuI, theta: float, z: np.ndarray, depth: float = DEPTH) -> np.ndarray:
    """The steady velocity [m/s] at heights z [m] of a μ(I) layer of depth ``depth`` on a slope of θ
    [rad] (docs/concepts/mu-i.md): (2/3) (I_θ/d) sqrt(φ g cos θ) (h^{3/2} − (h − z)^{3/2})."""
    mu = math.tan(theta)
    i_theta = mat.i0 * (mu - mat.mu_s) / (mat.mu_2 - mu)
    phi = mat.density / mat.grain_density
    scale = 2.0 / 3.0 * i_theta / mat.grain_diameter * math.sqrt(phi * G_ACC * math.cos(theta))
    return scale * (depth ** 1.5 - np.clip(depth - z, 0.0, None) ** 1.5)


def incline(cells: int, theta_deg: float, velocity=(0.0, 0.0), ramp: float = 0.02) -> Simulation:
    """A layer DEPTH deep on a no-slip floor, 4 cells wide and periodic in x, gravity tilted by θ
    (ramped over ``ramp`` [s], several of the layer's p-wave periods, so that loading it rings little)."""
    theta = math.radians(theta_deg)
    h = DEPTH / cells
    scene = Scene(domain=((0.0, 0.0), (4 * h, DEPTH + 2 * h)), cell_size=h,
                  gravity=(G_ACC * math.sin(theta), -G_ACC * math.cos(theta)), gravity_ramp=ramp,
                  boundaries={**PERIODIC, "bottom": "fixed", "top": "free"})
    scene.add_mpm_body(rectangle(0.0, 0.0, 4 * h, DEPTH), beads(), velocity=velocity, points_per_cell=2)
    return Simulation(scene, config(), device="cpu")


def steady_profile(cells: int) -> dict:
    """The layer at THETA after 1 s of flow from rest (7 relaxation times t_e ≈ 0.145 s: the
    remaining transient is < 1e-3 of the velocities), against the Bagnold profile."""
    sim = incline(cells, THETA)
    sim.advance_to(1.0)
    f = sim.fields()
    z, u = f["x"][:, 1], f["v"][:, 0]
    exact = bagnold(beads(), math.radians(THETA), z)
    top = z > z.max() - 0.25 * DEPTH / cells  # the surface row of points
    p, tau = pressure_and_tau(sim)
    core = (z > 0.25 * DEPTH) & (z < 0.75 * DEPTH)
    # the inertial number of the core: du/dz between rows of points (2 a cell) and their pressure
    mat = beads()
    rows = np.round(z / (0.5 * DEPTH / cells) - 0.5).astype(int)
    zr, ur, pr = (np.array([a[rows == r].mean() for r in np.unique(rows)]) for a in (z, u, p))
    mid, rate = 0.5 * (zr[1:] + zr[:-1]), np.diff(ur) / np.diff(zr)
    inside = (mid > 0.25 * DEPTH) & (mid < 0.75 * DEPTH)
    inertial = mat.inertial_number(rate, 0.5 * (pr[1:] + pr[:-1]))[inside].mean()
    mu = math.tan(math.radians(THETA))
    return {"mean": u.mean(), "mean_exact": exact.mean(), "surface": u[top].mean(),
            "surface_exact": exact[top].mean(), "ratio": np.mean(tau[core]) / np.mean(p[core]),
            "inertial": inertial, "inertial_exact": mat.i0 * (mu - mat.mu_s) / (mat.mu_2 - mu)}


@pytest.fixture(scope="module")
def profiles() -> dict:
    return {cells: steady_profile(cells) for cells in (8, 16)}


@pytest.mark.parametrize("what", ["mean", "surface", "inertial"])
def test_incline_converges_to_the_bagnold_profile(profiles, what):
    """Verify the depth-averaged and surface velocities, and the core's I (μ(I_θ) = tan θ), converge
    with the grid to Bagnold's."""
    coarse, fine = profiles[8], profiles[16]
    e_coarse = coarse[what] / coarse[f"{what}_exact"] - 1.0
    e_fine = fine[what] / fine[f"{what}_exact"] - 1.0
    print(f"{what}: error {e_coarse:+.4f} at h/8, {e_fine:+.4f} at h/16")
    assert abs(e_fine) < abs(e_coarse)
    assert abs(e_fine) <= abs(fine[what] / fine[f"{what}_exact"] - coarse[what] / coarse[f"{what}_exact"])
    # it flows at the speed of the law: not a few-fold off (a wrong I or d would be)
    assert abs(e_fine) < 0.05


def test_incline_flows_at_tan_theta(profiles):
    """Verify the steady layer's core sits on μ(I) = tan θ: τ/p = tan θ on both grids."""
    for cells, run in profiles.items():
        # equilibrium of a steady uniform layer: τ/p = tan θ at every depth; the grid's error in it
        # is what drives the velocities' (a 1 % error in μ is an 8 % error in I here)
        assert run["ratio"] == pytest.approx(math.tan(math.radians(THETA)), rel=1e-2), cells


def test_no_steady_flow_below_atan_mu_s():
    """Verify a layer launched down an 18° slope (below atan μs = 20.9°) comes to rest."""
    launched = lambda x: np.stack([bagnold(beads(), math.radians(THETA), x[:, 1]), 0.0 * x[:, 1]], 1)  # noqa: E731
    sim = incline(8, 18.0, velocity=launched, ramp=0.0)
    # the friction decelerates the layer by at least g (μs cos θ − sin θ) = 0.53 m/s²: its mean
    # speed of 0.06 m/s is gone within 0.12 s
    sim.advance_to(0.2)
    x1 = sim.fields()["x"]
    sim.advance_to(0.4)
    moved = np.abs(sim.fields()["x"][:, 0] - x1[:, 0]).max()
    # at rest, what moves is the elastic shear vibration of the layer: displacements below the
    # elastic shear of the column, τ h / G with τ = ρ g sin θ h at the floor (5e-6 m here);
    # a layer still flowing at the slowest steady speed would have moved by millimetres
    mat = beads()
    elastic = mat.density * G_ACC * math.sin(math.radians(18.0)) * DEPTH ** 2 / mat.shear_modulus
    assert moved < elastic


def test_slope_at_rest_below_atan_mu_s_stays_at_rest():
    """Verify a layer at rest on an 18° slope does not start to flow."""
    sim = incline(8, 18.0)
    x0 = sim.fields()["x"]
    sim.advance_to(0.3)
    mat = beads()
    elastic = mat.density * G_ACC * DEPTH ** 2 / mat.youngs_modulus  # the settlement's scale, ρ g h² / E
    assert np.abs(sim.fields()["x"] - x0).max() < 2.0 * elastic
