#!/usr/bin/env bash
# Where a G2P register cap pays (Tuning.g2p_registers; since call s59-B the default from 524288 points on): on one H200 a cap of 64
# made plain MPM at 1M points 6 % faster and a dense granular column 3-5 %, and a batch of five
# 2.5 mm Beverloo silos 2-3 % slower (docs/benchmarks.md). This call asks which scenes gain, to
# choose between a default cap, a cap by size, or none. Uncapped and 64, alternated twice (rows to
# $OUT; about 6 minutes on a warm kernel cache):
#   the dense column (plain and granular) at 65k, 262k, 1M and 4M points (granular_overhead.py);
#   the four small scenes (step_profile.py --cases) and Beverloo batches of 1 and 5 silos at 2.5 mm and
#   of 5 at 5 mm (step_profile.py --silo-batches)
#   OUT=$OUT bash bench/g2p_cap_gpu.sh
set -uo pipefail
out=${OUT:-/tmp/out}; mkdir -p "$out"
for round in 1 2; do
  for cap in None 64; do
    python bench/granular_overhead.py --device cuda --scenes dense-column --sizes 65536,262144,1048576,4194304 \
      --tuning g2p_registers=$cap --tuning g2p_registers_points=0 --out "$out/granular_overhead.jsonl" > /dev/null 2> "$out/go.err"
    grep "granular/plain" "$out/go.err" | sed "s/^/round $round g2p_registers=$cap /"
    python bench/step_profile.py --device cuda --steps 100 --tuning g2p_registers=$cap --tuning g2p_registers_points=0 \
      --out "$out/step_profile.jsonl" > /dev/null 2>&1
    python bench/step_profile.py --device cuda --silo-batches 0.0025:1,0.0025:5,0.005:5 --steps 100 \
      --tuning g2p_registers=$cap --tuning g2p_registers_points=0 --out "$out/step_profile.jsonl" > /dev/null 2>&1
  done
done
python bench/tuning_rows.py "$out/step_profile.jsonl" "$out/granular_overhead.jsonl"
