"""The shared-memory P2G of large CUDA scenes (``make_p2g(tile=...)``, ``MPMSolver.p2g_tile``).

A block of cell-sorted points sums its mass and momentum in a tile of nodes and adds the tile to
the grid once; nodes outside the tile take the global atomic. Either way every point-node term
is added once, so the grid must hold what the one-atomic-per-term P2G gives, up to the order of
the float sums: at most 9 points × 4 sub-terms meet at a node per block, so f32 sums reordered
differ by a few ε of the largest term; 1e-5 of the field's largest value bounds that.
"""

import numpy as np
import pytest

from mpmdem import NeoHookean, Scene, Simulation, SolverConfig, rectangle
from mpmdem.kernels import transfer
from mpmdem.kernels.clock import CLOCK_DT
from mpmdem.mpm import TILED_P2G_BLOCK, TILED_P2G_POINTS

BLOCK = 64


def p2g_fields(sim, tile):
    """Grid mass and momentum after the fused USL P2G with ``tile`` (() for the global atomics)."""
    import warp as wp

    m = sim.mpm
    c = m.config
    m.G.mass.zero_()
    m.G.mom.zero_()
    kernel = transfer.make_p2g(c.shape, c.scheme.affine, c.precision, mass=True, momentum=True, force=True,
                               fused_impulse=True, derived=m.material_kinds if m.derived_stress else (), tile=tile)
    n = m.particle_count
    inputs = [m.points, m.G, m.D, m.clock, m.status, m.materials]
    if tile:
        wp.launch(kernel, -(-n // tile[0]) * tile[0], inputs=inputs, block_dim=tile[0], device=m.device)
    else:
        wp.launch(kernel, n, inputs=inputs, device=m.device)
    return m.G.mass.numpy().copy(), m.G.mom.numpy().copy()


@pytest.mark.parametrize("shuffled", [False, True])
def test_tiled_p2g_adds_what_the_global_atomics_add(device, shuffled):
    """Verify the tiled P2G's grid mass and momentum equal the global-atomic P2G's."""
    scene = Scene(domain=((0.0, 0.0), (1.0, 1.0)), cell_size=1 / 64)
    scene.add_mpm_body(rectangle(0.2, 0.1, 0.8, 0.6), NeoHookean(1e5, 0.3, 1000.0), velocity=(0.3, -0.2))
    sim = Simulation(scene, SolverConfig(precision="f32", transfer="APIC"), device=device)
    sim.run(0.005, frames=1, quiet=True)  # stresses and an affine field that are not zero
    if shuffled:
        sim.mpm.shuffle_points(seed=1)  # most points then fall outside their block's tile
    clock = sim.mpm.clock.numpy()
    clock[CLOCK_DT] = 1.0e-5
    sim.mpm.clock.assign(clock)
    K = 3
    tile = (BLOCK, K + 1, BLOCK // 4 + K + 3)
    mass, mom = p2g_fields(sim, ())
    tiled_mass, tiled_mom = p2g_fields(sim, tile)
    assert mass.sum() > 0 and np.abs(mom).max() > 0
    np.testing.assert_allclose(tiled_mass, mass, rtol=0, atol=1e-5 * mass.max())
    np.testing.assert_allclose(tiled_mom, mom, rtol=0, atol=1e-5 * np.abs(mom).max())


def test_tiles_only_where_they_pay(device):
    """Verify the tile is chosen on CUDA for a large single-stencil scene, and not on the CPU,
    in granular mode, or for a multi-stencil shape."""
    scene = Scene(domain=((0.0, 0.0), (1.0, 1.0)), cell_size=1 / 300)
    scene.add_mpm_body(rectangle(0.05, 0.05, 0.95, 0.95), NeoHookean(1e5, 0.3, 1000.0))  # 4 per cell
    sim = Simulation(scene, SolverConfig(precision="f32"), device=device)
    assert sim.mpm.particle_count >= TILED_P2G_POINTS
    tile = sim.mpm.p2g_tile()
    if device == "cpu":
        assert tile == ()
        return
    assert tile == (TILED_P2G_BLOCK, 4, TILED_P2G_BLOCK // 4 + 6)
    assert Simulation(scene, SolverConfig(precision="f32", shape="cpdi1"), device=device).mpm.p2g_tile() == ()
    assert Simulation(scene, SolverConfig(precision="f32", deterministic=True),
                      device=device).mpm.p2g_tile() == ()
