"""The shared-memory P2G of large CUDA scenes (``make_p2g(tile=...)``, ``MPMSolver.p2g_tile``).

A block of cell-sorted points sums its mass and momentum in a tile of nodes and adds the tile to
the grid once; nodes outside the tile take the global atomic. Either way every point-node term
is added once, so the grid must hold what the one-atomic-per-term P2G gives, up to the order of
the float sums: at most 9 points × 4 sub-terms meet at a node per block, so f32 sums reordered
differ by a few ε of the largest term; 1e-5 of the field's largest value bounds that.
"""

import numpy as np
import pytest

from mpmdem import NeoHookean, Scene, Simulation, SolverConfig, Tuning, rectangle
from mpmdem.kernels import transfer
from mpmdem.kernels.clock import CLOCK_DT

BLOCK = 64


#: The P2G passes of the stress-update orders: fused USL; mass and momentum with a separate force
#: (USL with FLIP, MUSL's first pass); USF's two passes; MUSL's re-mapped momentum.
PASSES = {
    "fused": dict(mass=True, momentum=True, force=True, fused_impulse=True),
    "separate-force": dict(mass=True, momentum=True, force=True),
    "mass-momentum": dict(mass=True, momentum=True, force=False),
    "force-only": dict(mass=False, momentum=False, force=True),
    "remap": dict(mass=False, momentum=True, force=False, remap=True),
}


