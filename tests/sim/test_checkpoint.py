"""Checkpoints restart bit for bit on the same device."""

import numpy as np
import pytest
from helpers import free_disk_scene, random_velocity

from mpmdem import InputError, Simulation, SolverConfig


def restarted(make, t1: float, t2: float, path) -> tuple[Simulation, Simulation]:
    """(a run to t1 then t2 in one Simulation, a run to t1 → checkpoint → new Simulation → run to t2).

    Both stop at t1: the steps land on each stop time (kernels.reductions.land_on_stop), so the
    stops are part of the trajectory, as a run's frames are; the checkpoint must change nothing."""
    ref = make()
    ref.advance_to(t1)
    ref.advance_to(t2)
    first = make()
    first.advance_to(t1)
    first.save_checkpoint(path)
    second = make()
    second.load_checkpoint(path)
    second.advance_to(t2)
    return ref, second


def test_restart_is_bit_for_bit(tmp_path, device):
    """Verify run to t1 → checkpoint → run to t2 equals an uninterrupted run to t2, exactly."""
    def make():
        scene = free_disk_scene(velocity=random_velocity(seed=5, scale=0.5), gravity=(0.0, -9.81),
                                boundaries={"bottom": "fixed"})
        # deterministic: ordered float atomics, so GPU runs repeat bit for bit (CPU always does)
        return Simulation(scene, SolverConfig(transfer="FLIP", update="MUSL", deterministic=True), device=device)

    ref, second = restarted(make, 0.01, 0.02, tmp_path / "c.npz")
    a, b = ref.fields(), second.fields()
    for name in ("x", "v", "stress", "F", "volume"):
        assert np.array_equal(a[name], b[name]), name
    assert ref.time == second.time


def test_checkpoint_of_another_config_is_refused(tmp_path):
    """Verify a checkpoint cannot be loaded into a different config."""
    sim = Simulation(free_disk_scene(), SolverConfig(transfer="PIC"), device="cpu")
    sim.save_checkpoint(tmp_path / "c.npz")
    other = Simulation(free_disk_scene(), SolverConfig(transfer="APIC"), device="cpu")
    with pytest.raises(InputError, match="checkpoint"):
        other.load_checkpoint(tmp_path / "c.npz")


def test_checkpoint_of_another_layout_is_refused(tmp_path):
    """Verify a checkpoint whose arrays do not have this version's shapes (the clock of an older
    version had 6 slots) is refused with an error naming the array, before anything is overwritten."""
    sim = Simulation(free_disk_scene(), SolverConfig(), device="cpu")
    path = sim.save_checkpoint(tmp_path / "c.npz")
    with np.load(path) as data:
        arrays = {k: data[k] for k in data.files}
    arrays["clock"] = arrays["clock"][:6]
    np.savez(path, **arrays)
    before = sim.stage.sim_clock.values.numpy().copy()
    with pytest.raises(InputError, match="clock"):
        sim.load_checkpoint(path)
    assert np.array_equal(sim.stage.sim_clock.values.numpy(), before)


def test_sorting_points_changes_only_round_off():
    """Verify re-sorting the points by cell every few steps leaves the results (in scene order) unchanged."""
    def run(interval):
        # a fast spin moves points across cells (up to 1.2 cells of 0.1 m in 0.02 s)
        scene = free_disk_scene(angular_velocity=20.0, gravity=(0.0, -9.81), boundaries={"bottom": "fixed"})
        sim = Simulation(scene, SolverConfig(transfer="APIC", precision="f64", sort_interval=interval), device="cpu")
        sim.advance_to(0.02)
        return sim

    plain, shuffled = run(0), run(3)
    pid = shuffled.mpm.P.pid.numpy()
    assert sorted(pid.tolist()) == list(range(shuffled.particle_count))
    assert (pid != plain.mpm.P.pid.numpy()).any()  # the points were really reordered
    a, b = plain.fields(), shuffled.fields()
    # summation order of the P2G atomics changes, nothing else: f64 round-off
    for name in ("x", "v", "stress", "F"):
        np.testing.assert_allclose(b[name], a[name], rtol=1e-9, atol=1e-12 * (np.abs(a[name]).max() + 1e-300))
    np.testing.assert_array_equal(b["mass"], a["mass"])


