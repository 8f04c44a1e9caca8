"""Scenes of few rigid bodies list every body pair once (``dem.STATIC_PAIR_BODIES``).

A small scene's step is paid per launch, and the DEM's Verlet lists cost a conditional node per
step (~4.8 µs on an H100) even when nothing is rebuilt. With at most STATIC_PAIR_BODIES bodies, on
the devices of STATIC_PAIR_DEVICES (the GPU), every pair that can touch (one body free) is listed
for the whole run, owned and ordered as the list build would list it, and the contact kernel tests
its bounding circles as it does a listed pair's. It must change no force: on the CPU the bodies'
and the points' trajectories are the same bits as with the lists. The lists fold a pair's
dissipated work into its bodies' totals at each rebuild; the static pairs keep it in the pair, so
the dissipated totals agree to round-off, not to the bit. Reference: the Verlet lists, themselves
tested against brute-force lists in tests/test_dem.py.
"""

import numpy as np
import pytest

import mpmdem as m
from mpmdem import dem

#: diagnostics summed in another order (the dissipated work of the pairs), or counting the lists
REORDERED = ("work_contact_damping", "work_contact_friction")
LIST_COUNTS = ("list_rebuilds", "listed_pairs")


def pentagons_on_a_ramp(device):
    """Five pentagons dropped onto a fixed ramp beside a long fixed wall (a large body: its pairs
    are owned by the small ones), bouncing, sliding and colliding."""
    scene = m.Scene(domain=((0.0, 0.0), (1.0, 1.0)), contact=m.ContactLaw(2.0e5, restitution=0.4),
                    gravity=(0.0, -9.81))
    scene.add_rigid_body(m.rounded_rectangle(1.0, 0.05, 0.005), density=1000.0, position=(0.5, 0.2), angle=-0.2,
                         friction=0.5, motion="fixed")
    scene.add_rigid_body(m.rounded_rectangle(0.05, 0.9, 0.005), density=1000.0, position=(0.9, 0.5),
                         friction=0.3, motion="fixed")
    for k in range(5):
        scene.add_rigid_body(m.regular_polygon(5, 0.05, radius=0.004), density=800.0,
                             position=(0.25 + 0.12 * k, 0.45 + 0.07 * (k % 2)), angle=0.3 * k, friction=0.4)
    return m.Simulation(scene, m.SolverConfig(precision="f64"), device=device)


def block_into_a_free_square(device):
    """An elastic block thrown along a fixed floor into a free square standing on it (points and
    bodies: the body pair floor–square, and the points' contacts)."""
    scene = m.Scene(domain=((0.0, 0.0), (1.0, 0.6)), cell_size=0.02, contact=m.ContactLaw(1.0e6, restitution=0.5),
                    gravity=(0.0, -9.81), boundaries=dict.fromkeys(("left", "right", "bottom", "top"), "free"))
    mat = m.NeoHookean(youngs_modulus=2.0e5, poisson_ratio=0.3, density=1000.0)
    scene.add_rigid_body(m.rounded_rectangle(0.96, 0.04, 0.005), density=1000.0, position=(0.5, 0.05), friction=0.4,
                         motion="fixed")
    scene.add_mpm_body(m.rectangle(0.1, 0.08, 0.2, 0.16), mat, points_per_cell=2, velocity=(2.0, 0.0))
    scene.add_rigid_body(m.rounded_rectangle(0.1, 0.1, 0.005), density=500.0, position=(0.45, 0.125), friction=0.4)
    return m.Simulation(scene, m.SolverConfig(transfer="APIC", precision="f64"), device=device)


@pytest.mark.parametrize("make, end", [(pentagons_on_a_ramp, 0.4), (block_into_a_free_square, 0.12)],
                         ids=["pentagons-on-a-ramp", "block-into-a-free-square"])
def test_every_pair_listed_changes_no_force(monkeypatch, make, end):
    """Verify the static pairs give the Verlet lists' trajectory, to the bit on the CPU."""
    runs = {}
    for static in (False, True):
        monkeypatch.setattr(dem, "STATIC_PAIR_DEVICES", ("cpu", "cuda") if static else ())
        sim = make("cpu")
        assert sim.dem.static_pairs == static
        sim.advance_to(end)
        runs[static] = sim.body_fields(), (sim.fields() if sim.mpm is not None else {}), sim.diagnostics()
    (bodies, points, diag), (s_bodies, s_points, s_diag) = runs[False], runs[True]
    # the first build and at least one rebuild: the bodies moved
    assert diag["list_rebuilds"] >= 2 and s_diag["list_rebuilds"] == 0
    assert diag["work_contact_friction"] < 0.0  # bodies slid: history made and used
    for name in ("x", "angle", "v", "omega", "force", "torque"):
        np.testing.assert_array_equal(s_bodies[name], bodies[name], err_msg=name)
    for name in points:
        np.testing.assert_array_equal(s_points[name], points[name], err_msg=name)
    for name, value in diag.items():
        if name in LIST_COUNTS:
            continue
        if name in REORDERED:
            assert s_diag[name] == pytest.approx(value, rel=1e-9, abs=1e-12), name
        else:
            assert s_diag[name] == value, name


def test_many_bodies_keep_the_lists(monkeypatch):
    """Verify a scene past STATIC_PAIR_BODIES keeps the Verlet lists, even where static pairs are on."""
    monkeypatch.setattr(dem, "STATIC_PAIR_DEVICES", ("cpu", "cuda"))
    assert pentagons_on_a_ramp("cpu").dem.static_pairs
    monkeypatch.setattr(dem, "STATIC_PAIR_BODIES", 6)
    assert not pentagons_on_a_ramp("cpu").dem.static_pairs


def test_sand_blocks_step_on_a_gpu_has_no_list_node(monkeypatch):
    """Verify sand-blocks' step with every pair and every point–body pair listed (as on a GPU) has
    no list check and no conditional node but the granular relabel's."""
    import sys
    from pathlib import Path

    from mpmdem import coupling

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))
    from step_nodes import step_nodes

    monkeypatch.setattr(dem, "STATIC_PAIR_DEVICES", ("cpu", "cuda"))
    monkeypatch.setattr(coupling, "STATIC_IMP_DEVICES", ("cpu", "cuda"))
    row = step_nodes("sand-blocks", "cpu", [])
    top = [item for item in row["items"] if not item.startswith(" ")]
    items = "\n".join(row["items"])
    assert sum(item.startswith("if") for item in top) == 1, items  # (the relabel)
    assert not any(name in items for name in ("check_displacement", "check_lists", "build_lists")), items
    assert row["nodes"] == 11, items
