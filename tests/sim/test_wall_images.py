"""The wall images without launches of their own (``Tuning.mirror_in_g2p``, ``Tuning.fold_in_grid_update``).

Beyond a fixed or slip wall, wide stencils reach ghost nodes. What points put there is folded
onto the interior mirrors before the grid update, and after it the ghosts take the mirrors'
velocities, reflected (odd in every component at a fixed wall, in the normal one at a slip wall).
Each was a launch per grid update; a small scene pays per launch, so G2P now reads the mirror's
velocities where a stencil node is a ghost (in granular mode, the mirror's copy of the point's
component), and a grid update that clears and re-maps nothing folds its own node's images first.
Neither may change anything: the same values reach every node and point, so on the CPU the
trajectory is the same bits as with the launches, in both the plain and the granular grid, USL,
MUSL, USF and USAVG. Reference: the launches, themselves tested against the wall conditions in
tests/sim/test_walls.py and tests/sim/test_transfer.py.
"""

import numpy as np
import pytest

import mpmdem as m


def pile_in_a_box(granular: bool, shape: str, transfer: str, update: str, damping: float = 0.0,
                  tuning: m.Tuning | None = None):
    """A block thrown into the lower right corner of a box (slip floor, fixed right side) under gravity:
    points reach the ghost nodes of two walls and of the corner."""
    scene = m.Scene(domain=((0.0, 0.0), (0.3, 0.3)), cell_size=0.01, gravity=(0.0, -9.81),
                    boundaries={"left": "slip", "right": "fixed", "bottom": "slip", "top": "free"})
    if granular:
        mat = m.MohrCoulomb(2.0e5, 0.3, 1500.0, friction_angle=30.0, critical_density=1485.0)
    else:
        mat = m.NeoHookean(youngs_modulus=2.0e5, poisson_ratio=0.3, density=1000.0)
    scene.add_mpm_body(m.rectangle(0.16, 0.0, 0.26, 0.1), mat, points_per_cell=2, velocity=(2.0, -1.0))
    config = m.SolverConfig(granular=granular, shape=shape, transfer=transfer, update=update, precision="f64",
                            damping=damping)
    return m.Simulation(scene, config, device="cpu", tuning=tuning)


VARIANTS = [
    (False, "bspline2", "APIC", "USL"),
    (False, "bspline3", "FLIP", "MUSL"),
    (False, "cpgimp", "PIC", "USL"),
    (False, "bspline2", "APIC", "USF"),
    (False, "bspline2", "FLIP", "USAVG"),
    (True, "bspline2", "PIC", "MUSL"),
    (True, "bspline2", "FLIP", "USL"),
]


@pytest.mark.parametrize("flag", ["mirror_in_g2p", "fold_in_grid_update"])
@pytest.mark.parametrize("variant", VARIANTS, ids=lambda v: ("granular-" if v[0] else "") + "-".join(v[1:]))
def test_wall_images_without_their_launches_change_nothing(variant, flag):
    """Verify G2P reading the wall images, and grid updates folding them, give the trajectory of
    the fold and mirror launches, to the bit."""
    runs = {}
    for fused in (False, True):
        sim = pile_in_a_box(*variant, tuning=m.Tuning(**{flag: fused}))
        launches = [getattr(item, "kernel", None) for item in sim.mpm._sequence]
        names = [k.key for k in launches if k is not None]
        if flag == "mirror_in_g2p":
            assert sim.mpm.mirror_in_g2p == (fused and variant[3] in ("USL", "MUSL"))
        else:
            folds = sum("fold_ghosts" in name for name in names)
            # (USF and USAVG: G2P does not read the wall images, so their clearing update keeps its fold)
            assert folds == {"USL": 1 - fused, "MUSL": 2 - 2 * fused, "USF": 2 - fused, "USAVG": 3 - 2 * fused}[
                variant[3]]
        sim.advance_to(0.02)  # (the block reaches the right wall at ~0.01 s and bounces off by ~0.03 s)
        runs[fused] = sim.fields(), sim.diagnostics()
    (plain, plain_diag), (fused, fused_diag) = runs[False], runs[True]
    x = plain["x"]
    h = 0.01
    # points came within a stencil of the floor and the right wall: ghost nodes were read
    assert x[:, 1].min() < 1.5 * h and x[:, 0].max() > 0.3 - 1.5 * h
    for name in ("x", "v"):
        np.testing.assert_array_equal(fused[name], plain[name], err_msg=name)
    assert fused_diag == plain_diag