def test_dem_restart_is_bit_for_bit(tmp_path, device):
    """Verify a rigid-body pile restarts bit for bit: positions, contact lists and friction history."""
    from test_dem import random_pack

    def make():
        return Simulation(random_pack(n_side=4, seed=7), SolverConfig(precision="f64", deterministic=True),
                          device=device)

    ref, second = restarted(make, 0.03, 0.06, tmp_path / "dem.npz")
    a, b = ref.body_fields(), second.body_fields()
    for name in ("x", "angle", "v", "omega", "force", "torque"):
        assert np.array_equal(a[name], b[name]), name
    assert ref.diagnostics() == second.diagnostics()


def test_granular_restart_is_bit_for_bit(tmp_path, device):
    """Granular MPM with points still to be released restarts exactly: plastic state (σ, σ_zz, F),
    release bookkeeping and works come back; components and grid copies are rebuilt each step."""
    from mpmdem import MohrCoulomb, Scene

    def make():
        scene = Scene(domain=((0.0, 0.0), (0.3, 0.3)), cell_size=0.02, gravity=(0.0, -9.81))
        mat = MohrCoulomb(1.0e6, 0.3, 2000.0, 30.0, bagnold=0.1, critical_density=1990.0)
        scene.add_points(np.array([[0.1 + 0.01 * k, 0.2] for k in range(6)]), mat, size=0.01,
                         release_time=[0.0, 0.0, 0.005, 0.005, 0.012, 0.012])
        scene.add_points(np.array([[0.05 + 0.01 * i, 0.005 + 0.01 * j] for i in range(20) for j in range(4)]),
                         mat, size=0.01)
        return Simulation(scene, SolverConfig(granular=True, shape="linear", transfer="FLIP", update="MUSL",
                                              deterministic=True), device=device)

    ref, second = restarted(make, 0.008, 0.016, tmp_path / "g.npz")
    a, b = ref.fields(), second.fields()
    for name in ("x", "v", "stress", "F", "volume"):
        assert np.array_equal(a[name], b[name], equal_nan=True), name
    da, db = ref.mpm.diagnostics(), second.mpm.diagnostics()
    for name in ("work_plastic", "work_inflow", "mass", "components", "layers"):
        assert da[name] == db[name], name


def test_coupled_restart_is_bit_for_bit(tmp_path, device):
    """A coupled scene (points sliding on a fixed body, a free block landing on them) restarts
    exactly: point–body lists, tangential history, the contact energies and works come back."""
    from mpmdem import ContactLaw, LinearElastic, Scene, rectangle
    from mpmdem.model.spheropolygons import rounded_rectangle

    def make():
        scene = Scene(domain=((0.0, 0.0), (0.4, 0.3)), cell_size=0.02, gravity=(0.0, -9.81),
                      contact=ContactLaw(1.0e6, restitution=0.5))
        scene.add_mpm_body(rectangle(0.1, 0.08, 0.2, 0.14), LinearElastic(1.0e5, 0.3, 1000.0), velocity=(0.5, 0.0))
        scene.add_rigid_body(rounded_rectangle(0.36, 0.04, 0.005), density=1000.0, position=(0.2, 0.045),
                             motion="fixed", friction=0.3)
        scene.add_rigid_body(rounded_rectangle(0.04, 0.04, 0.005), density=1000.0, position=(0.15, 0.19))
        return Simulation(scene, SolverConfig(precision="f64", transfer="PIC", deterministic=True), device=device)

    ref, second = restarted(make, 0.03, 0.06, tmp_path / "c.npz")
    for name in ("x", "v", "stress", "contact_force"):
        assert np.array_equal(ref.fields()[name], second.fields()[name]), name
    for name in ("x", "angle", "v", "omega", "force"):
        assert np.array_equal(ref.body_fields()[name], second.body_fields()[name]), name
    da, db = ref.diagnostics(), second.diagnostics()
    for name in ("energy_contact_points", "work_imp_damping", "work_imp_friction", "imp_rebuilds"):
        assert da[name] == db[name], name
    assert da["imp_contacts"] > 0
