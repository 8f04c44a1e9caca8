#!/usr/bin/env bash
# Tuning.tiled_p2g_layers (the copies of a node the granular tile holds; 1 by default) in one GPU call:
#   its CUDA tests (the tile against the global atomics with one and four copies in the tile; sm_90 codegen),
#   then the 1M granular overhead scenes (granular_overhead.py: the dispersed cloud, up to nine copies a
#   node, and the dense column, one) and a Beverloo batch's step with 1, 2 and 4 copies, alternated twice
#   (rows to $OUT; about 4 minutes on a warm kernel cache)
#   OUT=$OUT bash bench/tile_layers_gpu.sh
set -uo pipefail
out=${OUT:-/tmp/out}; mkdir -p "$out"
python -m pytest -m cuda -q -p no:cacheprovider tests/kernels/test_tiled_p2g.py tests/kernels/test_cuda_codegen.py 2>&1 | tail -2
for round in 1 2; do
  for layers in 1 2 4; do
    python bench/granular_overhead.py --device cuda --scenes dispersed-cloud,dense-column --sizes 1048576 \
      --tuning tiled_p2g_layers=$layers --out "$out/granular_overhead.jsonl" > /dev/null 2> "$out/go.err"
    grep "granular/plain" "$out/go.err" | sed "s/^/round $round tiled_p2g_layers=$layers /"
    python bench/step_profile.py --device cuda --silo-batches 0.0025:5 --steps 200 \
      --tuning tiled_p2g_layers=$layers --out "$out/step_profile.jsonl" > /dev/null 2>&1
  done
done
python bench/tuning_rows.py "$out/step_profile.jsonl"
