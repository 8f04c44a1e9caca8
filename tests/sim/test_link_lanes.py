"""The rebuild's ``link`` and the relabel's ``relink`` over several threads a point
(``Tuning.link_lanes``).

In a flowing granular scene whose points cannot change node ranges without a rebuild, nearly every
rebuild comes in a streak that only merges pairs (no margin, no listed pair: FLAG_FORCED), and
deforming domains only merge at every step; where they can (``Tuning.node_range_moves``),
nearly every step relabels over wide lists of nearly every neighbour pair. There a point's
candidates, or its listed pairs, are split over ``link_lanes`` threads (the GPU, idle at a few thousand
points, runs the chains side by side). What must hold: the components are those of the one-thread
search, whose labels are tested against the O(N²) interaction graph in tests/sim/test_granular.py, and
since a component's root is its point of highest priority whatever the order of the merges, every
later result is the same bits. On the CPU (threads in sequence) both are checked to the bit:

- a sand flow (``sand-blocks``) over 500 steps, two hundred of them in such streaks, or relabels;
- the meeting grains with a deforming domain (cpGIMP), against the O(N²) graph at every step.
"""

import sys

import numpy as np
import pytest
from helpers import ROOT
from test_granular import assert_steps_label_as_brute_force, meeting_grains

from mpmdem import Tuning
from mpmdem.kernels import granular as kgran

sys.path.insert(0, str(ROOT / "bench"))
from small_scenes import build_case  # noqa: E402

BOTH = ("cpu", "cuda")


def sand_flow(devices, moves: bool):
    """sand-blocks on the CPU for 500 steps with ``link`` and ``relink`` on the given devices' lanes:
    (fields, diagnostics, the labels every 50 steps, the steps whose lanes had pairs to share: the
    rebuilds that only merged without moves, the relabels over the wide lists with them; the pairs
    listed at the end)."""
    # (without moves every new node range rebuilds: the streaks of merging rebuilds of a flow;
    # with them a flow relabels over its wide lists at nearly every step, Tuning.node_range_moves)
    sim, _ = build_case("sand-blocks", "cpu", [], Tuning(link_lanes_devices=devices, node_range_moves=moves))
    shared, labels = 0, []
    for k in range(500):
        f = sim.mpm.interaction.flags.numpy()
        if moves:
            shared += int(f[kgran.FLAG_RELABEL] != 0 and f[kgran.FLAG_REBUILD] == 0 and f[kgran.FLAG_WIDE] != 0)
        else:
            shared += int(f[kgran.FLAG_REBUILD] != 0 and f[kgran.FLAG_FORCED] > 0)
        sim.advance(1)
        if k % 50 == 49:
            labels.append(sim.mpm.P.comp.numpy().copy())
    return sim.fields(), sim.diagnostics(), labels, shared, int(sim.mpm.interaction.npairs.numpy().sum())


@pytest.mark.parametrize("moves", [False, True])
def test_link_over_lanes_changes_no_bit_of_a_flow(moves):
    """Verify a sand flow whose merging rebuilds (without moves) or relabels over the wide lists (with
    them) split each point's pairs over four lanes has the one-thread run's labels, positions,
    velocities and diagnostics, to the bit."""
    fields, diag, labels, shared, listed = sand_flow((), moves)
    l_fields, l_diag, l_labels, l_shared, l_listed = sand_flow(BOTH, moves)
    assert shared == l_shared >= 150  # the lanes' path ran
    if moves:
        assert listed == l_listed > 8000  # (more than a pair a point to share over the lanes)
    for a, b in zip(labels, l_labels, strict=True):
        np.testing.assert_array_equal(a, b)
    for name in ("x", "v"):
        np.testing.assert_array_equal(l_fields[name], fields[name], err_msg=name)
    assert l_diag == diag


@pytest.mark.parametrize("shape", ["cpgimp"])
def test_link_over_lanes_labels_the_brute_force_graph(shape):
    """Verify deforming domains (every rebuild only merges) label each step's O(N²) graph with
    ``link`` over four lanes, and end at the one-thread run's bits."""
    sim = meeting_grains("cpu", shape=shape, tuning=Tuning(link_lanes_devices=BOTH))
    sim.advance_to(1.0e-12)
    assert_steps_label_as_brute_force(sim, steps=30, relabels=False)
    ref = meeting_grains("cpu", shape=shape, tuning=Tuning(link_lanes_devices=()))
    ref.advance_to(1.0e-12)
    ref.mpm.set_stop_time(1.0)
    ref.advance(30)
    for name in ("x", "v"):
        np.testing.assert_array_equal(sim.fields()[name], ref.fields()[name], err_msg=name)
