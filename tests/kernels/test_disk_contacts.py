"""The DEM's disk–disk pass (``kernels.dem_disks``): pairs of two sphero-disks without the feature search.

Verify it against the general vertex–edge search (``Tuning(disk_pairs=False)``: the reference
for every other body pair, tested against shapely and the contact laws in tests/sim/test_dem.py) and
against the contact law itself (MPM-SDEM eq. 38-43): a head-on impact of two disks and a disk
sliding on a disk at rest. f64 on the CPU, a few bodies, seconds once compiled.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from shapely.geometry import box

from mpmdem import ContactLaw, Scene, Simulation, SolverConfig, Tuning, regular_polygon, sphero_disk
from mpmdem.model.grains import GrainSet, place_grains

F64 = SolverConfig(precision="f64")
G = 9.81


def disk_set(name: str, positions, radius: float, *, density: float = 1000.0, friction: float = 0.5,
             velocity=(0.0, 0.0)) -> GrainSet:
    """A grain set of disks of one radius [m] at ``positions`` (k, 2) [m], all moving at ``velocity``."""
    pos = np.asarray(positions, dtype=float).reshape(-1, 2)
    n = len(pos)
    r = np.full(n, radius)
    return GrainSet(name, "disk", radius, 0.0, density, friction, pos, np.zeros(n), r, np.zeros((n, 1, 2)),
                    0.5 * r * r * (2.0 * math.pi), 0.25 * r**4 * (2.0 * math.pi), np.zeros(n),
                    tuple(float(v) for v in velocity))


def simulate(scene: Scene, disk_pairs: bool, steps: int, config: SolverConfig = F64,
             device: str = "cpu") -> Simulation:
    sim = Simulation(scene, config, device=device, tuning=Tuning(disk_pairs=disk_pairs))
    assert sim.dem.disk_pairs == disk_pairs
    sim.stage.set_stop_time(1e30)
    sim.advance(steps)
    return sim


def pour() -> Scene:
    """Polydisperse disk grains falling into a box with a floor and side walls (fixed, large bodies)."""
    g = place_grains(box(0.0, 0.0, 0.03, 0.03), radius=0.001, density=1830.0, seed=2, friction=0.4)
    s = Scene(domain=((0.0, 0.0), (0.03, 0.03)), gravity=(0.0, -G), contact=ContactLaw(1e6, restitution=0.3))
    s.add_walls(("left", "right", "bottom"), thickness=0.005)
    s.add_grain_set(g)
    return s


def test_disk_pass_is_the_general_search_to_the_bit():
    """Verify a pour of disk grains onto walls (~1500 steps: contacts made, held with history,
    lists rebuilt) gives the same bits with the disk–disk pass as with the general search:
    positions, velocities, forces, torques, tangential history, contact energy and dissipated
    work. Tolerance 0: each pair's force is ``touch_force`` of the same arguments in both, and a
    disk sums its partners in the order of their indices, walls (the highest indices) last, as the
    general search's atomics add them on a CPU. (A pack is chaotic: one ulp would grow to 1e-3 by then.)"""
    runs = []
    for disk_pairs in (True, False):
        sim = simulate(pour(), disk_pairs, 1500)
        C = sim.dem.C
        runs.append({**sim.body_fields(), "slip": C.slip.numpy()[:, 0], "energy": C.energy.numpy(),
                     "dissipated": C.dissipated.numpy(), "rebuilds": sim.diagnostics()["list_rebuilds"]})
    fast, general = runs
    for name in fast:
        assert np.array_equal(fast[name], general[name]), name
    assert np.abs(fast["torque"]).max() > 0.0 and np.abs(fast["slip"]).max() > 0.0  # friction acted
    assert fast["rebuilds"] > 10


def test_disk_pass_restarts_bit_for_bit(tmp_path):
    """Verify a checkpoint of a pour with the disk–disk pass (its incoming lists and the partners'
    copies of δ_t included) continues bit for bit."""
    ref = simulate(pour(), True, 1000)  # (the pack lands at about step 900)
    ref.save_checkpoint(tmp_path / "disks.npz")
    assert any(name.startswith("D.") for name in ref.stage.state_arrays())
    second = simulate(pour(), True, 0)
    second.load_checkpoint(tmp_path / "disks.npz")
    for sim in (ref, second):
        sim.advance(500)
    a, b = ref.body_fields(), second.body_fields()
    for name in a:
        assert np.array_equal(a[name], b[name]), name
    assert np.abs(a["torque"]).max() > 0.0


