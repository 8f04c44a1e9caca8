#!/usr/bin/env bash
# Issue 46's target in one call on one GPU: the 16-start block-impact ensemble at 3.125 mm against
# one lone start, on a baseline tree BASE (a `git archive` of the commit before, folders mpmdem/
# kernels/ cases/) and on this tree, alternating, after a lone run of each tree has warmed Warp's
# kernel cache. Rows (label "base" or "new") go to $OUT:
#   lone_runs.jsonl     `mpmdem run sand-blocks --device cuda --ensemble-seed 1`, wall time (LONE rounds)
#   study_overhead.jsonl bench/study_overhead.py: the study's phases and `cli_wall_s`, the whole
#                        `mpmdem study block-impact-ensemble --set=--cell-size=0.003125 --gpus 1`;
#                        on this tree also with --workers-per-gpu 1 (label "new-1wpg": in its process)
#                        and with --batch 16 (label "new-b16": the 16 starts one batch, in its process)
#   batch_frames.jsonl  bench/batch_frames.py --case sand-blocks, WORLDS worlds, on BASE and on this
#                       tree at the Tuning's writer switch interval and at Python's own (label "new-si0")
#   git archive OLD mpmdem kernels cases | tar -x -C .gpu/base      # then, on the GPU machine:
#   BASE=.gpu/base bash bench/ensemble_ab.sh
# ROUNDS (default 2) study rounds; LONE (default 2) lone rounds; WORLDS="" skips batch_frames.
set -uo pipefail
out=${OUT:-/tmp/out}; base=${BASE:-.gpu/base}; root=$PWD; mkdir -p "$out"
commit=${COMMIT:-$(git rev-parse --short HEAD 2>/dev/null || echo unknown)}
gpu=$(nvidia-smi --query-gpu=name --format=csv,noheader 2>/dev/null | head -1)
lone() {  # label round
  local dir=$root; [ "$1" = base ] && dir=$root/$base
  local t0 t1 rc
  t0=$(date +%s.%N)
  (cd "$dir" && python -m mpmdem.cli run sand-blocks --device cuda --ensemble-seed 1 --quiet \
    --out "/tmp/lone-$1") > "/tmp/lone-$1.log" 2>&1
  rc=$?; t1=$(date +%s.%N)
  python -c "import json, sys; print(json.dumps({'run': 'sand-blocks --ensemble-seed 1', 'label': sys.argv[1],
'round': int(sys.argv[2]), 'rc': int(sys.argv[3]), 'wall_s': round(float(sys.argv[5]) - float(sys.argv[4]), 2),
'commit': sys.argv[6], 'device': sys.argv[7]}))" "$1" "$2" "$rc" "$t0" "$t1" "$commit" "$gpu" \
    | tee -a "$out/lone_runs.jsonl"
}
study() {  # label round [flags]
  local label=$1 round=$2; shift 2
  local path=$root; [ "$label" = base ] && path=$root/$base
  PYTHONPATH=$path:${PYTHONPATH:-} python bench/study_overhead.py --gpus 1 --keep-sizes \
    --set=--cell-size=0.003125 --cli --label "$label round $round ($gpu)" "$@" \
    --out "$out/study_overhead.jsonl" 2>/dev/null | tail -1 | cut -c1-700
}
lone base 0 > /dev/null; lone new 0 > /dev/null  # (warm caches; not kept)
for round in $(seq 1 "${LONE:-2}"); do lone base "$round"; lone new "$round"; done
for round in $(seq 1 "${ROUNDS:-2}"); do
  study base "$round"; study new "$round"; study new-1wpg "$round" --workers-per-gpu 1
  study new-b16 "$round" --batch 16
done
for w in ${WORLDS-8 16}; do
  PYTHONPATH=$root/$base:${PYTHONPATH:-} python bench/batch_frames.py --device cuda --case sand-blocks \
    --worlds "$w" --cell-size 0.003125 --label base --out "$out/batch_frames.jsonl" 2>/dev/null | tail -1 | cut -c1-500
  PYTHONPATH=$root:${PYTHONPATH:-} python bench/batch_frames.py --device cuda --case sand-blocks --worlds "$w" \
    --cell-size 0.003125 --label new --out "$out/batch_frames.jsonl" 2>/dev/null | tail -1 | cut -c1-500
  PYTHONPATH=$root:${PYTHONPATH:-} python bench/batch_frames.py --device cuda --case sand-blocks --worlds "$w" \
    --cell-size 0.003125 --switch-interval 0 --label new-si0 --out "$out/batch_frames.jsonl" 2>/dev/null | tail -1 | cut -c1-500
done
