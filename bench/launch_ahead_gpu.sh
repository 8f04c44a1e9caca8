#!/usr/bin/env bash
# How much of a frame's steps to launch before the host's work on the frame before
# (Tuning.launch_ahead_fraction, 0.5): a 16-world block-impact batch's run took 7.4 s on an H200
# (ac87b29) against about 4 s of steps without frames (H100): the frames' host work overlaps the
# steps only while launched steps remain. 0.5 / 0.75 / 0.9, alternated twice (bench/batch_frames.py: the 16-start
# ensemble's batch at 3.125 mm and the five 2.5 mm Beverloo silos; rows to $OUT, about 5 minutes warm)
#   OUT=$OUT bash bench/launch_ahead_gpu.sh
set -uo pipefail
out=${OUT:-/tmp/out}; mkdir -p "$out"
for round in 1 2; do
  for fraction in 0.5 0.75 0.9; do
    python bench/batch_frames.py --device cuda --case sand-blocks --worlds 16 --cell-size 0.003125 \
      --tuning launch_ahead_fraction=$fraction --label "ahead $fraction round $round" \
      --out "$out/batch_frames.jsonl" > /dev/null 2>&1
    python bench/batch_frames.py --device cuda --case silo-discharge --worlds 5 --cell-size 0.0025 \
      --tuning launch_ahead_fraction=$fraction --label "ahead $fraction round $round" \
      --out "$out/batch_frames.jsonl" > /dev/null 2>&1
  done
done
python - "$out/batch_frames.jsonl" <<'PY'
import json, sys
for line in open(sys.argv[1]):
    r = json.loads(line)
    print(r["case"], r["worlds"], r["label"], "run_s", r["run_s"], "steps_s", r["steps_s"], "frames_s", r["frames_s"])
PY
