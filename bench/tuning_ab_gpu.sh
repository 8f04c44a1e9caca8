#!/usr/bin/env bash
# Tuning settings alternated twice in one GPU call: per setting the 1M granular overhead scenes
# (granular_overhead.py: the dispersed cloud, up to nine copies a node, and the dense column, one;
# both modes) and five 2.5 mm silos (step_profile.py's Beverloo batch); rows to $OUT, then one line
# a row (tuning_rows.py). A setting is KNOB=VALUE[,KNOB=VALUE...] (values as Python literals); about
# 30 s a setting and round on a warm kernel cache.
#   OUT=$OUT bash bench/tuning_ab_gpu.sh g2p_registers=None g2p_registers=64
set -uo pipefail
out=${OUT:-/tmp/out}; mkdir -p "$out"
for round in 1 2; do
  for setting in "$@"; do
    knobs=$(echo "$setting" | tr ',' '\n' | sed 's/^/--tuning /' | tr '\n' ' ')
    python bench/granular_overhead.py --device cuda --scenes dispersed-cloud,dense-column --sizes 1048576 \
      $knobs --out "$out/granular_overhead.jsonl" > /dev/null 2> "$out/go.err"
    grep "granular/plain" "$out/go.err" | sed "s/^/round $round $setting /"
    python bench/step_profile.py --device cuda --silo-batches 0.0025:5 --steps 200 \
      $knobs --out "$out/step_profile.jsonl" > /dev/null 2>&1
  done
done
python bench/tuning_rows.py "$out/step_profile.jsonl" "$out/granular_overhead.jsonl"
