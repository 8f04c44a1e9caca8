"""The Granular MPM block laid out as conditional graph nodes or in line (``mpmdem.sim.block_layout``).

A block that runs in most steps costs less launched in line (each kernel reads its flag and
returns where the block would be skipped) than as a taken conditional node; one that rarely runs
costs less as a skipped node. ``BlockLayout`` picks from the rate it reads after each batch.
What must hold whatever it picks: the same kernels run on the same data, so

- the labels of every step replayed from a graph with the block in line are those of the O(N²)
  interaction graph (the reference of tests/sim/test_granular.py), over steps that rebuild, relabel
  and keep;
- a run that switched layouts is the same bits as one that never did (deterministic mode, where
  a GPU's atomics are ordered).
"""

import numpy as np
import pytest
import warp as wp
from conftest import DEVICES
from test_granular import assert_steps_label_as_brute_force, meeting_grains

from mpmdem import Tuning
from mpmdem.kernels import granular as kgran
from mpmdem.sim.block_layout import BlockLayout
from mpmdem.sim.launch_plan import IfFlag


def test_layout_follows_the_rate():
    """Verify the layout goes in line from ``inline_above`` (0.6) of a window's steps, stays there
    above ``conditional_below`` (0.3), goes back at or below it, decides nothing on a window too
    short (100 steps), and starts a new window when the step count goes back (a checkpoint loaded)."""
    tuning = Tuning(inline_above=0.6, conditional_below=0.3, layout_window_steps=100)
    counts = wp.zeros(kgran.FLAG_SLOTS, dtype=wp.int32, device="cpu")
    block = IfFlag(wp.zeros(1, dtype=wp.int32, device="cpu"), [])
    layout = BlockLayout(block, counts, (kgran.FLAG_COUNT, kgran.FLAG_RELABELS), tuning)

    def batch(steps, rebuilds, relabels):
        c = counts.numpy()
        c[kgran.FLAG_COUNT], c[kgran.FLAG_RELABELS] = rebuilds, relabels
        counts.assign(c)
        return layout.after_batch(steps)

    assert not batch(0, 0, 0) and not layout.inline  # the first window starts
    assert not batch(99, 99, 0) and not layout.inline  # 99 steps: too short to decide
    assert batch(100, 40, 20) and layout.inline and layout.rate == pytest.approx(0.6)
    assert block.inline
    assert not batch(200, 60, 31) and layout.inline  # 0.31 > conditional_below: stays
    assert batch(300, 75, 46) and not layout.inline and not block.inline  # 0.30
    assert not batch(400, 110, 56) and not layout.inline  # 0.45: below inline_above
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


@pytest.mark.parametrize("device", DEVICES[1:])  # (CUDA graphs only: elsewhere every block runs in line)
def test_in_line_block_replays_the_brute_force_labels(device):
    """Verify the steps replayed from a graph with the blocks in line label exactly the components
    of the O(N²) graph, over steps that rebuild and steps that relabel without a rebuild."""
    sim = meeting_grains(device)
    sim.advance_to(1.0e-12)  # (loads the modules, captures the graph, takes one step)
    assert len(sim.block_layouts) == 2
    for layout in sim.block_layouts:
        layout.set_inline(True)
    sim._record_graphs()
    assert_steps_label_as_brute_force(sim)


@pytest.mark.parametrize("device", DEVICES[1:])
def test_switching_layouts_changes_no_bit(device):
    """Verify a deterministic run whose block went in line is the same bits as one kept in
    conditional nodes throughout."""
    short = Tuning(layout_window_steps=10)
    kept = meeting_grains(device, deterministic=True, tuning=short)
    kept.block_layouts = []
    switched = meeting_grains(device, deterministic=True, tuning=short)
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
