"""Large coupled scenes sift the listed points before the IMP force search (``kernels.coupling.sift``).

The sift ends the contacts of listed points that no body can reach this step (outside every
listed body's bounding circle) and packs the rest for the force kernel, which then searches only
those. It must change nothing a scene computes: on the CPU (points sifted in list order, so the
bodies' reactions are summed in the same order) the trajectory, the contact forces and the
bodies' motion are the same bits as with the unsifted force kernel. Reference: the unsifted
kernel, itself tested against the brute-force lists and contact laws in tests/test_coupling.py.
"""

import numpy as np
import pytest

import mpmdem as m
from mpmdem import coupling
from mpmdem.spheropolygons import rounded_rectangle


def disk_onto_a_spinning_square(device):
    """A frictional, oblique disk–square impact (contacts made, held with history, and ended)."""
    scene = m.Scene(domain=((0.0, 0.0), (1.0, 1.0)), cell_size=0.02, contact=m.ContactLaw(1.0e6, restitution=0.5),
                    boundaries=dict.fromkeys(("left", "right", "bottom", "top"), "free"))
    mat = m.NeoHookean(youngs_modulus=2.0e5, poisson_ratio=0.3, density=1000.0)
    scene.add_mpm_body(m.disk(center=(0.3, 0.45), radius=0.08), mat, points_per_cell=2, velocity=(2.0, 0.3))
    scene.add_rigid_body(rounded_rectangle(0.12, 0.12, 0.01), density=1000.0, position=(0.55, 0.55), angle=0.3,
                         friction=0.5)
    return m.Simulation(scene, m.SolverConfig(transfer="APIC", precision="f64"), device=device)


def run(device):
    sim = disk_onto_a_spinning_square(device)
    sim.advance_to(0.1)  # contact from ~0.05 s to ~0.08 s: made, held and ended
    return sim, sim.fields(), sim.body_fields(), sim.diagnostics()


def test_sifted_force_search_changes_nothing(monkeypatch, device):
    """Verify the sifted IMP forces give the unsifted run's trajectory (the same bits on the CPU)."""
    plain, fields, bodies, diag = run(device)
    assert not plain.coupling.sifted  # a small scene: the force kernel over every listed point
    monkeypatch.setattr(coupling, "SIFTED_IMP_POINTS", 0)
    sifted, s_fields, s_bodies, s_diag = run(device)
    assert sifted.coupling.sifted
    assert diag["work_imp_friction"] < -0.01  # the contact slid: history was made and used
    if device == "cpu":
        for name in ("x", "v", "contact_force"):
            np.testing.assert_array_equal(s_fields[name], fields[name], err_msg=name)
        for name in ("x", "v", "omega"):
            np.testing.assert_array_equal(s_bodies[name], bodies[name], err_msg=name)
        assert s_diag["work_imp_friction"] == diag["work_imp_friction"]
    else:
        # GPU atomics sum the reactions in another order in every run (sifted or not): f64
        # round-off, grown through one contact, stays far below 1e-6 m (5e-5 of a cell)
        np.testing.assert_allclose(s_fields["x"], fields["x"], rtol=0, atol=1e-6)
        np.testing.assert_allclose(s_bodies["omega"], bodies["omega"], rtol=1e-6)
        assert s_diag["work_imp_friction"] == pytest.approx(diag["work_imp_friction"], rel=1e-6)
