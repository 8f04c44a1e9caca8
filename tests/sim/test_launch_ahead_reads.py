"""A frame is read whole before the next frame's first steps are launched (``Simulation.launch_ahead``).

On a GPU those steps are queued while the host writes the frame, so a device read that came after the
launch would see a later state than the frame's, on the GPU only. Here ``launch_ahead`` is made to
run its steps at once on the CPU, which is what a GPU's queue may have done by the time a late read
comes: every dataset of the run files must then be the plain run's, bit for bit (the wall times
aside), for a lone run and for a batch of worlds, MPM with bodies and in granular mode.
"""

import h5py
import numpy as np
import pytest

import mpmdem as m
from mpmdem.model.config import SolverConfig
from mpmdem.model.spheropolygons import rounded_rectangle
from mpmdem.sim.batch_run import BatchedSimulation
from mpmdem.sim.simulation import Simulation

END, FRAMES = 0.004, 4


def sand_on_plate(width: float = 0.2, left: float = 0.1) -> m.Scene:
    """A sand block falling on a fixed spheropolygon plate in a 0.4 × 0.3 m box."""
    scene = m.Scene(domain=((0.0, 0.0), (0.4, 0.3)), cell_size=0.02, gravity=(0.0, -10.0),
                    contact=m.ContactLaw(1e5, restitution=0.5),
                    boundaries={"left": "slip", "right": "slip", "bottom": "slip", "top": "free"})
    scene.add_mpm_body(m.rectangle(left, 0.08, left + width, 0.16),
                       m.MohrCoulomb(1e6, 0.3, 1500.0, 30.0, critical_density=1490.0), velocity=(0.5, -0.5))
    scene.add_rigid_body(rounded_rectangle(0.3, 0.02, 0.005), density=1000.0, position=(0.2, 0.05),
                         motion="fixed", name="floor")
    return scene


def launch_at_once(self, t_now: float, t_stop: float, dt: float) -> int:
    """``Simulation.launch_ahead`` without its CUDA condition: its steps run as it launches them."""
    if not (dt > 0.0 and t_stop > t_now):
        return 0
    self.stage.set_stop_time(t_stop)
    steps = int(self.tuning.launch_ahead_fraction * (t_stop - t_now) / dt)
    if steps > 0:
        self.advance(steps)
    return steps


def datasets(path) -> dict[str, np.ndarray]:
    with h5py.File(path, "r") as f:
        names = []
        f.visit(names.append)
        return {n: f[n][()] for n in names if isinstance(f[n], h5py.Dataset)
                and not n.endswith(("wall_time", "diagnostic_values"))}  # (the table: its columns are the views)


CONFIGS = {"mpm": SolverConfig(precision="f64", dt=2.0e-5),
           "granular": SolverConfig(precision="f64", dt=2.0e-5, granular=True, shape="bspline2")}


@pytest.mark.parametrize("config,batched,fraction", [("mpm", False, 0.5), ("mpm", True, 0.5), ("granular", False, 0.5),
                                                     ("granular", True, 0.5), ("mpm", False, 0.95)],
                         ids=["mpm-lone", "mpm-batch", "granular-lone", "granular-batch", "mpm-lone-0.95"])
def test_a_frame_is_read_before_the_next_steps_are_launched(tmp_path, monkeypatch, config, batched, fraction):
    tuning = m.Tuning(launch_ahead_fraction=fraction)

    def files(out, ahead: bool) -> list[dict]:
        if ahead:
            monkeypatch.setattr(Simulation, "launch_ahead", launch_at_once)
        else:
            monkeypatch.undo()
        cfg = CONFIGS[config]
        if batched:
            b = BatchedSimulation([sand_on_plate(), sand_on_plate(0.15, left=0.15)], cfg, device="cpu", tuning=tuning)
            results = b.run(END, outs=[out / "w0", out / "w1"], frames=FRAMES, names="sand")
        else:
            results = [Simulation(sand_on_plate(), cfg, device="cpu", tuning=tuning).run(
                END, frames=FRAMES, out=out / "w0", name="sand")]
        assert [r.status for r in results] == ["completed"] * len(results)
        return [datasets(r.path) for r in results]

    plain, ahead = files(tmp_path / "plain", False), files(tmp_path / "ahead", True)
    for a, b in zip(plain, ahead, strict=True):
        assert a.keys() == b.keys()
        for name in a:
            np.testing.assert_array_equal(b[name], a[name], err_msg=name)
