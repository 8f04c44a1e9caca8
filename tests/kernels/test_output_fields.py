"""A frame's point fields packed on the device (``kernels.output_fields``) are exact copies of the
device arrays, put back in the scene's order: the same values, dtypes and shapes as reading each
array and reordering it on the host."""

import numpy as np

from mpmdem import ContactLaw, LinearElastic, Scene, Simulation, disk, rounded_rectangle


def coupled_scene() -> Scene:
    scene = Scene(domain=((0.0, 0.0), (1.0, 1.0)), cell_size=0.05, gravity=(0.0, -9.81),
                  contact=ContactLaw(1e6, restitution=0.5))
    scene.add_mpm_body(disk((0.3, 0.5), 0.12), LinearElastic(1e6, 0.3, 1000.0), velocity=(0.3, 0.0))
    scene.add_mpm_body(disk((0.7, 0.55), 0.1), LinearElastic(2e6, 0.3, 800.0), velocity=(-0.3, 0.0))
    scene.add_rigid_body(rounded_rectangle(1.0, 0.3, 0.01), density=1000.0, position=(0.5, 0.15), motion="fixed")
    return scene


def test_packed_fields_are_the_arrays_in_scene_order(device):
    sim = Simulation(coupled_scene(), device=device)
    sim.advance_to(0.01)
    mpm = sim.mpm
    P = mpm.points
    pid = P.pid.numpy()
    assert not np.array_equal(pid, np.arange(len(pid)))  # (the device order is not the scene's)

    def scene_order(a):
        host = a.numpy()
        out = np.empty_like(host)
        out[pid] = host
        return out

    expected = {"x": P.x, "v": P.v, "stress": P.stress, "volume": P.vol, "mass": P.mass, "F": P.F,
                "contact_force": P.fcont}
    fields = mpm.fields()
    assert list(fields) == ["x", "v", "stress", "volume", "mass", "F", "body", "contact_force"]
    for name, array in expected.items():
        want, got = scene_order(array), fields[name]
        assert got.dtype == want.dtype and got.shape == want.shape, name
        np.testing.assert_array_equal(got, want, err_msg=name)
        assert got.flags["C_CONTIGUOUS"]
    again = mpm.fields()  # (the device buffer is reused: earlier frames' arrays must not change)
    sim.advance_to(0.02)
    mpm.fields()
    np.testing.assert_array_equal(again["x"], fields["x"])
