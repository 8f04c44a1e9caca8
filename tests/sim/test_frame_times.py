"""Output frames land on their nominal times, the last on the end time (issue 29: "0 .. 3.50731 s"
for a 3.5 s run), in MPM, DEM and coupled scenes, with the CFL step and with a fixed step that does
not divide the frame interval."""

import numpy as np
import pytest

from mpmdem import ContactLaw, LinearElastic, Scene, Simulation, SolverConfig, disk, rounded_rectangle, sphero_disk

END, FRAMES = 0.013, 4  # s; 3.25 ms frames, not a whole number of any step below


def mpm_scene(contact: ContactLaw | None = None) -> Scene:
    scene = Scene(domain=((0.0, 0.0), (1.0, 1.0)), cell_size=0.05, gravity=(0.0, -9.81), contact=contact)
    scene.add_mpm_body(disk((0.5, 0.5), 0.15), LinearElastic(1e6, 0.3, 1000.0), velocity=(0.3, 0.0))
    return scene


def dem_scene() -> Scene:
    scene = Scene(domain=((0.0, 0.0), (1.0, 1.0)), gravity=(0.0, -9.81), contact=ContactLaw(1e6, restitution=0.5))
    scene.add_rigid_body(sphero_disk(0.05), density=1000.0, position=(0.5, 0.3), velocity=(0.0, -1.0))
    scene.add_rigid_body(rounded_rectangle(1.0, 0.1, 0.01), density=1000.0, position=(0.5, 0.05), motion="fixed")
    return scene


def coupled_scene() -> Scene:
    scene = mpm_scene(ContactLaw(1e6, restitution=0.5))
    scene.add_rigid_body(rounded_rectangle(1.0, 0.3, 0.01), density=1000.0, position=(0.5, 0.15), motion="fixed")
    return scene


@pytest.mark.parametrize("dt", [None, 7.0e-5], ids=["cfl", "fixed-dt"])
@pytest.mark.parametrize("build", [mpm_scene, dem_scene, coupled_scene], ids=["mpm", "dem", "coupled"])
def test_frames_land_on_their_nominal_times(build, dt):
    sim = Simulation(build(), SolverConfig(dt=dt), device="cpu")
    result = sim.run(END, frames=FRAMES)
    # the steps of a frame sum to its length up to float64 round-off (n ε t, n < 100 here)
    np.testing.assert_allclose(result.times, np.linspace(0.0, END, FRAMES + 1), rtol=0, atol=1e-12)
    assert result.times[-1] == END
    # every step of a frame is at most the step asked for (LANDING_SLACK: 0.1 % / steps per frame)
    asked = dt if dt else None
    if asked:
        assert np.all(result.diagnostics["dt"][1:] <= asked * (1 + 1e-3))


@pytest.mark.parametrize("build", [mpm_scene, dem_scene, coupled_scene], ids=["mpm", "dem", "coupled"])
def test_steps_launched_ahead_are_the_steps_of_the_frame(build, device):
    """``launch_ahead`` (the next frame's first steps launched while the host writes the last one, on
    a GPU) takes the same steps as ``advance_to`` alone: with a fixed dt, the same count per frame
    and no idle step (dt = 0) in any frame; on the CPU it launches nothing."""
    dt = 7.0e-5
    plain = Simulation(build(), SolverConfig(dt=dt), device=device)
    counts = [plain.advance_to(END * k / FRAMES)[1] for k in range(1, FRAMES + 1)]
    sim = Simulation(build(), SolverConfig(dt=dt), device=device)
    ahead = sim.launch_ahead(0.0, END / FRAMES, dt)
    assert ahead == (0 if device == "cpu" else int(0.5 * END / FRAMES / dt))
    assert sim.advance_to(END / FRAMES)[1] == counts[0]
    result = Simulation(build(), SolverConfig(dt=dt), device=device).run(END, frames=FRAMES)
    assert list(result.diagnostics["steps"][1:]) == counts
    assert np.all(result.diagnostics["dt"][1:] > 0.0)
    np.testing.assert_allclose(result.times, np.linspace(0.0, END, FRAMES + 1), rtol=0, atol=1e-12)
