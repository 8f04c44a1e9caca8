"""Run a bench script with every kernel launched at another CUDA block size.

Warp launches 256 threads a block. A small scene's point kernel (2601 points) then runs on 11 of
an H100's 132 SMs, and each of those SMs issues all its threads' scattered atomics and gathers
through one L1. This wrapper measures what smaller blocks change:

    python bench/block_size.py 64 bench/small_scenes.py --device cuda --out /tmp/b64.jsonl
    python bench/block_size.py spread bench/small_scenes.py --device cuda

``N`` launches every kernel (that names no block size of its own) at N threads a block;
``spread`` uses the smallest multiple of 32 that still puts one block on every SM, at most 256.
The JSON rows the script prints get ``block_dim``.
Nothing is asserted.
"""

import json
import math
import runpy
import sys

import warp as wp


def spread(threads: int, sm_count: int) -> int:
    """Threads a block so that ``threads`` fill every SM once: a multiple of 32 in [32, 256]."""
    return max(32, min(256, 32 * math.ceil(threads / (32 * sm_count))))


if __name__ == "__main__":
    if len(sys.argv) < 3:
        sys.exit("usage: python bench/block_size.py N|spread SCRIPT [ARGS...]")
    policy, script = sys.argv[1], sys.argv[2]
    sys.argv = sys.argv[2:]
    launch = wp.launch

    def launch_at(kernel, dim, *args, block_dim=None, **kw):
        device = wp.get_device(kw.get("device"))
        if block_dim is None and device.is_cuda:
            threads = math.prod(dim) if isinstance(dim, (tuple, list)) else int(dim)
            block_dim = spread(threads, device.sm_count) if policy == "spread" else int(policy)
        if block_dim is None:
            return launch(kernel, dim, *args, **kw)
        return launch(kernel, dim, *args, block_dim=block_dim, **kw)

    wp.launch = launch_at
    print_ = print

    def tagged(*args, **kw):
        # tag the JSON rows the script prints with the policy
        if len(args) == 1 and isinstance(args[0], str) and args[0].startswith("{"):
            try:
                row = json.loads(args[0])
                row["block_dim"] = policy
                args = (json.dumps(row),)
            except ValueError:
                pass
        print_(*args, **kw)

    import builtins

    builtins.print = tagged
    runpy.run_path(script, run_name="__main__")