def test_mixed_scene_forces_match_to_round_off(device):
    """Verify a first step of squeezed disk grains among free pentagons and free rigid disks (pairs of
    every kind touching at once) gives the general search's forces and torques. Each pair's force is
    the same expression (on a GPU the compiler may fuse it differently in the two kernels: an ulp);
    a disk's sum adds its pentagon partners after its disk partners here, in index order (or the
    atomics' order, on a GPU) there, so a sum of m terms may differ by m ulp of its largest term:
    1e-13 of the largest force bounds that in f64 (m < 20)."""
    g = place_grains(box(0.0, 0.0, 0.02, 0.02), radius=0.001, density=1000.0, seed=3, friction=0.5)
    centre = np.array([0.01, 0.01])
    g = dataclasses.replace(g, position=centre + 0.93 * (g.position - centre))  # overlapping neighbours
    s = Scene(domain=((0.0, 0.0), (0.02, 0.02)), gravity=(0.0, -G), contact=ContactLaw(1e6, restitution=0.5),
              allow_initial_overlap=True)
    s.add_grain_set(g)
    rng = np.random.default_rng(1)
    picks = rng.choice(len(g), 12, replace=False)
    for k, p in enumerate(picks):
        shape = regular_polygon(5, 0.0008, radius=0.0003) if k % 2 else sphero_disk(0.0011)
        s.add_rigid_body(shape, density=1000.0, position=tuple(g.position[p] + [0.0008, 0.0]),
                         angle=float(rng.uniform(0, 6.3)), velocity=(0.01, -0.02), friction=0.5)
    forces = []
    for disk_pairs in (True, False):
        sim = simulate(s, disk_pairs, 1, device=device)
        forces.append(sim.body_fields())
    fast, general = forces
    for name in ("force", "torque"):
        scale = np.abs(general[name]).max()
        assert scale > 0.0
        np.testing.assert_allclose(fast[name], general[name], rtol=0.0, atol=1e-13 * scale, err_msg=name)


@pytest.mark.parametrize("restitution", [1.0, 0.4])
def test_head_on_impact_of_two_disks_is_the_linear_spring_dashpot(restitution, device):
    """Verify a head-on impact of two disks of different masses against the law's analytic solution:
    with the dashpot c = 2ζ sqrt(k_n m*) (m* = m1 m2 / (m1 + m2); the lever arms are 0 on the centre
    line) the overlap is a damped oscillator (MPM-SDEM eq. 43's normal part), in contact for π/ω_d,
    ω_d = sqrt(k_n/m*) sqrt(1 − ζ²), leaving at e = exp(−ζπ/sqrt(1 − ζ²)) times the approach speed;
    the kinetic energy lost, (1 − e²) m* v²/2, is the dashpot work the diagnostics book. The leapfrog
    update errs by O((ω dt)²) ≈ 6e-5 at 400 steps a contact: 1e-3 bounds it."""
    kn, rho, r1, r2, v1, v2 = 1e6, 1000.0, 0.1, 0.07, 0.5, -0.2
    s = Scene(domain=((-1.0, -1.0), (1.0, 1.0)), contact=ContactLaw(kn, restitution=restitution))
    s.add_grain_set(disk_set("a", [(-0.2, 0.0)], r1, density=rho, velocity=(v1, 0.0)))
    s.add_grain_set(disk_set("b", [(0.05, 0.0)], r2, density=rho, velocity=(v2, 0.0)))
    m1, m2 = rho * math.pi * r1**2, rho * math.pi * r2**2
    m_eff = m1 * m2 / (m1 + m2)
    zeta = s.contact.damping_ratio
    e = math.exp(-zeta * math.pi / math.sqrt(1.0 - zeta**2))
    assert e == pytest.approx(restitution, rel=1e-12)
    t_contact = math.pi / (math.sqrt(kn / m_eff) * math.sqrt(1.0 - zeta**2))
    dt = t_contact / 400.0
    sim = Simulation(s, SolverConfig(precision="f64", dt=dt), device=device)
    assert sim.dem.disk_pairs
    sim.stage.set_stop_time(1e30)
    d0 = sim.diagnostics()
    gap = 0.25 - r1 - r2
    in_contact = 0
    for _ in range(int((gap / (v1 - v2) + 2.0 * t_contact) / dt)):
        sim.advance(1)
        x = sim.body_fields()["x"]
        in_contact += np.linalg.norm(x[1] - x[0]) < r1 + r2
    v = sim.body_fields()["v"]
    assert in_contact * dt == pytest.approx(t_contact, rel=0.01)  # ±1 step of 400, plus O((ω dt)²)
    j = (1.0 + e) * m_eff * (v1 - v2)  # the impulse of the impact
    assert v[0, 0] == pytest.approx(v1 - j / m1, abs=1e-3 * (v1 - v2))
    assert v[1, 0] == pytest.approx(v2 + j / m2, abs=1e-3 * (v1 - v2))
    d1 = sim.diagnostics()
    lost = 0.5 * m_eff * (1.0 - e * e) * (v1 - v2) ** 2
    kinetic = 0.5 * (m1 * v1 * v1 + m2 * v2 * v2)
    assert d0["energy_kinetic"] - d1["energy_kinetic"] == pytest.approx(lost, abs=1e-3 * kinetic)
    assert -(d1["work_contact_damping"] - d0["work_contact_damping"]) == pytest.approx(lost, abs=1e-3 * kinetic)
    assert d1["momentum_x"] == pytest.approx(m1 * v1 + m2 * v2, rel=1e-12)  # equal and opposite, to the bit


