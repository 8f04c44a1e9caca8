"""The contracts between the coordinator and its stages: the Stage protocol, one Clock per run,
the named clock slots, the silent library run with a progress callback."""

import numpy as np
import pytest
from helpers import free_disk_scene

import mpmdem as m
from mpmdem.kernels import clock as clock_slots
from mpmdem.sim.stage import Clock, ClockReading, Stage

FREE = {s: "free" for s in ("left", "right", "bottom", "top")}


def _dem_scene(with_points: bool) -> m.Scene:
    scene = m.Scene(domain=((0.0, 0.0), (1.0, 1.0)), cell_size=0.05, gravity=(0.0, -9.81), boundaries=FREE,
                    contact=m.ContactLaw(1.0e5))
    scene.add_rigid_body(m.sphero_disk(0.05), density=1000.0, position=(0.5, 0.3))
    if with_points:
        scene.add_mpm_body(m.rectangle(0.3, 0.6, 0.7, 0.8), m.LinearElastic(1.0e5, 0.3, 1000.0))
    return scene


SCENES = {"mpm": lambda: free_disk_scene(velocity=(0.1, 0.0)), "dem": lambda: _dem_scene(False),
          "coupled": lambda: _dem_scene(True)}


@pytest.mark.parametrize("kind", list(SCENES))
def test_every_stage_satisfies_the_stage_protocol(kind):
    """Verify the MPM, DEM and coupled stages implement Stage and step on the Simulation's one Clock."""
    sim = m.Simulation(SCENES[kind](), m.SolverConfig(), device="cpu")
    assert isinstance(sim.stage, Stage)
    assert type(sim.stage).__name__ == {"mpm": "MPMSolver", "dem": "DEMSolver", "coupled": "CoupledStage"}[kind]
    for stage in (sim.stage, sim.mpm, sim.dem):
        if stage is not None:
            assert isinstance(stage, Stage)
            assert stage.sim_clock is sim.clock
            assert stage.clock is sim.clock.values and stage.steps is sim.clock.steps
    clock = sim.stage.read_clock()
    assert isinstance(clock, ClockReading) and (clock.t, clock.steps) == (0.0, 0)
    if kind == "coupled":  # each stage's counters by name
        from mpmdem.sim.coupling import CoupledStatus

        assert isinstance(clock.status, CoupledStatus)
        assert all(isinstance(part, np.ndarray) and not part.any() for part in clock.status)
    else:
        assert isinstance(clock.status, np.ndarray) and not clock.status.any()
    sim.stage.set_stop_time(1.0)
    assert sim.clock.values.numpy()[clock_slots.CLOCK_T_STOP] == 1.0
    sim.stage.step()
    reading = sim.clock.read()
    assert reading.steps == 1 and reading.t == reading.dt > 0.0
    assert set(sim.stage.WORK_TERMS) <= set(sim.stage.diagnostics())


def test_clock_slots_are_distinct_and_fill_the_array():
    """Verify the CLOCK_* names cover slots 0..CLOCK_SIZE-1 once each."""
    slots = [getattr(clock_slots, n) for n in clock_slots.__all__ if n.startswith("CLOCK_") and n != "CLOCK_SIZE"]
    assert sorted(slots) == list(range(clock_slots.CLOCK_SIZE))


def test_a_stage_built_alone_keeps_its_own_clock_and_policy():
    """Verify an MPM stage built without a clock makes one with its CFL policy."""
    from mpmdem.sim.mpm import MPMSolver

    config = m.SolverConfig(cfl=0.3)
    stage = MPMSolver(free_disk_scene().finalize(), config, "cpu")
    assert isinstance(stage.sim_clock, Clock)
    c = stage.clock.numpy()
    assert c[clock_slots.CLOCK_DT_FACTOR] == 0.3 and c[clock_slots.CLOCK_DT_FIXED] == 0.0


def test_run_is_silent_and_calls_progress(capsys):
    """Verify Simulation.run prints nothing and calls progress(t, dt) up to the end time."""
    sim = m.Simulation(free_disk_scene(velocity=(0.1, 0.0)), m.SolverConfig(), device="cpu")
    calls = []
    sim.run(0.02, frames=2, progress=lambda t, dt: calls.append((t, dt)))
    captured = capsys.readouterr()
    assert captured.err == "" and captured.out == ""
    assert calls and calls[-1][0] >= 0.02 and all(dt > 0.0 for _, dt in calls)


def test_keyboard_interrupt_from_progress_leaves_a_readable_file(tmp_path):
    """Verify a KeyboardInterrupt raised between batches marks the file interrupted and closes it."""
    import h5py

    sim = m.Simulation(free_disk_scene(velocity=(0.1, 0.0)), m.SolverConfig(), device="cpu")

    def stop(t, dt):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        sim.run(0.02, out=tmp_path, frames=2, progress=stop)
    with h5py.File(tmp_path / "run.h5", "r") as f:
        assert f.attrs["status"] == "interrupted"
