"""Hyperelastic scenes store F alone: σ and V are recomputed from it (kernels.constitutive).

The step then reads and writes 20 bytes a point less (f32). What must hold: the output stress and
volume are the Neo-Hookean law's of the output F ("MPM notes" step 8), the trajectory is the one
the stored update gives (the same arithmetic, so the same bits on the CPU), and scenes whose
stress has a history (rate-form laws, a stress-free state) keep storing it.
"""

import numpy as np
import pytest

from mpmdem import LinearElastic, NeoHookean, Scene, Simulation, SolverConfig, disk
from mpmdem.kernels import constitutive

MAT = NeoHookean(1.0e4, 0.3, 1000.0)


def colliding_disks(second=MAT):
    scene = Scene(domain=((0.0, 0.0), (1.0, 1.0)), cell_size=1.0 / 16,
                  boundaries=dict.fromkeys(("left", "right", "bottom", "top"), "free"))
    scene.add_mpm_body(disk(center=(0.3, 0.3), radius=0.15), MAT, velocity=(0.4, 0.4))
    scene.add_mpm_body(disk(center=(0.7, 0.7), radius=0.15), second, velocity=(-0.4, -0.4))
    return scene


def run(scene, precision="f64", **config):
    sim = Simulation(scene, SolverConfig(precision=precision, **config), device="cpu")
    sim.run(0.4, frames=2)  # through the impact: F far from I
    return sim


def neo_hookean_stress(F, mu, lam):
    """Cauchy stress of the compressible Neo-Hookean law in plane strain [Pa] ("MPM notes", step 8)."""
    J = np.linalg.det(F)
    FFt = F @ np.swapaxes(F, 1, 2)
    return (mu / J)[:, None, None] * (FFt - np.eye(2)) + (lam * np.log(J) / J)[:, None, None] * np.eye(2)


def test_output_stress_and_volume_follow_the_law_of_the_output_F():
    """Verify the frames' stress and volume equal σ(F) and V0 det F of the same frame's F."""
    scene = colliding_disks()
    sim = run(scene)
    assert sim.mpm.derived_stress
    f = sim.fields()
    F = f["F"]
    assert np.abs(F - np.eye(2)).max() > 1e-3  # the disks deformed: the check is not at F = I
    E, nu = 1.0e4, 0.3  # MAT's Young's modulus [Pa] and Poisson's ratio
    mu, lam = E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))
    expected = neo_hookean_stress(F, mu, lam)
    # f64: the law evaluated twice differs by round-off only (1e-12 of the stress scale μ)
    np.testing.assert_allclose(f["stress"], expected, rtol=0, atol=1e-12 * mu)
    vol0 = scene.particles()["vol"]
    np.testing.assert_allclose(f["volume"], vol0 * np.linalg.det(F), rtol=1e-12)


@pytest.mark.parametrize("precision", ["f32", "f64"])
def test_trajectory_matches_the_stored_update(monkeypatch, precision):
    """Verify storing σ and V, or recomputing them from F, gives the same bits on the CPU."""
    derived = run(colliding_disks(), precision).fields()
    monkeypatch.setattr(constitutive, "stress_from_deformation", lambda kinds, critical: False)
    stored_sim = run(colliding_disks(), precision)
    assert not stored_sim.mpm.derived_stress
    stored = stored_sim.fields()
    for name in ("x", "v", "F", "stress", "volume"):
        np.testing.assert_array_equal(derived[name], stored[name], err_msg=name)


def test_scenes_with_a_stress_history_store_it():
    """Verify a rate-form law or a critical density keeps the stored stress."""
    assert not constitutive.stress_from_deformation((constitutive.LINEAR_ELASTIC, constitutive.NEO_HOOKEAN), False)
    assert not constitutive.stress_from_deformation((constitutive.NEO_HOOKEAN,), True)
    assert constitutive.stress_from_deformation((constitutive.NEO_HOOKEAN,), False)
    sim = Simulation(colliding_disks(second=LinearElastic(1.0e4, 0.3, 1000.0)), SolverConfig(), device="cpu")
    assert not sim.mpm.derived_stress
