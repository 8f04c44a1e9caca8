#!/usr/bin/env bash
# Issue 46, the ensemble's frames on a GPU after the cheaper frame writing (the diagnostics as one
# table, the bodies' frame data as copies, writer children without Warp; 3c2a3e3): on the development
# CPU a frame of one file went 3.75 -> 2.52 ms and 16 worlds' frames 125-130 -> 103-107 ms
# (bench/batch_host.py), not yet timed on a GPU. Alternated twice in one call (rows to $OUT, about
# 5 minutes warm):
#   batch_frames.jsonl  bench/batch_frames.py --case sand-blocks --worlds 16 at 3.125 mm: BASE's tree
#                       ("base"), this tree with its writer thread ("new") and with two writer
#                       children ("new-2children")
#   times.txt           whole commands: a lone start and the 16-start ensemble on BASE and on this tree
#   git archive 9d911e8 mpmdem kernels cases | tar -x -C .gpu/base      # then, on the GPU machine:
#   OUT=$OUT BASE=.gpu/base bash bench/ensemble_writer_gpu.sh
set -uo pipefail
out=${OUT:-/tmp/out}; base=${BASE:-.gpu/base}; root=$PWD; mkdir -p "$out"
frames() {  # label tree [flags]
  local label=$1 tree=$2; shift 2
  PYTHONPATH=$tree:${PYTHONPATH:-} python bench/batch_frames.py --device cuda --case sand-blocks --worlds 16 \
    --cell-size 0.003125 --label "$label" --out "$out/batch_frames.jsonl" "$@" > /dev/null 2>&1
}
t() {  # label tree command...
  local label=$1 tree=$2; shift 2
  local t0; t0=$(date +%s.%N)
  (cd "$tree" && "$@") > "$out/$label.log" 2>&1
  local rc=$?
  python -c "import sys; print('$label', 'rc=$rc', round($(date +%s.%N) - $t0, 2))" | tee -a "$out/times.txt"
}
lone=(python -m mpmdem.cli run sand-blocks --ensemble-seed 1 --cell-size 0.003125 --device cuda --quiet)
ensemble=(python -m mpmdem.cli study block-impact-ensemble --set=--cell-size=0.003125 --gpus 1)
t warm-base "$root/$base" "${lone[@]}" --out /tmp/warm-base > /dev/null
t warm-new "$root" "${lone[@]}" --out /tmp/warm-new > /dev/null
for round in 1 2; do
  frames "base round $round" "$root/$base"
  frames "new round $round" "$root"
  frames "new-2children round $round" "$root" --writer-processes 2
  t "lone-base-$round" "$root/$base" "${lone[@]}" --out "/tmp/lone-base-$round"
  t "ensemble-base-$round" "$root/$base" "${ensemble[@]}" --out "/tmp/ens-base-$round"
  t "lone-new-$round" "$root" "${lone[@]}" --out "/tmp/lone-new-$round"
  t "ensemble-new-$round" "$root" "${ensemble[@]}" --out "/tmp/ens-new-$round"
done
python - "$out/batch_frames.jsonl" <<'PY'
import json, sys
for line in open(sys.argv[1]):
    r = json.loads(line)
    print(r["label"], "run_s", r["run_s"], "steps_s", r["steps_s"], "frames_s", r["frames_s"])
PY
