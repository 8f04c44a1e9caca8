"""Points that change node ranges without a rebuild (``granular_state.NODE_RANGE_MOVES``).

Where every domain of interaction is granular and under half a cell (and does not deform, outside
staged scenes), two domains that overlap are less than a cell apart on each axis, and the stencils
of any shape then share a node: the pre-task of the interaction graph ("Granular MPM" appendix
Table A1) holds for every pair that passes task 1 (Table A2) whatever the node ranges. A point whose
node range changed then needs no rebuild, only a relabel, which claims its copies at its new nodes.
What must hold:

- the labels of such steps are those of the O(N²) graph (tests/test_granular.py, every
  non-deforming shape), and the copies separate the components at every node;
- a flow gives the same bits with and without it (on the CPU, whose threads run in sequence, the
  copies are claimed in the same order), while it rebuilds far less often.
"""

import sys
from pathlib import Path

import numpy as np

from mpmdem import granular_state
from mpmdem.kernels import granular as kgran

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))
from small_scenes import build_case  # noqa: E402

#: Steps of sand-blocks: it flows (and rebuilds at nearly every step without moves) after about 300
STEPS = 600


def sand_flow(monkeypatch, moves: bool):
    """sand-blocks (B-spline, granular) on the CPU for STEPS steps: (fields, diagnostics, labels at
    the end, rebuilds, whether the interaction allowed moves)."""
    monkeypatch.setattr(granular_state, "NODE_RANGE_MOVES", moves)
    sim, _ = build_case("sand-blocks", "cpu", [])
    sim.advance(STEPS)
    S = sim.mpm.interaction
    return (sim.fields(), sim.diagnostics(), sim.mpm.P.comp.numpy().copy(),
            int(S.flags.numpy()[kgran.FLAG_COUNT]), S.moves)


def test_node_range_moves_change_no_bit_of_a_flow(monkeypatch):
    """Verify sand-blocks has the same positions, velocities, labels and diagnostics (but the
    rebuild counts) to the bit whether its new node ranges rebuild or relabel, and that relabels
    replaced most rebuilds."""
    fields, diag, labels, rebuilds, moves = sand_flow(monkeypatch, False)
    m_fields, m_diag, m_labels, m_rebuilds, m_moves = sand_flow(monkeypatch, True)
    assert (moves, m_moves) == (0, 1)
    np.testing.assert_array_equal(m_labels, labels)
    for name in ("x", "v"):
        np.testing.assert_array_equal(m_fields[name], fields[name], err_msg=name)
    counts = {"granular_rebuilds", "granular_relabels"}
    assert {k: v for k, v in m_diag.items() if k not in counts} == {k: v for k, v in diag.items() if k not in counts}
    # (once it flows, some point takes a new node range at every step: without moves each rebuilds)
    assert rebuilds > 0.5 * STEPS and m_rebuilds < rebuilds / 4