def p2g_fields(sim, tile, flags=PASSES["fused"], layered=False, tile_layers=1):
    """Grid mass, momentum, force and re-mapped momentum after the P2G pass ``flags`` with ``tile``
    (() for the global atomics); ``layered``: the granular mode's pass, onto the nodes' copies, the
    first ``tile_layers`` of them in the tile."""
    import warp as wp

    m = sim.mpm
    c = m.config
    for field in (m.G.mass, m.G.mom, m.G.force, m.G.vm):
        field.zero_()
    kernel = transfer.make_p2g(c.shape, c.scheme.affine, c.precision, layered=layered,
                               derived=m.material_kinds if m.derived_stress else (), tile=tile,
                               tile_layers=tile_layers if tile else 1, **flags)
    n = m.particle_count
    inputs = [m.points, m.G, m.D, m.clock, m.status, m.materials]
    if tile:
        wp.launch(kernel, -(-n // tile[0]) * tile[0], inputs=inputs, block_dim=tile[0], device=m.device)
    else:
        wp.launch(kernel, n, inputs=inputs, device=m.device)
    return [f.numpy().copy() for f in (m.G.mass, m.G.mom, m.G.force, m.G.vm)]


@pytest.mark.parametrize(("shuffled", "step_pass"), [(False, "fused"), (True, "fused"), (False, "separate-force"),
                                                     (False, "mass-momentum"), (False, "force-only"),
                                                     (False, "remap")])
def test_tiled_p2g_adds_what_the_global_atomics_add(device, shuffled, step_pass):
    """Verify the tiled P2G's grid fields equal the global-atomic P2G's, for every pass."""
    scene = Scene(domain=((0.0, 0.0), (1.0, 1.0)), cell_size=1 / 64)
    scene.add_mpm_body(rectangle(0.2, 0.1, 0.8, 0.6), NeoHookean(1e5, 0.3, 1000.0), velocity=(0.3, -0.2))
    # (MUSL: the grid then has the re-mapped momentum field the "remap" pass adds to)
    sim = Simulation(scene, SolverConfig(precision="f32", transfer="APIC", update="MUSL"), device=device)
    sim.run(0.005, frames=1)  # stresses and an affine field that are not zero
    if shuffled:
        sim.mpm.shuffle_points(seed=1)  # most points then fall outside their block's tile
    clock = sim.mpm.clock.numpy()
    clock[CLOCK_DT] = 1.0e-5
    sim.mpm.clock.assign(clock)
    K = 3
    tile = (BLOCK, K + 1, BLOCK // 4 + K + 3)
    flags = PASSES[step_pass]
    fields = p2g_fields(sim, (), flags)
    tiled = p2g_fields(sim, tile, flags)
    written = 0
    for name, want, got in zip(("mass", "mom", "force", "vm"), fields, tiled, strict=True):
        scale = np.abs(want).max()
        written += scale > 0
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-5 * scale, err_msg=name)
    assert written == sum(flags.get(k, False) for k in ("mass", "momentum", "force")) - (
        1 if flags.get("fused_impulse") else 0)  # the pass wrote each of its fields (fused: force in mom)


def test_tiles_only_where_they_pay(device):
    """Verify the tile is chosen on CUDA for a large single-stencil scene, and not on the CPU,
    in granular mode when ``Tuning.tiled_p2g_granular`` is off, or for a multi-stencil shape."""
    scene = Scene(domain=((0.0, 0.0), (1.0, 1.0)), cell_size=1 / 300)
    scene.add_mpm_body(rectangle(0.05, 0.05, 0.95, 0.95), NeoHookean(1e5, 0.3, 1000.0))  # 4 per cell
    sim = Simulation(scene, SolverConfig(precision="f32"), device=device)
    assert sim.mpm.particle_count >= Tuning().tiled_p2g_points
    tile = sim.mpm.p2g_tile()
    if device == "cpu":
        assert tile == ()
        return
    block = Tuning().tiled_p2g_block
    assert tile == (block, 4, block // 4 + 6)
    assert Simulation(scene, SolverConfig(precision="f32", shape="cpdi1"), device=device).mpm.p2g_tile() == ()
    assert Simulation(scene, SolverConfig(precision="f32", deterministic=True),
                      device=device).mpm.p2g_tile() == ()
    granular = SolverConfig(precision="f32", granular=True)
    assert Simulation(scene, granular, device=device).mpm.p2g_tile() == (block, 4, block // 4 + 6)
    assert Simulation(scene, granular, device=device,
                      tuning=Tuning(tiled_p2g_granular=False)).mpm.p2g_tile() == ()


@pytest.mark.parametrize("tile_layers", [1, 4])
@pytest.mark.parametrize("step_pass", ["fused", "separate-force", "force-only"])
def test_tiled_p2g_in_granular_mode_adds_what_the_global_atomics_add(device, step_pass, tile_layers):
    """Granular mode (``layered``): the tile holds the nodes' first copies and a term for another
    copy takes the global atomic, so every copy of every node must hold what the one-atomic P2G
    gives, to the same reordering bound. A block of sand (one component, first copies) beside a
    cloud of separate points (spacing 0.65 h, domains h/2: each its own component, so a node holds
    several copies) exercises both the tile and the global atomics of the other copies; with
    ``tile_layers`` 4 the tile holds the first four copies of each node and the deeper ones go global."""
    from mpmdem import MohrCoulomb

    h = 1 / 64
    scene = Scene(domain=((0.0, 0.0), (1.0, 1.0)), cell_size=h)
    # (a critical density: points below it separate, "Granular MPM" §3.3)
    sand = MohrCoulomb(1.0e7, 0.3, 2250.0, 30.0, 0.0, bagnold=0.15, critical_density=2235.0)
    scene.add_mpm_body(rectangle(0.1, 0.1, 0.45, 0.5), sand, velocity=(0.2, 0.0))
    ii, jj = np.divmod(np.arange(24 * 24), 24)
    cloud = np.column_stack([0.55 + (jj + 0.5) * 0.65 * h, 0.1 + (ii + 0.5) * 0.65 * h])
    scene.add_points(cloud, sand, size=0.5 * h, velocity=(-0.2, 0.1))
    config = SolverConfig(precision="f32", granular=True, shape="bspline2")
    sim = Simulation(scene, config, device=device)
    sim.run(0.002, frames=1)  # stresses, layers in use
    m = sim.mpm
    clock = m.clock.numpy()
    clock[CLOCK_DT] = 1.0e-5
    m.clock.assign(clock)
    flags = {k: v for k, v in PASSES[step_pass].items()}
    flags["mass"] = False  # (a pass that moves mass claims copies: the step's first, not re-run here)

    def fields(tile):
        return p2g_fields(sim, tile, flags, layered=True, tile_layers=tile_layers)[1:3]  # (momentum, force)

    layer_rows = m.D.layer_rows
    want = fields(())
    got = fields((BLOCK, 4, BLOCK // 4 + 6))
    written = 0
    for name, a, b in zip(("mom", "force"), want, got, strict=True):
        scale = np.abs(a).max()
        written += scale > 0
        np.testing.assert_allclose(b, a, rtol=0, atol=1e-5 * scale, err_msg=name)
    assert written == (1 if flags.get("fused_impulse") else 1 + bool(flags.get("momentum")))
    # (the copies past the tile's hold terms: the global atomics' share of the tiled pass was exercised)
    assert np.abs(want[-1 if not flags.get("fused_impulse") else 0][tile_layers * layer_rows:]).max() > 0
