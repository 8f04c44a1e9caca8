"""The IMP contact forces spread by a launch of their own, and the coupled step's parallel branches.

On CUDA (``mpm.SPREAD_CONTACT_DEVICES``) the IMP scheme's contact forces reach the grid through
``kernels.contact_spread`` instead of the P2G pass (MPM-SDEM eq. 47-48), so that the IMP forces
and P2G run as parallel branches of the step's graph (``mpmdem.step_streams``). The nodal forces
are the same sums added in another order, so the reference is the P2G path itself, run on the same
device: the two trajectories may differ only by the rounding of reordered f64 sums. Over a few
hundred explicit steps of an impact that stays far below 1e-9 m (a touch turned on or off one step
apart by a rounding would move a point by about dt² f/m, ~1e-10 m here). A spread with a wrong
weight, node, or dt misses by the whole contact impulse, ~1e-4 m in these runs.

The branches themselves exist only inside a CUDA graph: the CUDA item runs the same scene with
(default) and without branches (deterministic mode, one stream) and compares within the same
rounding argument; a branch that read its inputs before they were written (a missing edge) drops
or doubles a contact load and misses by the impulse.
"""

import numpy as np
import pytest

import mpmdem as m
from conftest import HAS_CUDA
from mpmdem import mpm as mpm_module
from mpmdem.spheropolygons import rounded_rectangle

#: largest allowed position difference [m]: reordered f64 sums only (see the module docstring)
ROUNDING = 1.0e-9


def disk_onto_a_square_on_a_floor(device, **config):
    """An elastic disk thrown down onto a free rounded square resting on a fixed floor: points
    touch the square (history, reactions on a free body) while the square presses on the floor."""
    scene = m.Scene(domain=((0.0, 0.0), (0.6, 0.6)), cell_size=0.02, contact=m.ContactLaw(1.0e6, restitution=0.5),
                    gravity=(0.0, -9.81), boundaries=dict.fromkeys(("left", "right", "bottom", "top"), "slip"))
    mat = m.NeoHookean(youngs_modulus=2.0e5, poisson_ratio=0.3, density=1000.0)
    scene.add_rigid_body(rounded_rectangle(0.5, 0.04, 0.005), density=1000.0, position=(0.3, 0.05), friction=0.4,
                         motion="fixed")
    scene.add_rigid_body(rounded_rectangle(0.12, 0.12, 0.005), density=500.0, position=(0.32, 0.135), friction=0.4)
    scene.add_mpm_body(m.disk(center=(0.3, 0.3), radius=0.06), mat, points_per_cell=2, velocity=(0.4, -2.5))
    return m.Simulation(scene, m.SolverConfig(precision="f64", **config), device=device)


def run(device, end, **config):
    sim = disk_onto_a_square_on_a_floor(device, **config)
    sim.advance_to(end)
    return sim, sim.fields(), sim.body_fields(), sim.diagnostics()


VARIANTS = {
    "USL-PIC (fused impulse)": dict(transfer="PIC", shape="ugimp"),
    "MUSL-FLIP bspline2": dict(transfer="FLIP", update="MUSL", shape="bspline2"),
    "USL-APIC cpdi1": dict(transfer="APIC", shape="cpdi1"),
}


@pytest.mark.parametrize("variant", list(VARIANTS), ids=list(VARIANTS))
def test_spread_contact_forces_give_the_p2g_path_trajectory(monkeypatch, variant):
    """Verify the contact forces spread by their own launch give P2G's trajectory within rounding."""
    config = VARIANTS[variant]
    end = 0.025  # (within the impact: the disk touches the square from ~0.015 s to ~0.035 s)
    monkeypatch.setattr(mpm_module, "SPREAD_CONTACT_DEVICES", ())
    in_p2g, fields, bodies, diag = run("cpu", end, **config)
    assert not in_p2g.mpm.contact_spread
    monkeypatch.setattr(mpm_module, "SPREAD_CONTACT_DEVICES", ("cpu", "cuda"))
    spread, s_fields, s_bodies, s_diag = run("cpu", end, **config)
    assert spread.mpm.contact_spread
    # the run is an impact: points touch the square, which is pushed into the floor
    assert np.abs(fields["contact_force"]).max() > 1.0 and diag["imp_contacts"] >= 3
    assert np.abs(bodies["v"]).max() > 0.05
    assert np.abs(s_fields["x"] - fields["x"]).max() < ROUNDING
    assert np.abs(s_bodies["x"] - bodies["x"]).max() < ROUNDING
    assert np.abs(s_fields["v"] - fields["v"]).max() < 1.0e3 * ROUNDING  # (v ~ x / dt: ~1e-5 s steps)


def test_contact_forces_stay_in_p2g_where_a_stress_update_comes_first(monkeypatch):
    """Verify USF keeps the contact forces in its force P2G: a stress update before it moves a
    deforming domain's stencil (CPDI here), and a spread made before it missed P2G's nodal forces
    by 1.4e-6 m in this run."""
    monkeypatch.setattr(mpm_module, "SPREAD_CONTACT_DEVICES", ("cpu", "cuda"))
    sim = disk_onto_a_square_on_a_floor("cpu", transfer="APIC", update="USF", shape="cpdi1")
    assert not sim.mpm.contact_spread


@pytest.mark.cuda
@pytest.mark.skipif(not HAS_CUDA, reason="no CUDA device here: the CUDA items run on the GPU machine (pytest -m cuda)")
@pytest.mark.parametrize("variant", list(VARIANTS)[:2], ids=list(VARIANTS)[:2])
def test_parallel_branches_of_a_coupled_graph_give_the_one_stream_trajectory(variant):
    """Verify a CUDA run whose step graph has parallel branches (the DEM's contact forces and body
    update; the IMP forces and their spread beside P2G) gives the one-stream run's trajectory
    (deterministic mode takes no branch) within rounding."""
    config = VARIANTS[variant]
    end = 0.025  # (within the impact: the disk touches the square from ~0.015 s to ~0.035 s)
    one, fields, bodies, diag = run("cuda", end, deterministic=True, **config)
    branched, b_fields, b_bodies, b_diag = run("cuda", end, **config)
    assert not one.coupling.streams.enabled and branched.coupling.streams.enabled
    assert branched.mpm.contact_spread and not one.mpm.contact_spread
    assert np.abs(fields["contact_force"]).max() > 1.0 and diag["imp_contacts"] >= 3
    assert np.abs(b_fields["x"] - fields["x"]).max() < ROUNDING
    assert np.abs(b_bodies["x"] - bodies["x"]).max() < ROUNDING
