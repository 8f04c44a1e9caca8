"""The Granular MPM block laid out as conditional graph nodes or in line (``mpmdem.block_layout``).

A block that runs in most steps costs less launched in line (each kernel reads its flag and
returns where the block would be skipped) than as a taken conditional node; one that rarely runs
costs less as a skipped node. ``BlockLayout`` picks from the rate it reads after each batch.
What must hold whatever it picks: the same kernels run on the same data, so

- the labels of every step replayed from a graph with the block in line are those of the O(N²)
  interaction graph (the reference of tests/test_granular.py), over steps that rebuild, relabel
  and keep;
- a run that switched layouts is the same bits as one that never did (deterministic mode, where
  a GPU's atomics are ordered).
"""

import numpy as np
import pytest
import warp as wp
from test_granular import H, _brute_force_components, _by_smallest_member

from mpmdem import LinearElastic, Scene, Simulation, SolverConfig, block_layout
from mpmdem.block_layout import BlockLayout
from mpmdem.kernels import granular as kgran
from mpmdem.launch_plan import IfFlag


def meeting_grains(device, **config) -> Simulation:
    """100 grains flying apart and through each other (tests/test_granular.py): every step rebuilds
    or relabels at first, then fewer as they part."""
    rng = np.random.default_rng(3)
    x = 0.085 + rng.uniform(0.0, 0.03, (100, 2))
    angle = rng.uniform(0.0, 2.0 * np.pi, 100)
    v = rng.uniform(2.0, 4.0, 100)[:, None] * np.column_stack([np.cos(angle), np.sin(angle)])
    scene = Scene(domain=((0.0, 0.0), (0.2, 0.2)), cell_size=H, gravity=(0.0, 0.0),
                  boundaries={s: "free" for s in ("left", "right", "bottom", "top")})
    scene.add_points(x, LinearElastic(1.0e5, 0.3, 1500.0, critical_density=1400.0), size=0.5 * H, velocity=v)
    return Simulation(scene, SolverConfig(granular=True, shape="linear", precision="f64", dt=2.0e-5, **config),
                      device=device)


def test_layout_follows_the_rate(monkeypatch):
    """Verify the layout goes in line from INLINE_ABOVE of a window's steps, stays there above
    CONDITIONAL_BELOW, goes back at or below it, decides nothing on a window too short, and starts
    a new window when the step count goes back (a checkpoint loaded)."""
    monkeypatch.setattr(block_layout, "WINDOW_STEPS", 100)
    counts = wp.zeros(kgran.FLAG_SLOTS, dtype=wp.int32, device="cpu")
    block = IfFlag(wp.zeros(1, dtype=wp.int32, device="cpu"), [])
    layout = BlockLayout(block, counts, (kgran.FLAG_COUNT, kgran.FLAG_RELABELS))

    def batch(steps, rebuilds, relabels):
        c = counts.numpy()
        c[kgran.FLAG_COUNT], c[kgran.FLAG_RELABELS] = rebuilds, relabels
        counts.assign(c)
        return layout.after_batch(steps)

    assert not batch(0, 0, 0) and not layout.inline  # the first window starts
    assert not batch(99, 99, 0) and not layout.inline  # 99 steps: too short to decide
    assert batch(100, 40, 20) and layout.inline and layout.rate == pytest.approx(0.6)
    assert block.inline
    assert not batch(200, 60, 31) and layout.inline  # 0.31 > CONDITIONAL_BELOW: stays
    assert batch(300, 75, 46) and not layout.inline and not block.inline  # 0.30
    assert not batch(400, 110, 56) and not layout.inline  # 0.45: below INLINE_ABOVE
    assert not batch(50, 0, 0) and not batch(149, 99, 0) and not layout.inline  # restarted at step 50
    assert batch(150, 100, 0) and layout.inline and layout.switches == 3


def test_a_granular_step_lays_out_its_relabel_and_rebuild_blocks():
    """Verify the layouts are the relabel block's (run by the rebuilds and the relabels without one)
    and the rebuild's nested in it (run by the rebuilds), both conditional at first, and that only a
    CUDA-graph run has them (elsewhere every block already runs in line)."""
    sim = meeting_grains("cpu")
    assert sim.block_layouts == []
    relabel, rebuild = sim.mpm.block_layouts()
    assert rebuild.block in relabel.block.body
    assert relabel.slots == (kgran.FLAG_COUNT, kgran.FLAG_RELABELS) and rebuild.slots == (kgran.FLAG_COUNT,)
    assert not relabel.inline and not rebuild.inline


@pytest.mark.cuda
def test_in_line_block_replays_the_brute_force_labels():
    """Verify the steps replayed from a graph with the block in line label exactly the components of
    the O(N²) graph, over steps that rebuild and steps that relabel without a rebuild."""
    if not wp.get_cuda_device_count():
        pytest.skip("no CUDA device here: the CUDA items run on the GPU machine (pytest -m cuda)")
    sim = meeting_grains("cuda")
    sim.advance_to(1.0e-12)  # (loads the modules, captures the graph, takes one step)
    for layout in sim.block_layouts:
        layout.set_inline(True)
    sim._record_graphs()
    m = sim.mpm
    m.set_stop_time(1.0)
    seen = set()
    for _ in range(40):
        f = m.interaction.flags.numpy()
        seen.add((int(f[kgran.FLAG_REBUILD]), int(f[kgran.FLAG_RELABEL])))
        x0, reach0 = m.P.x.numpy().copy(), m.node_ranges()
        sim.advance(1)
        np.testing.assert_array_equal(_by_smallest_member(m.P.comp.numpy()),
                                      _brute_force_components(x0, *m.interaction_domains(), reach0))
    assert {(1, 1), (0, 1)} <= seen  # steps that rebuilt and steps that relabelled without a rebuild


@pytest.mark.cuda
def test_switching_layouts_changes_no_bit(monkeypatch):
    """Verify a deterministic run whose block went in line and back is the same bits as one kept in
    conditional nodes throughout."""
    if not wp.get_cuda_device_count():
        pytest.skip("no CUDA device here: the CUDA items run on the GPU machine (pytest -m cuda)")
    monkeypatch.setattr(block_layout, "WINDOW_STEPS", 10)
    kept = meeting_grains("cuda", deterministic=True)
    kept.block_layouts = []
    switched = meeting_grains("cuda", deterministic=True)
    layouts = []
    for t in np.linspace(0.0, 4.0e-3, 21)[1:]:  # 200 steps, batches of 10
        kept.advance_to(t, max_batch=10)
        switched.advance_to(t, max_batch=10)
        layouts.append(switched.block_layouts[0].inline)
    assert True in layouts  # the grains rebuild or relabel in most of the first steps
    assert switched.block_layouts[0].switches >= 1
    a, b = kept.fields(), switched.fields()
    for name in ("x", "v"):
        np.testing.assert_array_equal(a[name], b[name], err_msg=name)
