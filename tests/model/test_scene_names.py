"""Scene is the builder, Model what the stages take: ``Scene.finalize`` checks the scene, seeds its
points and lays out its DEM bodies once, into a frozen model; the old names are gone."""

import dataclasses
import inspect

import numpy as np
import pytest

from mpmdem import ContactLaw, InputError, NeoHookean, Scene, Simulation, disk, sphero_disk
from mpmdem.model.finished import Model


def _scene() -> Scene:
    scene = Scene(domain=((0.0, 0.0), (2.0, 2.0)), cell_size=0.1, gravity=(0.0, -9.81),
                  contact=ContactLaw(normal_stiffness=1.0e5))
    scene.add_mpm_body(disk(center=(1.0, 1.2), radius=0.3), NeoHookean(1.0e4, 0.3, 1000.0), velocity=(0.5, 0.0),
                       points_per_cell=3, name="ball")
    scene.add_rigid_body(sphero_disk(0.2), density=1000.0, position=(1.0, 0.4), name="puck")
    return scene


def test_old_names_are_gone():
    """Verify Scene.add_body (add_mpm_body's old name) and Simulation.run's quiet are removed."""
    assert not hasattr(Scene, "add_body")
    assert "quiet" not in inspect.signature(Simulation.run).parameters


def test_finalize_gives_the_scenes_points_and_bodies_frozen():
    """Verify the model holds the scene's seeded points and DEM columns, equal to what the scene
    builds, and that neither the model nor its arrays change, even when the scene goes on growing."""
    scene = _scene()
    model = scene.finalize()
    assert isinstance(model, Model) and model.has_mpm and model.has_dem
    host = scene.particles()
    assert sorted(model.particles) == sorted(host)
    for key in host:
        np.testing.assert_array_equal(model.particles[key], host[key], err_msg=key)
    arrays = scene.body_arrays()
    np.testing.assert_array_equal(model.arrays.position, arrays.position)
    np.testing.assert_array_equal(model.arrays.mass, arrays.mass)
    assert model.body_names == ("puck",) and model.cell_counts == scene.cell_counts
    with pytest.raises(dataclasses.FrozenInstanceError):
        model.cell_size = 0.2
    with pytest.raises(ValueError):
        model.particles["x"][0, 0] = 0.0  # read-only
    scene.add_rigid_body(sphero_disk(0.1), density=1000.0, position=(1.7, 1.7), name="late")
    assert len(model.rigid_bodies) == 1 and len(model.arrays) == 1


def test_finalize_checks_the_whole_scene():
    """Verify finalize refuses a scene without bodies and a point starting inside a rigid body."""
    with pytest.raises(InputError, match="bodies"):
        Scene(domain=((0.0, 0.0), (1.0, 1.0)), cell_size=0.1).finalize()
    scene = _scene()
    scene.add_rigid_body(sphero_disk(0.1), density=1000.0, position=(1.0, 1.2), name="inside")
    with pytest.raises(InputError, match="inside"):
        scene.finalize()


def test_simulation_builds_points_and_bodies_once(monkeypatch):
    """Verify Simulation(scene) seeds the points and lays out the DEM bodies once each (finalize)."""
    calls = {"particles": 0, "body_arrays": 0}
    for name in calls:
        method = getattr(Scene, name)

        def counted(self, _method=method, _name=name):
            calls[_name] += 1
            return _method(self)

        monkeypatch.setattr(Scene, name, counted)
    sim = Simulation(_scene(), device="cpu")
    assert calls == {"particles": 1, "body_arrays": 1}
    assert sim.model.particles is sim.mpm.model.particles and sim.dem.arrays is sim.model.arrays
