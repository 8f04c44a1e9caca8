"""The coupled step's parallel branches in a CUDA graph (``mpmdem.sim.step_streams``).

On CUDA, outside deterministic mode, the coupled step is recorded on three streams: the body–body
contact forces and the body update on a side branch beside the IMP forces and the MPM passes, and,
in granular mode with the relabel laid in line, the IMP forces on a second branch beside the
relabel's kernels, joined before P2G. A missing edge between the branches would let a launch read
its inputs before they were written: a body moved before the points' reactions (or the body–body
forces) were in its loads, loads cleared after a contact had added to them, or a P2G that read the
last step's contact forces. Each misses the one-stream trajectory by a contact impulse over a step
(dt² f / m ~ 1e-6 m in these runs). The granular run lays every Granular MPM block in line
(``Tuning.inline_above`` and ``conditional_below`` at or below any rate), so that its IMP forces
take their branch.

Reference: the same scene in deterministic mode, which takes no branch (one stream, ordered
atomics). The two differ otherwise only by the order of float atomics in the branched run, f64
sums reordered: ~1e-13 m over these few thousand steps, so the bound 1e-9 m holds by four
orders of magnitude while staying three under a missed edge's error.
"""

import numpy as np
import pytest
from conftest import HAS_CUDA

import mpmdem as m
from mpmdem.model.spheropolygons import rounded_rectangle

#: largest allowed position difference [m] (see the module docstring)
ROUNDING = 1.0e-9

pytestmark = [pytest.mark.cuda, pytest.mark.skipif(
    not HAS_CUDA, reason="no CUDA device here: the CUDA items run on the GPU machine (pytest -m cuda)")]


#: every Granular MPM block laid in line, whatever its rate
IN_LINE = m.Tuning(inline_above=0.0, conditional_below=-1.0)


def disk_onto_a_square_on_a_floor(granular: bool, **config):
    """An elastic (or granular) disk thrown down onto a free rounded square resting on a fixed floor:
    points touch the square (history, reactions on a free body) while the square presses on the
    floor (a body–body contact)."""
    scene = m.Scene(domain=((0.0, 0.0), (0.6, 0.6)), cell_size=0.02, contact=m.ContactLaw(1.0e6, restitution=0.5),
                    gravity=(0.0, -9.81), boundaries=dict.fromkeys(("left", "right", "bottom", "top"), "slip"))
    mat = (m.MohrCoulomb(youngs_modulus=2.0e5, poisson_ratio=0.3, density=1500.0, friction_angle=30.0) if granular
           else m.NeoHookean(youngs_modulus=2.0e5, poisson_ratio=0.3, density=1000.0))
    scene.add_rigid_body(rounded_rectangle(0.5, 0.04, 0.005), density=1000.0, position=(0.3, 0.05), friction=0.4,
                         motion="fixed")
    scene.add_rigid_body(rounded_rectangle(0.12, 0.12, 0.005), density=500.0, position=(0.32, 0.135), friction=0.4)
    scene.add_mpm_body(m.disk(center=(0.3, 0.3), radius=0.06), mat, points_per_cell=2, velocity=(0.4, -2.5))
    return m.Simulation(scene, m.SolverConfig(precision="f64", granular=granular, **config), device="cuda",
                        tuning=IN_LINE)


def run(granular: bool, end: float, **config):
    sim = disk_onto_a_square_on_a_floor(granular, **config)
    sim.advance_to(end)
    return sim, sim.fields(), sim.body_fields(), sim.diagnostics()


@pytest.mark.parametrize("granular", [False, True], ids=["elastic", "granular"])
def test_parallel_branches_of_a_coupled_graph_give_the_one_stream_trajectory(granular):
    """Verify a CUDA run whose step graph has parallel branches gives the one-stream run's
    trajectory within rounding, through an impact on a free body resting on a fixed one."""
    end = 0.025  # (within the impact: the disk touches the square from ~0.015 s to ~0.035 s)
    one, fields, bodies, diag = run(granular, end, deterministic=True)
    branched, b_fields, b_bodies, b_diag = run(granular, end)
    assert not one.coupling.streams.enabled and branched.coupling.streams.enabled
    if granular:  # (the relabel's kernels were recorded after the last conditional node: the IMP branch)
        assert all(layout.inline for layout in branched.block_layouts)
    # the run is an impact: points touch the square, which is pushed into the floor
    assert np.abs(fields["contact_force"]).max() > 1.0 and diag["imp_contacts"] >= 3
    assert np.abs(bodies["v"]).max() > 0.05
    assert np.abs(b_fields["x"] - fields["x"]).max() < ROUNDING
    assert np.abs(b_bodies["x"] - bodies["x"]).max() < ROUNDING
