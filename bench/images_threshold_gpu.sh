#!/usr/bin/env bash
# Where the wall images pay in the kernels (Tuning.images_in_kernels_points, 65536 by default) in one
# GPU call, alternated twice (rows to $OUT; about 3 minutes on a warm kernel cache):
#   step_profile.jsonl      Beverloo batches (five silos at 2.5 mm, 190k points; five at 3.5 mm, 97k):
#                           their own mirror and fold launches (default) against G2P reading the images
#                           and the grid update folding them (the knob raised above their size)
#   granular_overhead.jsonl the dense 1M column and the cloud, both modes, the same two settings
# The Nsight Compute split of the batch (bench/results/ncu_split/h100_silo_batch.txt) gives the two
# launches 8 µs of kernels of a 238 µs step, plus two gaps between graph nodes.
#   OUT=$OUT bash bench/images_threshold_gpu.sh
set -uo pipefail
out=${OUT:-/tmp/out}; mkdir -p "$out"
for round in 1 2; do
  for points in 65536 100000000; do
    python bench/step_profile.py --device cuda --silo-batches 0.0025:5,0.0035:5 --steps 200 \
      --tuning images_in_kernels_points=$points --out "$out/step_profile.jsonl" > /dev/null 2>&1
    python bench/granular_overhead.py --device cuda --scenes dense-column,dispersed-cloud --sizes 1048576 \
      --tuning images_in_kernels_points=$points --out "$out/granular_overhead.jsonl" > /dev/null 2> "$out/go.err"
    grep "granular/plain" "$out/go.err" | sed "s/^/round $round images_in_kernels_points=$points /"
  done
done
python bench/tuning_rows.py "$out/step_profile.jsonl" "$out/granular_overhead.jsonl"
