"""Rigid bodies that start overlapping each other are refused (by name, with the depth) unless the
scene opts in for a pre-stressed pack; then a blow-up names the overlap as its likely cause."""

import math

import pytest

from mpmdem import BlowUpError, ContactLaw, InputError, Scene, Simulation, rod, rounded_rectangle, sphero_disk

R = 0.05  # [m] the disks


def two_disks(overlap, *, gravity=(0.0, 0.0), allow=False):
    scene = Scene(domain=((0.0, 0.0), (1.0, 1.0)), gravity=gravity, contact=ContactLaw(1e6, restitution=0.5),
                  allow_initial_overlap=allow)
    scene.add_rigid_body(sphero_disk(R), density=1000.0, position=(0.5, 0.5), name="left")
    scene.add_rigid_body(sphero_disk(R), density=1000.0, position=(0.5 + 2 * R - overlap, 0.5), name="right")
    return scene


@pytest.mark.parametrize("overlap", [0.08, 0.005])
def test_overlapping_free_disks_are_refused_by_name(overlap):
    """Verify two free disks overlapping by 80 mm or 5 mm (R = 50 mm) are an InputError naming both
    bodies and the overlap, before any kernel runs."""
    with pytest.raises(InputError, match=r"'left' and 'right'.*overlapping by 0\.0") as err:
        Simulation(two_disks(overlap), device="cpu")
    assert f"{overlap:.4g}" in str(err.value) and "allow_initial_overlap" in str(err.value)


@pytest.mark.parametrize("overlap", [0.0, 1e-4])
def test_touching_or_slightly_overlapping_disks_pass(overlap):
    """Verify disks built exactly touching, or 0.1 mm deep (0.2 % of R, under the 1 % floor), pass."""
    two_disks(overlap).validate()


def test_resting_pile_overlap_under_gravity_passes():
    """Verify a contact as deep as a resting pile's under gravity passes: 1 mm is 2 % of R, but the
    weight of a 1 m column 0.1 m wide of 1000 kg/m³ on k_n = 1e6 N/m per m is 0.98 mm (x 3 allowed)."""
    two_disks(0.001, gravity=(0.0, -9.81)).validate()
    with pytest.raises(InputError, match="'left' and 'right'"):
        two_disks(0.001).validate()  # no gravity: no pile, the 1 % floor (0.5 mm) applies


def test_crossing_cores_are_measured_by_their_deepest_vertex():
    """Verify two rods whose cores cross report the depth a_i + a_j + the deepest core vertex inside."""
    scene = Scene(domain=((0.0, 0.0), (1.0, 1.0)), contact=ContactLaw(1e6))
    scene.add_rigid_body(rounded_rectangle(0.2, 0.1, 0.005), density=1000.0, position=(0.5, 0.5), name="a")
    scene.add_rigid_body(rounded_rectangle(0.2, 0.1, 0.005), density=1000.0, position=(0.53, 0.57), name="b")
    # rectangles 0.1 m tall 0.07 m apart overlap by 0.03 m: cores 0.09 tall cross by 0.02, + a_i + a_j
    assert scene.initial_overlaps() == [("a", "b", pytest.approx(0.03, rel=1e-12))]
    scene = Scene(domain=((0.0, 0.0), (1.0, 1.0)), contact=ContactLaw(1e6))
    scene.add_rigid_body(rod(0.2, 0.01), density=1000.0, position=(0.5, 0.5), name="x")
    scene.add_rigid_body(rod(0.2, 0.01), density=1000.0, position=(0.5, 0.5), angle=math.pi / 2, name="y")
    # an X of rods: the cores cross at their middles, no vertex inside the other: a_i + a_j
    assert scene.initial_overlaps() == [("x", "y", pytest.approx(0.02, rel=1e-12))]


def test_fixed_bodies_may_overlap_each_other():
    """Verify walls meeting at a corner (fixed–fixed) are no overlap: fixed bodies never interact."""
    scene = Scene(domain=((0.0, 0.0), (1.0, 1.0)), contact=ContactLaw(1e6))
    scene.add_walls(("left", "bottom", "right"))
    scene.add_rigid_body(rounded_rectangle(0.5, 0.5), density=1000.0, position=(0.2, 0.2), motion="fixed")
    scene.add_rigid_body(sphero_disk(R), density=1000.0, position=(0.5, 0.9))
    assert scene.initial_overlaps() == []
    scene.validate()


def test_opt_in_runs_and_a_blow_up_names_the_overlap():
    """Verify Scene(allow_initial_overlap=True) builds the 80 mm overlap, and that when the run blows
    up the message names the initial overlap rather than only the time step."""
    sim = Simulation(two_disks(0.08, allow=True), device="cpu")
    try:
        sim.run(0.2, frames=4)
    except BlowUpError as e:
        assert "initial overlap of rigid bodies 'left' and 'right'" in str(e)
    else:  # no blow-up: the overlap turned into speed instead (the 5 mm case flies apart at 1.18 m/s)
        assert sim.dem.initial_overlaps[0][:2] == ("left", "right")
    assert "initial overlap of rigid bodies 'left' and 'right'" in sim.dem.likely_cause(1e-4)
