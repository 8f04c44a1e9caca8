"""Scenes with few rigid bodies list every body for every point, once (``Tuning.static_imp_bodies``).

A small scene's step is paid per launch, and the Verlet lists cost two per step even when nothing
is rebuilt: the check and a skipped conditional node (~4.8 µs on an H100). With at most
``static_imp_bodies`` bodies, on the devices of ``static_imp_devices`` (the GPU), slot s of every point
holds body s for the whole run, and the force kernel finds the bodies within reach of a point by
their bounding circle and the core's bounding box. It must change no force: a touch is within
reach of an edge or a vertex of the core, or inside it, and the box is never farther than those;
each point sums its bodies in index order, as the sorted lists do. So on the CPU (points visited
in order, the bodies' reactions summed in the same order) the trajectory, the contact forces and
the bodies' motion and loads are the same bits as with the lists. Reference: the Verlet lists,
themselves tested against brute-force lists in tests/sim/test_coupling.py.
"""

import sys

import numpy as np
import pytest
from helpers import ROOT

import mpmdem as m
from mpmdem.model.spheropolygons import rounded_rectangle

sys.path.insert(0, str(ROOT / "bench"))
from step_nodes import step_nodes  # noqa: E402

#: diagnostics that count the lists themselves, not the contacts
LIST_COUNTS = ("imp_pairs", "imp_rebuilds")


#: static lists on the CPU too (by default only on CUDA), and nowhere
STATIC_EVERYWHERE = m.Tuning(static_imp_devices=("cpu", "cuda"))
STATIC_NOWHERE = m.Tuning(static_imp_devices=())


def block_on_a_floor_by_a_square(device, tuning):
    """An elastic block thrown along a long fixed floor (whose bounding circle covers the whole
    scene) into a free rounded square standing on it: contacts made, held with history (the
    block slides), ended; with a free body the DEM stage clears the loads each step."""
    scene = m.Scene(domain=((0.0, 0.0), (1.0, 0.6)), cell_size=0.02, contact=m.ContactLaw(1.0e6, restitution=0.5),
                    gravity=(0.0, -9.81), boundaries=dict.fromkeys(("left", "right", "bottom", "top"), "free"))
    mat = m.NeoHookean(youngs_modulus=2.0e5, poisson_ratio=0.3, density=1000.0)
    scene.add_rigid_body(rounded_rectangle(0.96, 0.04, 0.005), density=1000.0, position=(0.5, 0.05), friction=0.4,
                         motion="fixed")
    scene.add_mpm_body(m.rectangle(0.1, 0.08, 0.2, 0.16), mat, points_per_cell=2, velocity=(2.0, 0.0))
    scene.add_rigid_body(rounded_rectangle(0.1, 0.1, 0.005), density=500.0, position=(0.45, 0.125), friction=0.4)
    return m.Simulation(scene, m.SolverConfig(transfer="APIC", precision="f64"), device=device, tuning=tuning)


def disk_onto_fixed_squares(device, tuning):
    """An elastic disk dropped between two fixed squares tilted towards it: no free body, so
    the fixed bodies' loads (what a user reads as the reaction) are cleared by the coupling."""
    scene = m.Scene(domain=((0.0, 0.0), (1.0, 1.0)), cell_size=0.02, contact=m.ContactLaw(1.0e6, restitution=0.5),
                    gravity=(0.0, -9.81), boundaries=dict.fromkeys(("left", "right", "bottom", "top"), "free"))
    mat = m.NeoHookean(youngs_modulus=2.0e5, poisson_ratio=0.3, density=1000.0)
    scene.add_mpm_body(m.disk(center=(0.5, 0.6), radius=0.08), mat, points_per_cell=2, velocity=(0.3, -2.0))
    for x, angle in ((0.36, 0.4), (0.64, -0.4)):
        scene.add_rigid_body(rounded_rectangle(0.16, 0.16, 0.01), density=1000.0, position=(x, 0.38), angle=angle,
                             friction=0.5, motion="fixed")
    return m.Simulation(scene, m.SolverConfig(transfer="APIC", precision="f64"), device=device, tuning=tuning)


def run(make, device, end, tuning):
    sim = make(device, tuning)
    sim.advance_to(end)
    return sim, sim.fields(), sim.body_fields(), sim.diagnostics()


@pytest.mark.parametrize("make, end", [(block_on_a_floor_by_a_square, 0.11), (disk_onto_fixed_squares, 0.08)],
                         ids=["sliding-block-free-square", "disk-between-fixed-squares"])
def test_every_body_listed_changes_no_force(device, make, end):
    """Verify the static lists give the Verlet lists' trajectory (the same bits on the CPU)."""
    listed, fields, bodies, diag = run(make, device, end, STATIC_NOWHERE)
    assert not listed.coupling.static_lists
    assert diag["imp_rebuilds"] >= 2  # the points moved: the lists were rebuilt and carried history
    static, s_fields, s_bodies, s_diag = run(make, device, end, STATIC_EVERYWHERE)
    assert static.coupling.static_lists and s_diag["imp_rebuilds"] == 0
    assert diag["work_imp_friction"] < -1e-4  # the contacts slid: history was made and used
    # the end falls within an impact: touches on, the bodies loaded by them
    assert diag["imp_contacts"] >= 5 and np.abs(bodies["force"]).max() > 100.0
    if device == "cpu":
        for name in ("x", "v", "contact_force"):
            np.testing.assert_array_equal(s_fields[name], fields[name], err_msg=name)
        for name in ("x", "angle", "v", "omega", "force", "torque"):
            np.testing.assert_array_equal(s_bodies[name], bodies[name], err_msg=name)
        assert {k: v for k, v in s_diag.items() if k not in LIST_COUNTS} == {
            k: v for k, v in diag.items() if k not in LIST_COUNTS}
    else:
        # GPU atomics sum the reactions in another order in every run: f64 round-off grown
        # through the contacts stays far below 1e-6 m (5e-5 of a cell)
        np.testing.assert_allclose(s_fields["x"], fields["x"], rtol=0, atol=1e-6)
        np.testing.assert_allclose(s_bodies["x"], bodies["x"], rtol=0, atol=1e-6)
        assert s_diag["work_imp_friction"] == pytest.approx(diag["work_imp_friction"], rel=1e-6)


def test_many_bodies_keep_the_lists():
    """Verify a scene past ``Tuning.static_imp_bodies`` keeps the Verlet lists, even where static
    lists are on."""
    sim = disk_onto_fixed_squares("cpu", STATIC_EVERYWHERE)
    assert sim.coupling.static_lists
    one = m.Tuning(static_imp_devices=("cpu", "cuda"), static_imp_bodies=1)
    assert not disk_onto_fixed_squares("cpu", one).coupling.static_lists


def test_static_lists_drop_the_check_and_the_conditional_node():
    """Verify normal-force's step with every body listed has no list check and no conditional node
    (6 nodes: the loads' clearing, forces, P2G, grid update, G2P, the clock), as on a GPU."""
    row = step_nodes("normal-force", "cpu", [], STATIC_EVERYWHERE)
    items = "\n".join(row["items"])
    assert row["conditional_nodes"] == 0, items
    assert row["nodes"] == 6, items
    assert "check_lists" not in items and "forces" in items, items
