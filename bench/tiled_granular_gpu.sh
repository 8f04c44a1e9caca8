#!/usr/bin/env bash
# The tiled P2G in granular mode (Tuning.tiled_p2g_granular, on by default since it was timed so) in one GPU call:
#   its CUDA tests (the tile against the global atomics, with many copies a node; sm_90 codegen),
#   then a Beverloo batch's step (five silos at 2.5 mm, 190k points) without and with it,
#   alternated twice: graph µs a step and the per-kernel split (P2G's row) -> $OUT/step_profile.jsonl
#   OUT=$OUT bash bench/tiled_granular_gpu.sh
set -uo pipefail
out=${OUT:-/tmp/out}; mkdir -p "$out"
python -m pytest -m cuda -q -p no:cacheprovider tests/kernels/test_tiled_p2g.py tests/kernels/test_cuda_codegen.py 2>&1 | tail -3
for round in 1 2; do
  for on in False True; do
    python bench/step_profile.py --device cuda --silo-batches 0.0025:5 --steps 400 --tuning tiled_p2g_granular=$on \
      --out "$out/step_profile.jsonl" 2>/dev/null | python -c "
import json, sys
for line in sys.stdin:
    if line.startswith('{'):
        r = json.loads(line)
        p2g = [k for k in r['kernels'] if 'p2g' in k[0]]
        print('tiled_p2g_granular=$on', 'graph_us', round(r['graph_us_per_step'], 1), 'p2g', p2g)"
  done
done
