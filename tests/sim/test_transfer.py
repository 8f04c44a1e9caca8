"""P2G → G2P transfers: conservation of mass and momentum, exact rigid rotation for APIC."""

import numpy as np
import pytest
from helpers import free_disk_scene, random_velocity

from mpmdem import TRANSFER_SCHEMES, Simulation, SolverConfig
from mpmdem.sim.launch_plan import run_plan


def one_step(scene, config, device):
    sim = Simulation(scene, config, device=device)
    before = sim.fields()
    dt = config.cfl * sim.mpm.dt_bound0
    sim.advance_to(0.5 * dt)  # exactly one explicit step (no shortening of the last step)
    return sim, before, sim.fields()


@pytest.mark.parametrize("transfer", sorted(TRANSFER_SCHEMES))
def test_transfer_conserves_mass_and_momentum(transfer):
    """Verify one step of every transfer keeps grid mass = point mass and Σ m v to round-off."""
    scene = free_disk_scene(velocity=random_velocity(seed=3))
    cfg = SolverConfig(transfer=transfer, flip_fraction=0.9, precision="f64", shape="bspline2")
    sim, before, after = one_step(scene, cfg, "cpu")
    m = before["mass"]
    # grid mass after P2G (the step's first launch; the step's last grid update clears the grid
    # for the next one): includes ghost nodes; fold/mirror does not apply (no wall is touched)
    fresh = Simulation(scene, cfg, device="cpu")
    fresh.stage.set_stop_time(1.0)  # (a step to take: dt > 0 on the clock)
    run_plan(fresh.mpm._sequence[:1], "cpu")
    np.testing.assert_allclose(fresh.mpm.G.mass.numpy().sum(), m.sum(), rtol=1e-12)
    p0 = (m[:, None] * before["v"]).sum(0)
    p1 = (m[:, None] * after["v"]).sum(0)
    # Σ_i f_int,i = −Σ_p V σ Σ_i ∇N_i = 0 and Σ_i N_i (x_i − x_p) = 0, so the only change is
    # round-off: f64 sums over ~1e3 points of O(0.1 kg m/s) terms -> 1e-12 relative is generous.
    scale = (m * np.linalg.norm(before["v"], axis=1)).sum()
    assert np.abs(p1 - p0).max() < 1e-12 * scale


@pytest.mark.parametrize("shape", ["linear", "ugimp", "cpgimp", "bspline2", "bspline3"])
def test_apic_reproduces_rigid_rotation(shape, device):
    """Verify APIC transfers a rigid rotation exactly (velocities and C), for every shape."""
    omega = 2.0
    scene = free_disk_scene(angular_velocity=omega)
    sim, before, after = one_step(scene, SolverConfig(transfer="APIC", shape=shape, precision="f64"), device)
    # first step: stress is zero, so the grid carries the affine field v_c + W (x_i − x_c) and
    # interpolates it back exactly at the old positions (linear completeness of every shape)
    vmax = np.abs(before["v"]).max()
    np.testing.assert_allclose(after["v"], before["v"], atol=1e-12 * vmax)
    C = sim.mpm.P.C.numpy()
    np.testing.assert_allclose(C, np.broadcast_to([[0.0, -omega], [omega, 0.0]], C.shape), atol=1e-10)


def test_pic_loses_angular_momentum_of_rotation():
    """Verify PIC does not keep a rigid rotation's angular momentum (the reason for APIC)."""
    scene = free_disk_scene(angular_velocity=2.0)

    def angular(f):
        x = f["x"] - f["x"].mean(0)
        return (f["mass"] * (x[:, 0] * f["v"][:, 1] - x[:, 1] * f["v"][:, 0])).sum()

    _, before, after = one_step(scene, SolverConfig(transfer="PIC", precision="f64"), "cpu")
    _, _, after_apic = one_step(scene, SolverConfig(transfer="APIC", precision="f64"), "cpu")
    loss_pic = 1 - angular(after) / angular(before)
    loss_apic = 1 - angular(after_apic) / angular(before)
    # PIC filters the rotation through the grid: one transfer at h = 0.1 m loses ~1e-2 of L
    assert loss_pic > 1e-3
    assert abs(loss_apic) < 1e-10
