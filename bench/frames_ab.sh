#!/usr/bin/env bash
# A/B of what a batched study's frames cost (issue 46), in one call on one GPU: bench/batch_frames.py
# and the whole `mpmdem study beverloo --gpus 1` (default flags) on a baseline tree BASE (a `git
# archive` of the commit before the change, folders mpmdem/ kernels/ cases/) and on this tree.
# Rows go to $OUT/batch_frames.jsonl and $OUT/study_times.jsonl (label "base" or "new").
#   git archive OLD mpmdem kernels cases | tar -x -C .gpu/base    # then, on the GPU machine:
#   BASE=.gpu/base CELLS="0.0035 0.0025" bash bench/frames_ab.sh
# CELLS="" skips the bench; STUDIES="new" runs only this tree's study; KERNEL_CACHE labels the rows;
# LONE=N also times N rounds of a lone `mpmdem run silo-discharge --device cuda` on each tree,
# alternating (base, new, base, new, ...) after the rest, so every one of them finds a warm cache.
set -uo pipefail
out=${OUT:-/tmp/out}; base=${BASE:-.gpu/base}; root=$PWD; mkdir -p "$out"
commit=${COMMIT:-$(git rev-parse --short HEAD 2>/dev/null || echo unknown)}
for h in ${CELLS-0.0035 0.0025}; do
  PYTHONPATH=$root/$base:${PYTHONPATH:-} python bench/batch_frames.py --cell-size "$h" --label base \
    --out "$out/batch_frames.jsonl" 2>/dev/null | tail -1 | cut -c1-400
  python bench/batch_frames.py --cell-size "$h" --label new --out "$out/batch_frames.jsonl" 2>/dev/null \
    | tail -1 | cut -c1-400
done
for label in ${STUDIES-base new}; do
  dir=$root; [ "$label" = base ] && dir=$root/$base
  t0=$(date +%s.%N)
  (cd "$dir" && python -m mpmdem.cli study beverloo --gpus 1 --out "/tmp/bev-$label" ${STUDY_FLAGS:-}) \
    > "/tmp/bev-$label.log" 2>&1
  rc=$?; t1=$(date +%s.%N)
  python - "$label" "$rc" "$t0" "$t1" "$commit" "/tmp/bev-$label" <<'PY' | tee -a "$out/study_times.jsonl"
import json, os, subprocess, sys
label, rc, t0, t1, commit, d = sys.argv[1:]
rows = [json.loads(line) for line in open(f"{d}/results.jsonl")] if rc == "0" else []
log = open(f"{d}.log").read().splitlines()
gpu = subprocess.run(["nvidia-smi", "--query-gpu=name", "--format=csv,noheader"], capture_output=True,
                     text=True).stdout.split("\n")[0]
print(json.dumps({"study": "beverloo", "label": label, "runs": len(rows), "rc": int(rc),
                  "completed": sum(r.get("status") == "completed" for r in rows),
                  "wall_s": round(float(t1) - float(t0), 1), "commit": commit,
                  "batch_walls_s": sorted({round(r.get("wall_seconds") or 0, 1) for r in rows}),
                  "grouping": next((ln for ln in log if ln.startswith("study ")), ""), "device": gpu,
                  "kernel_cache": os.environ.get("KERNEL_CACHE", "warm"), "command": "mpmdem study beverloo --gpus 1"}))
PY
done
for round in $(seq 1 "${LONE:-0}"); do
  for label in base new; do
    dir=$root; [ "$label" = base ] && dir=$root/$base
    t0=$(date +%s.%N)
    (cd "$dir" && python -m mpmdem.cli run silo-discharge --device cuda --out "/tmp/lone-$label") \
      > "/tmp/lone-$label.log" 2>&1
    rc=$?; t1=$(date +%s.%N)
    python -c "import json, sys; print(json.dumps({'run': 'silo-discharge', 'label': sys.argv[1], 'round': int(sys.argv[2]),
'rc': int(sys.argv[3]), 'wall_s': round(float(sys.argv[5]) - float(sys.argv[4]), 2), 'commit': sys.argv[6]}))" \
      "$label" "$round" "$rc" "$t0" "$t1" "$commit" | tee -a "$out/lone_runs.jsonl"
  done
done