def test_xpic_keeps_the_mirror_launch():
    """Verify XPIC, whose smoothing passes read the ghosts' velocities, keeps the launch."""
    scene = m.Scene(domain=((0.0, 0.0), (0.3, 0.3)), cell_size=0.01, boundaries={"bottom": "fixed", "top": "free"})
    scene.add_mpm_body(m.rectangle(0.1, 0.0, 0.2, 0.1), m.NeoHookean(2.0e5, 0.3, 1000.0))
    sim = m.Simulation(scene, m.SolverConfig(transfer="XPIC"), device="cpu")
    assert not sim.mpm.mirror_in_g2p


@pytest.mark.parametrize("granular", [False, True])
def test_channel_one_cell_wide_folds_to_the_same_bits_and_a_clear_grid(granular):
    """Verify a channel one cell wide (the cubic B-spline's images of one wall land on the other
    wall's node line) gives the same bits with the images folded in the clearing grid update, and
    a clear grid after the step, every ghost copy read cleared by the node that folds it."""
    runs = {}
    for fused in (False, True):
        scene = m.Scene(domain=((0.0, 0.0), (0.01, 0.2)), cell_size=0.01, gravity=(0.0, -9.81),
                        boundaries={"left": "slip", "right": "fixed", "bottom": "slip", "top": "free"})
        mat = (m.MohrCoulomb(2.0e5, 0.3, 1500.0, friction_angle=30.0, critical_density=1485.0) if granular
               else m.NeoHookean(youngs_modulus=2.0e5, poisson_ratio=0.3, density=1000.0))
        scene.add_mpm_body(m.rectangle(0.0, 0.02, 0.01, 0.1), mat, points_per_cell=2, velocity=(0.5, -1.0))
        sim = m.Simulation(scene, m.SolverConfig(granular=granular, shape="bspline3", transfer="PIC", precision="f64"),
                           device="cpu", tuning=m.Tuning(fold_in_grid_update=fused))
        names = [getattr(item, "kernel", None) for item in sim.mpm._sequence]
        assert sum(k is not None and "fold_ghosts" in k.key for k in names) == 1 - fused
        sim.advance_to(0.03)
        # the step's last grid update leaves the grid clear for the next P2G, ghosts included
        assert not np.any(sim.mpm.G.mass.numpy()) and not np.any(sim.mpm.G.mom.numpy())
        runs[fused] = sim.fields(), sim.diagnostics()
    (plain, plain_diag), (fused, fused_diag) = runs[False], runs[True]
    for name in ("x", "v"):
        np.testing.assert_array_equal(fused[name], plain[name], err_msg=name)
    assert fused_diag == plain_diag


def test_damped_grid_keeps_its_ghost_updates():
    """Verify a damped scene (Cundall's damping does work at the ghost nodes too, in the energy
    balance) keeps the clearing update's fold launch, and so its ghosts' updates: the same bits,
    diagnostics included."""
    runs = {}
    for fused in (False, True):
        sim = pile_in_a_box(False, "bspline2", "PIC", "USL", damping=0.2,
                            tuning=m.Tuning(fold_in_grid_update=fused))
        names = [getattr(item, "kernel", None) for item in sim.mpm._sequence]
        assert sum(k is not None and "fold_ghosts" in k.key for k in names) == 1
        sim.advance_to(0.02)
        runs[fused] = sim.fields(), sim.diagnostics()
    (plain, plain_diag), (fused, fused_diag) = runs[False], runs[True]
    assert plain_diag["work_damping"] < 0.0
    np.testing.assert_array_equal(fused["x"], plain["x"])
    assert fused_diag == plain_diag


def test_large_scenes_keep_the_wall_image_launches():
    """Verify a scene of ``Tuning.images_in_kernels_points`` points or more keeps the fold and mirror launches
    (in a large scene the work they add to G2P and the grid update costs more than the launches)."""
    sim = pile_in_a_box(False, "bspline2", "APIC", "MUSL")
    assert sim.mpm.mirror_in_g2p
    sim = pile_in_a_box(False, "bspline2", "APIC", "MUSL",
                        tuning=m.Tuning(images_in_kernels_points=sim.particle_count))
    names = [k.key for k in (getattr(item, "kernel", None) for item in sim.mpm._sequence) if k is not None]
    assert not sim.mpm.mirror_in_g2p
    assert sum("fold_ghosts" in name for name in names) == 2 and sum("mirror_ghosts" in name for name in names) == 2
