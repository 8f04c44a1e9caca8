#!/usr/bin/env bash
# The granular grid update's register cap and batch of copies (Tuning.grid_update_registers, 32, and
# Tuning.grid_update_copies, 4) in one GPU call: Nsight Compute found the capped four-copy batch
# spilling to local memory on the 1M cloud. Its CUDA test first, then per setting, alternated twice:
# the 1M granular overhead scenes (granular_overhead.py: the cloud, up to nine copies a node, and the
# dense column, one) and five 2.5 mm silos (step_profile.py); rows to $OUT (about 5 minutes warm)
#   OUT=$OUT bash bench/grid_update_gpu.sh
set -uo pipefail
out=${OUT:-/tmp/out}; mkdir -p "$out"
python -m pytest -m cuda -q -p no:cacheprovider tests/sim/test_grid_update_copies.py 2>&1 | tail -1
for round in 1 2; do
  for setting in 32:4 32:2 32:1 40:2 48:4 None:4 None:2; do
    regs=${setting%:*}; copies=${setting#*:}
    knobs="--tuning grid_update_registers=$regs --tuning grid_update_copies=$copies"
    python bench/granular_overhead.py --device cuda --scenes dispersed-cloud,dense-column --sizes 1048576 \
      $knobs --out "$out/granular_overhead.jsonl" > /dev/null 2> "$out/go.err"
    grep "granular/plain" "$out/go.err" | sed "s/^/round $round registers=$regs copies=$copies /"
    python bench/step_profile.py --device cuda --silo-batches 0.0025:5 --steps 200 \
      $knobs --out "$out/step_profile.jsonl" > /dev/null 2>&1
  done
done
python bench/tuning_rows.py "$out/step_profile.jsonl" "$out/granular_overhead.jsonl"
