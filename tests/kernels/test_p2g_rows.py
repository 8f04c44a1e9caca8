"""Small scenes on a GPU run P2G a stencil row a thread (``kernels.transfer.make_p2g``'s ``rows``).

Each of the K threads of a point reads the point and adds the K nodes of its row, so a warp's
chain of instructions is shorter (a small scene's P2G is as long as that chain). It must change
nothing a scene computes: every node still receives its points' terms in point order, so on the
CPU the trajectory is the same bits as with a thread a point, for every single-stencil shape, the
affine and force variants, USL's fused impulse, MUSL's re-mapping, and the IMP contact forces.
Reference: the thread-a-point P2G, itself tested against the analytic cases of
tests/sim/test_transfer.py and tests/sim/test_convergence.py.
On a GPU every small non-granular scene of the CUDA suite runs P2G by rows (``Tuning.row_p2g_points``)
and is checked against its own references there.
"""

import numpy as np
import pytest

import mpmdem as m
from mpmdem.model.spheropolygons import rounded_rectangle


def disk_onto_a_square(shape: str, transfer: str, update: str, precision: str, tuning: m.Tuning | None = None):
    """An elastic disk thrown at a fixed rounded square (IMP contact), walls on two sides."""
    scene = m.Scene(domain=((0.0, 0.0), (1.0, 1.0)), cell_size=0.04, contact=m.ContactLaw(1.0e6, restitution=0.5),
                    boundaries={"left": "fixed", "bottom": "slip", "right": "free", "top": "free"})
    mat = m.NeoHookean(youngs_modulus=2.0e5, poisson_ratio=0.3, density=1000.0)
    scene.add_mpm_body(m.disk(center=(0.3, 0.45), radius=0.1), mat, points_per_cell=2, velocity=(2.0, -0.5))
    scene.add_rigid_body(rounded_rectangle(0.12, 0.12, 0.01), density=1000.0, position=(0.55, 0.4), angle=0.3,
                         friction=0.5, motion="fixed")
    config = m.SolverConfig(shape=shape, transfer=transfer, update=update, precision=precision)
    return m.Simulation(scene, config, device="cpu", tuning=tuning)


@pytest.mark.parametrize("variant", [
    ("ugimp", "PIC", "USL", "f64"),  # normal-force's
    ("bspline2", "APIC", "USL", "f32"),
    ("linear", "FLIP", "MUSL", "f64"),
    ("bspline3", "APIC", "USF", "f64"),
], ids="-".join)
def test_p2g_by_rows_changes_nothing(variant):
    """Verify P2G by stencil rows gives the thread-a-point trajectory, to the bit on the CPU."""
    runs = {}
    for rows in (False, True):
        sim = disk_onto_a_square(*variant, tuning=m.Tuning(row_p2g_devices=("cpu", "cuda") if rows else ()))
        assert sim.mpm.p2g_rows(sim.mpm.p2g_tile()) == rows
        sim.advance_to(0.12)  # the disk reaches the square at ~0.06 s
        runs[rows] = sim.fields(), sim.diagnostics()
    (plain, plain_diag), (by_rows, rows_diag) = runs[False], runs[True]
    assert plain_diag["work_imp_friction"] < 0.0  # the disk slid on the square: the contact term was used
    for name in ("x", "v", "contact_force"):
        np.testing.assert_array_equal(by_rows[name], plain[name], err_msg=name)
    assert rows_diag == plain_diag
