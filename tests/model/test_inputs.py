"""Bad input: each gives an InputError naming the parameter, before any kernel runs."""

import math

import pytest
from helpers import free_disk_scene

from mpmdem import (
    Boundary,
    InputError,
    LinearElastic,
    NeoHookean,
    Scene,
    Simulation,
    SolverConfig,
    disk,
    rectangle,
)

MAT = LinearElastic(1.0e6, 0.3, 1000.0)


@pytest.mark.parametrize("kwargs, name", [
    (dict(youngs_modulus=-1.0, poisson_ratio=0.3, density=1000.0), "youngs_modulus"),
    (dict(youngs_modulus=0.0, poisson_ratio=0.3, density=1000.0), "youngs_modulus"),
    (dict(youngs_modulus=1e6, poisson_ratio=0.5, density=1000.0), "poisson_ratio"),
    (dict(youngs_modulus=1e6, poisson_ratio=-1.0, density=1000.0), "poisson_ratio"),
    (dict(youngs_modulus=1e6, poisson_ratio=0.3, density=0.0), "density"),
    (dict(youngs_modulus=math.nan, poisson_ratio=0.3, density=1.0), "youngs_modulus"),
])
@pytest.mark.parametrize("model", [LinearElastic, NeoHookean])
def test_bad_material(model, kwargs, name):
    """Verify invalid material parameters are rejected with the parameter's name."""
    with pytest.raises(InputError, match=name):
        model(**kwargs)


@pytest.mark.parametrize("kwargs, name", [
    (dict(shape="quartic"), "shape"),
    (dict(transfer="MLS"), "transfer"),
    (dict(update="USX"), "update"),
    (dict(precision="f16"), "precision"),
    (dict(cfl=0.0), "cfl"),
    (dict(cfl=1.5), "cfl"),
    (dict(dt=-1e-3), "dt"),
    (dict(dt=0.0), "dt"),
    (dict(flip_fraction=1.2), "flip_fraction"),
    (dict(blowup_energy_factor=0.0), "blowup_energy_factor"),
])
def test_bad_config(kwargs, name):
    """Verify invalid solver choices are rejected and the message lists what is allowed."""
    with pytest.raises(InputError, match=name) as err:
        SolverConfig(**kwargs)
    assert "invalid" in str(err.value)


def test_config_names_are_case_insensitive():
    """Verify 'apic', 'usl', 'BSPLINE2' are accepted and normalised."""
    c = SolverConfig(transfer="apic", update="usl", shape="BSPLINE2")
    assert (c.transfer, c.update, c.shape) == ("APIC", "USL", "bspline2")


@pytest.mark.parametrize("kwargs, name", [
    (dict(domain=((1.0, 0.0), (0.0, 1.0)), cell_size=0.1), "domain"),
    (dict(domain="box", cell_size=0.1), "domain"),
    (dict(domain=((0, 0), (1, 1)), cell_size=0.0), "cell_size"),
    (dict(domain=((0, 0), (1, 1)), cell_size=2.0), "cell_size"),
    (dict(domain=((0, 0), (1, 1)), cell_size=0.1, gravity=(0, -9.8, 0)), "gravity"),
    (dict(domain=((0, 0), (1, 1)), cell_size=0.1, boundaries={"bottom": "sticky"}), "boundary kind"),
    (dict(domain=((0, 0), (1, 1)), cell_size=0.1, boundaries={"floor": "fixed"}), "boundaries"),
    (dict(domain=((0, 0), (1, 1)), cell_size=0.1, gravity_ramp=-1.0), "gravity_ramp"),
])
def test_bad_scene(kwargs, name):
    """Verify invalid scene parameters are rejected with the parameter's name."""
    with pytest.raises(InputError, match=name):
        Scene(**kwargs)


def test_bad_boundary_friction():
    """Verify a negative wall friction is rejected."""
    with pytest.raises(InputError, match="friction"):
        Boundary("friction", friction=-0.1)


@pytest.mark.parametrize("kwargs, name", [
    (dict(points_per_cell=0), "points_per_cell"),
    (dict(points_per_cell=9), "points_per_cell"),
    (dict(velocity=(math.inf, 0.0)), "velocity"),
    (dict(velocity=lambda x: x[:, :1]), "velocity"),
])
def test_bad_body(kwargs, name):
    """Verify invalid body parameters are rejected with the parameter's name."""
    scene = Scene(domain=((0, 0), (1, 1)), cell_size=0.1)
    with pytest.raises(InputError, match=name):
        scene.add_mpm_body(disk(center=(0.5, 0.5), radius=0.2), MAT, **kwargs)


def test_body_outside_domain():
    """Verify a shape that sticks out of the domain is rejected."""
    scene = Scene(domain=((0, 0), (1, 1)), cell_size=0.1)
    with pytest.raises(InputError, match="inside the domain"):
        scene.add_mpm_body(rectangle(0.5, 0.5, 1.5, 0.8), MAT)


def test_material_must_be_a_material():
    """Verify a non-material is rejected."""
    scene = Scene(domain=((0, 0), (1, 1)), cell_size=0.1)
    with pytest.raises(InputError, match="material"):
        scene.add_mpm_body(disk(center=(0.5, 0.5), radius=0.2), {"E": 1e6})


def test_fixed_dt_above_bound_is_an_error_naming_the_bound():
    """Verify a user dt above h/max(c+|v|) raises before any kernel runs, naming the bound."""
    scene = free_disk_scene(material=MAT)
    bound = scene.cell_size / MAT.wave_speed
    with pytest.raises(InputError, match="stable bound") as err:
        Simulation(scene, SolverConfig(dt=1.01 * bound), device="cpu")
    assert f"{bound:.6g}"[:4] in str(err.value)
    Simulation(scene, SolverConfig(dt=0.99 * bound), device="cpu")  # just below: accepted


def test_unknown_device():
    """Verify an unknown device name is rejected listing the devices."""
    with pytest.raises(InputError, match="device"):
        Simulation(free_disk_scene(), device="tpu")


def test_scene_without_bodies():
    """Verify a scene with nothing in it is rejected."""
    with pytest.raises(InputError, match="bodies"):
        Simulation(Scene(domain=((0, 0), (1, 1)), cell_size=0.1), device="cpu")


def test_bad_run_arguments():
    """Verify run() rejects a non-positive end time and frame count."""
    sim = Simulation(free_disk_scene(), device="cpu")
    with pytest.raises(InputError, match="end_time"):
        sim.run(-1.0)
    with pytest.raises(InputError, match="frames"):
        sim.run(1.0, frames=0)


def test_one_rule_for_numbers():
    """Verify every input check takes numbers alike (mpmdem.checks): a bool or a string is refused
    with the parameter's name, a NumPy scalar is accepted."""
    import numpy as np

    from mpmdem import ContactLaw, MohrCoulomb, sphero_disk

    for bad in (True, "1e6", math.nan, None):
        with pytest.raises(InputError, match="normal_stiffness"):
            ContactLaw(bad)
    with pytest.raises(InputError, match="youngs_modulus"):
        LinearElastic(True, 0.3, 1000.0)
    with pytest.raises(InputError, match="radius"):
        sphero_disk("0.1")
    with pytest.raises(InputError, match="x0"):
        rectangle(False, 0.0, 1.0, 1.0)
    assert ContactLaw(np.float32(1e6)).kt == pytest.approx(1e6)
    assert MohrCoulomb(1e6, 0.3, 2000.0, np.float32(30.0)).friction_angle == pytest.approx(30.0)
    assert sphero_disk(np.float64(0.1)).radius == pytest.approx(0.1)
