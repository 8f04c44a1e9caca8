"""Points that change node ranges without a rebuild (``Tuning.node_range_moves``).

Where every domain of interaction is granular and under half a cell (and does not deform, outside
staged scenes), two domains that overlap are less than a cell apart on each axis, and the stencils
of any shape then share a node: the pre-task of the interaction graph ("Granular MPM" appendix
Table A1) holds for every pair that passes task 1 (Table A2) whatever the node ranges. A point whose
node range changed then needs no rebuild nor relabel: it claims its copies at its new nodes in the
next P2G. Relabels keep the copies too (a point whose label changed claims anew), so the copies of
labels that moved on stay claimed until a rebuild, or a relabel that frees every copy, which a claim
past half a node's layers asks for.
What must hold:

- the labels of such steps are those of the O(N²) graph (tests/sim/test_granular.py, every
  non-deforming shape), and the copies separate the components at every node;
- a flow gives the same bits with and without it (a copy's sums do not depend on its layer), while
  it rebuilds far less often;
- the kept copies never fill a node: a discharging silo runs past the time they once did.
"""

import sys

import numpy as np
from helpers import ROOT

from mpmdem import Tuning
from mpmdem.kernels import granular as kgran

sys.path.insert(0, str(ROOT / "bench"))
from small_scenes import build_case  # noqa: E402

#: Steps of sand-blocks: it flows (and rebuilds at nearly every step without moves) after about 300
STEPS = 600


def sand_flow(moves: bool):
    """sand-blocks (B-spline, granular) on the CPU for STEPS steps: (fields, diagnostics, labels at
    the end, rebuilds, whether the interaction allowed moves)."""
    sim, _ = build_case("sand-blocks", "cpu", [], Tuning(node_range_moves=moves))
    sim.advance(STEPS)
    S = sim.mpm.interaction
    return (sim.fields(), sim.diagnostics(), sim.mpm.P.comp.numpy().copy(),
            int(S.flags.numpy()[kgran.FLAG_COUNT]), S.moves)


def test_node_range_moves_change_no_bit_of_a_flow():
    """Verify sand-blocks has the same positions, velocities, labels and diagnostics (but the
    rebuild counts) to the bit whether its new node ranges rebuild or relabel, and that relabels
    replaced most rebuilds."""
    fields, diag, labels, rebuilds, moves = sand_flow(False)
    m_fields, m_diag, m_labels, m_rebuilds, m_moves = sand_flow(True)
    assert (moves, m_moves) == (0, 1)
    np.testing.assert_array_equal(m_labels, labels)
    for name in ("x", "v"):
        np.testing.assert_array_equal(m_fields[name], fields[name], err_msg=name)
    counts = {"granular_rebuilds", "granular_relabels"}
    assert {k: v for k, v in m_diag.items() if k not in counts} == {k: v for k, v in diag.items() if k not in counts}
    # (once it flows, some point takes a new node range at every step: without moves each rebuilds)
    assert rebuilds > 0.5 * STEPS and m_rebuilds < rebuilds / 4


def test_kept_copies_never_fill_a_node_of_a_discharging_silo(tmp_path):
    """Verify the silo of ``silo-discharge`` at Table 3's grid (19k points) runs to 0.1 s. Relabels
    keep the grid copies between rebuilds, and the grains falling through the orifice change labels
    at nearly every step: without a relabel that frees every copy when a claim goes past half a
    node's layers (``kgran.STATUS_DEEP_CLAIM``, ``FLAG_FRESH``), the copies their old labels kept
    filled 36 layers at 0.084 s and the run stopped with a layer overflow."""
    from mpmdem.cli import main

    rc = main(["run", "silo-discharge", "--device", "cpu", "--quiet", "--frames", "1", "--out", str(tmp_path),
               "--cell-size", "0.0035", "--fill-height", "0.3", "--end-time", "0.1"])
    assert rc == 0