def test_disk_sliding_on_a_disk_at_rest_saturates_at_coulomb(device):
    """Verify the tangential spring with history and its Coulomb cap (MPM-SDEM eq. 43) on a disk grain
    sliding over the top of a fixed disk of its size under gravity: while it sticks, the tangential
    force is −k_t Σ v_t dt over its steps in contact (v_t the contact point's tangential velocity,
    spin included, at each step: the history carried); once k_t δ_t would pass μ k_n δ it slides at
    |F_t| = μ k_n δ, against the slip. No dashpot (e = 1): the normal force is k_n δ. The forces are
    the kernel's f64 sums; the host's δ, N from the same positions differ by round-off of
    |x|/δ ≈ 1e3 ulp: 1e-9 relative bounds it."""
    r, rho, kn, kt, mu, v0, dt = 0.01, 1000.0, 1e5, 2e3, 0.2, 0.2, 2e-5
    m = rho * math.pi * r * r
    delta0 = m * G / kn  # resting overlap
    s = Scene(domain=((-0.1, -0.1), (0.1, 0.1)), gravity=(0.0, -G),
              contact=ContactLaw(kn, tangential_stiffness=kt, restitution=1.0), allow_initial_overlap=True)
    s.add_rigid_body(sphero_disk(r), density=rho, position=(0.0, 0.0), motion="fixed", friction=mu)
    s.add_grain_set(disk_set("g", [(0.0, 2.0 * r - delta0)], r, density=rho, friction=mu, velocity=(v0, 0.0)))
    sim = Simulation(s, SolverConfig(precision="f64", dt=dt), device=device)
    assert sim.dem.disk_pairs and int(sim.dem.B.disk.numpy().sum()) == 2  # the pair is the disk pass's
    sim.stage.set_stop_time(1e30)
    stretch = 0.0  # δ_t [m]; in scene order the fixed disk (at the origin) is body 0, the grain 1
    phases = {"stick": 0, "slide": 0}
    for _ in range(400):
        f = sim.body_fields()
        x, v, w = f["x"][1], f["v"][1], f["omega"][1]
        d = np.linalg.norm(x)
        N = x / d
        t = np.array([-N[1], N[0]])
        p = x - (r - 0.5 * (2.0 * r - d)) * N  # contact point, in the middle of the overlap (eq. 41)
        lever = p - x
        v_t = float((v + w * np.array([-lever[1], lever[0]])) @ t)
        sim.advance(1)
        F = sim.body_fields()["force"][1]
        fn_elastic = kn * (2.0 * r - d)
        ft = float(F @ t)
        cap = mu * fn_elastic
        stretch += v_t * dt
        if abs(kt * stretch) < cap * (1.0 - 1e-9):
            phases["stick"] += 1
            assert ft == pytest.approx(-kt * stretch, rel=1e-9)
        else:
            phases["slide"] += 1
            assert abs(ft) == pytest.approx(cap, rel=1e-9)
            assert ft * v_t < 0.0  # against the slip
            stretch = -ft / kt  # the capped stretch the history keeps
        assert float(F @ N) == pytest.approx(fn_elastic, rel=1e-9)
    assert phases["stick"] >= 5 and phases["slide"] >= 50


def test_disk_pass_compiles_for_sm90(tmp_path):
    """Verify the CUDA code of the disk–disk pass and of the kernels it specialises (the list build
    that packs only the general pairs, the general search that skips disk pairs) compiles for sm_90
    without a GPU (Warp's NVRTC, as tests/kernels/test_cuda_codegen.py)."""
    import warp as wp

    from mpmdem.kernels import dem_disks, dem_lists

    sim = Simulation(pour(), SolverConfig(), device="cpu")
    dem = sim.dem
    assert dem.disk_pairs
    disks = dem_disks.make_disk_pairs("f32", False)
    lists = dem_lists.make_dem_lists("f32", False, True)
    for k in (disks.list_incoming, disks.sort_incoming, disks.disk_forces, lists.build_lists, dem.contact_kernel):
        paths = wp.compile_aot_module(k.module, arch=90, module_dir=str(tmp_path))
        assert paths and all(p.exists() for p in paths), k.key
