"""Scene.add_mpm_body's old name, Scene.add_body, still works: it warns and builds the same scene."""

import warnings

import numpy as np
import pytest

from mpmdem import NeoHookean, Scene, disk, sphero_disk


def _scene(add: str) -> Scene:
    scene = Scene(domain=((0.0, 0.0), (2.0, 2.0)), cell_size=0.1, gravity=(0.0, -9.81))
    getattr(scene, add)(disk(center=(1.0, 1.2), radius=0.3), NeoHookean(1.0e4, 0.3, 1000.0), velocity=(0.5, 0.0),
                        points_per_cell=3, name="ball")
    scene.add_rigid_body(sphero_disk(0.2), density=1000.0, position=(1.0, 0.4), name="puck")
    return scene


def test_add_body_warns_and_gives_the_same_scene():
    """Verify the old name emits a DeprecationWarning naming the new one, and the two scenes match:
    the same description and the same material points."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the new name warns about nothing
        new = _scene("add_mpm_body")
    with pytest.warns(DeprecationWarning, match="add_mpm_body"):
        old = _scene("add_body")
    assert old.to_dict() == new.to_dict()
    assert len(old.bodies) == len(new.bodies) == 1 and old.bodies[0].contact_radius == new.bodies[0].contact_radius
    a, b = old.particles(), new.particles()
    assert sorted(a) == sorted(b)
    for key in a:
        np.testing.assert_array_equal(a[key], b[key], err_msg=key)
