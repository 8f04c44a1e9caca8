#!/usr/bin/env bash
# Issue 46's open GPU questions in one call (rows to $OUT; about 3-4 minutes on a warm kernel cache):
#   side_by_side.jsonl  do batches side by side in threads overlap? (bench/side_by_side.py: its modes
#                       sequential / round-robin / side-by-side, batches built in their turn or outside,
#                       and with CUDA_DEVICE_MAX_CONNECTIONS=32: do the streams share hardware queues?)
#   batch_frames.jsonl  a 16-start batch with its frames written by a thread or by a child process
#                       (Tuning.batch_writer_processes 1), alternated twice
#   OUT=$OUT bash bench/issue46_gpu.sh
set -uo pipefail
out=${OUT:-/tmp/out}; mkdir -p "$out"
for worlds in 1 5; do
  for build in in-turn outside; do
    python bench/side_by_side.py --device cuda --worlds "$worlds" --build "$build" --out "$out/side_by_side.jsonl" \
      2>/dev/null | cut -c1-300
  done
  CUDA_DEVICE_MAX_CONNECTIONS=32 python bench/side_by_side.py --device cuda --worlds "$worlds" \
    --out "$out/side_by_side_32_connections.jsonl" 2>/dev/null | cut -c1-300
done
for round in 1 2; do
  for how in "" "--writer-processes 1"; do
    python bench/batch_frames.py --device cuda --case sand-blocks --worlds 16 --cell-size 0.003125 $how \
      --label "round $round${how:+ one writer process}" --out "$out/batch_frames.jsonl" 2>/dev/null | tail -1 | cut -c1-400
  done
done
