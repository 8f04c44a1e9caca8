"""Run a bench script with conditional graph nodes replaced by kernels that return at once.

Nsight Compute profiles no kernel node of a CUDA graph that holds conditional nodes
(``launch_plan.IfFlag``/``IfAny``), so a per-kernel split of a step needs them off:

    ncu --graph-profiling node --metrics gpu__time_duration.sum --cache-control none --csv \\
        python bench/without_conditionals.py bench/coupled_throughput.py --device cuda ... > out.csv

Without them every kernel of a skipped block is launched and returns after reading its flag, as
on a CPU; the step computes the same thing. Nothing is asserted.
"""

import runpy
import sys

import warp as wp

if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit("usage: python bench/without_conditionals.py SCRIPT [ARGS...]")
    wp.is_conditional_graph_supported = lambda: False
    script, sys.argv = sys.argv[1], sys.argv[1:]
    runpy.run_path(script, run_name="__main__")
