"""A step's graph nodes (issue 27): small scenes are paid per node, so their count is guarded.

On an H100 every dependent node of a captured step costs at least 1.2 µs and a skipped conditional
node 4.8 µs (bench/launch_floor.py, bench/results/launch_floor/h100.jsonl), whatever it computes; a
small scene's step (bench/small_scenes.py) is a few tens of such nodes. The counts below are those
of this code (bench/step_nodes.py, listed on the CPU as a CUDA graph records them); a change that
adds a node to these steps must show its H100 figure in docs/bench-history.md and raise the bound here.
"""

from __future__ import annotations

import sys

import pytest
import warp as wp
from helpers import ROOT

from mpmdem.sim.launch_plan import IfAny, Launch, run_plan

sys.path.insert(0, str(ROOT / "bench"))
from step_nodes import step_nodes  # noqa: E402

#: graph nodes of one step outside conditional bodies (d0820bc: 21, 13, 16, 15; 8e96e0a: 16, 7, 13, 11;
#: G2P reading the wall images: 15, 7, 11, 10; grid updates folding them: 14, 7, 10, 9; the DEM's world
#: vertices and displacement check in one launch: 13, 7, 10, 9), on the CPU,
#: with the point–body lists (a GPU lists every body for every point in these scenes,
#: tests/sim/test_imp_static_lists.py)
NODE_BOUNDS = {"sand-blocks": 13, "normal-force": 7, "silo-filling": 10, "silo-discharge": 9}


@pytest.mark.parametrize("case", sorted(NODE_BOUNDS))
def test_small_scene_steps_keep_their_node_count(case):
    """Verify the step of each small scene records no more graph nodes than measured."""
    row = step_nodes(case, "cpu", [])
    assert 0 < row["nodes"] <= NODE_BOUNDS[case], "\n".join(row["items"])


@wp.kernel
def _bump(a: wp.array(dtype=wp.int32)):
    a[0] = a[0] + 1


def test_if_any_runs_its_body_outside_a_graph_and_takes_one_to_three_flags():
    """Verify an IfAny block runs its launches outside a CUDA graph (there each kernel reads its
    own flag, as in an IfFlag block), and that it refuses an empty or a four-flag list."""
    flags = [wp.zeros(1, dtype=wp.int32, device="cpu") for _ in range(4)]
    out = wp.zeros(1, dtype=wp.int32, device="cpu")
    counter = wp.zeros(1, dtype=wp.int32, device="cpu")
    run_plan([IfAny(flags[:2], out, [Launch(_bump, 1, [counter])])], "cpu")
    assert counter.numpy()[0] == 1
    with pytest.raises(ValueError, match="one to three"):
        IfAny(flags, out, [])
    with pytest.raises(ValueError, match="one to three"):
        IfAny([], out, [])
