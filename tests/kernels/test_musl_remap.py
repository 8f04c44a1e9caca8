"""MUSL's re-mapping P2G inside the velocity G2P (``Tuning.remap_in_g2p``, ``transfer.make_g2p``'s ``remap``).

A MUSL step re-maps the updated point velocities to the grid before it moves the points ("Motion
integration" §3.3). The re-mapping used to be a P2G launch of its own; it now runs in the G2P that
updates the velocities, each thread adding its point's terms m_p (V_p + C_p (x_i − x_p)) N_i once
it has stored V_p and C_p. Every node still receives its points' terms in point order, so on the
CPU the trajectory is the same bits as with the separate launch, for the tent, B-spline and CPDI
stencils, APIC and FLIP, USAVG (whose second half is MUSL's), granular mode (the point's copies)
and the IMP contact. Reference: the separate re-mapping P2G, itself tested against the analytic
cases of tests/sim/test_transfer.py and tests/sim/test_convergence.py and the MUSL studies. On a GPU
the float atomics of both paths add in
an order that varies from run to run: there the two must agree within the rounding of reordered
f64 sums over these few hundred steps (1e-9 m, where a missing or doubled term misses by the
momentum of a point over a step, ~1e-5 m).
"""

import numpy as np
import pytest

import mpmdem as m
from mpmdem.model.spheropolygons import rounded_rectangle

#: largest position difference [m] between the two paths on a GPU (see the module docstring)
ROUNDING = 1.0e-9


def disk_onto_a_square(device: str, shape: str, transfer: str, update: str, granular: bool,
                       tuning: m.Tuning | None = None):
    """A disk (elastic, or granular sand) thrown at a fixed rounded square (IMP contact), with a
    fixed wall and a slip floor."""
    walls = {"left": "fixed", "bottom": "slip", "right": "free", "top": "free"}
    scene = m.Scene(domain=((0.0, 0.0), (1.0, 1.0)), cell_size=0.04, contact=m.ContactLaw(1.0e6, restitution=0.5),
                    gravity=(0.0, -9.81), boundaries=walls)
    mat = (m.MohrCoulomb(youngs_modulus=2.0e5, poisson_ratio=0.3, density=1500.0, friction_angle=30.0) if granular
           else m.NeoHookean(youngs_modulus=2.0e5, poisson_ratio=0.3, density=1000.0))
    scene.add_mpm_body(m.disk(center=(0.3, 0.45), radius=0.1), mat, points_per_cell=2, velocity=(2.0, -0.5))
    scene.add_rigid_body(rounded_rectangle(0.12, 0.12, 0.01), density=1000.0, position=(0.55, 0.4), angle=0.3,
                         friction=0.5, motion="fixed")
    config = m.SolverConfig(shape=shape, transfer=transfer, update=update, precision="f64", granular=granular)
    return m.Simulation(scene, config, device=device, tuning=tuning)


VARIANTS = [
    ("linear", "APIC", "MUSL", True),  # silo-filling's
    ("bspline2", "FLIP", "MUSL", False),
    ("cpdi1", "APIC", "USAVG", False),
]


def run(device, variant, fused: bool):
    # (small non-granular scenes take P2G by stencil rows on a GPU, which keeps its own re-mapping:
    # here a thread a point everywhere, so that both paths run on every device)
    sim = disk_onto_a_square(device, *variant, tuning=m.Tuning(remap_in_g2p=fused, row_p2g_devices=()))
    remaps = [item for item in sim.mpm._sequence if "p2g" in getattr(item.kernel, "key", "")]
    sim.advance_to(0.12)  # the disk reaches the square at ~0.06 s
    return len(remaps), sim.fields(), sim.diagnostics()


@pytest.mark.parametrize("variant", VARIANTS, ids=lambda v: "-".join(str(x) for x in v))
def test_remap_in_g2p_gives_the_separate_remap_trajectory(device, variant):
    """Verify the re-mapping in G2P gives the separate re-mapping P2G's trajectory (the same bits
    on the CPU), through an impact on a fixed body."""
    p2g_apart, fields, diag = run(device, variant, fused=False)
    p2g_fused, fused_fields, fused_diag = run(device, variant, fused=True)
    assert p2g_fused == p2g_apart - 1  # one P2G launch fewer a step
    assert diag["work_imp_friction"] < 0.0  # the disk slid on the square: the contact forces were used
    if device == "cpu":
        for name in ("x", "v", "contact_force", "stress"):
            np.testing.assert_array_equal(fused_fields[name], fields[name], err_msg=name)
        assert fused_diag == diag
    else:
        assert np.abs(fused_fields["x"] - fields["x"]).max() < ROUNDING
