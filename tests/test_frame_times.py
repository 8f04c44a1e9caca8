"""Frames land on their requested times: the step that would cross a frame time ends on it, on
the device (MPM, DEM and coupled clocks), so a 3.5 s run's last frame is at 3.5 s, not 3.5 + dt."""

import numpy as np
import pytest

from mpmdem import ContactLaw, NeoHookean, Scene, Simulation, disk, rounded_rectangle, sphero_disk


def _mpm():
    scene = Scene(domain=((0.0, 0.0), (1.0, 1.0)), cell_size=0.1, gravity=(0.0, -9.81))
    scene.add_body(disk((0.5, 0.5), 0.2), NeoHookean(1e4, 0.3, 1000.0), velocity=(0.1, 0.0))
    return scene


def _dem(coupled=False):
    scene = Scene(domain=((0.0, 0.0), (1.0, 1.0)), cell_size=0.1 if coupled else None, gravity=(0.0, -9.81),
                  contact=ContactLaw(1e5, restitution=0.5))
    scene.add_rigid_body(sphero_disk(0.05), density=1000.0, position=(0.5, 0.7))
    scene.add_rigid_body(rounded_rectangle(1.0, 0.1), density=1000.0, position=(0.5, 0.05), motion="fixed")
    if coupled:
        scene.add_body(disk((0.3, 0.4), 0.1), NeoHookean(1e4, 0.3, 1000.0))
    return scene


@pytest.mark.parametrize("make", [_mpm, _dem, lambda: _dem(coupled=True)], ids=["mpm", "dem", "coupled"])
def test_frames_end_on_the_requested_times(make):
    """Verify every frame time equals t_end k / frames to round-off and the last is t_end exactly,
    with steps that do not divide the frame interval (the CFL and DEM steps vary)."""
    end, frames = 0.0137, 5
    result = Simulation(make(), device="cpu").run(end, frames=frames, quiet=True)
    expected = end * np.arange(frames + 1) / frames
    np.testing.assert_allclose(result.times, expected, rtol=0, atol=1e-15)
    assert result.times[-1] == end
    # a frame's dt is its last step's, shortened to end on the frame: never 0, never above the bound
    dt = result.diagnostics["dt"][1:]
    assert (dt > 0).all() and (dt <= result.diagnostics["dt_bound"][1:]).all()
