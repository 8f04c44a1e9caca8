#!/usr/bin/env bash
# Runs the studies of the silo (Beverloo) and the block impact, and the column collapse, on the GPUs
# of this machine, timing each whole study (compilation included: a fresh machine has no kernel
# cache), and packs every run's summary.json, the tables and the charts into $OUT/studies.tgz.
#   bash bench/gpu_studies.sh GPUS WORKERS_PER_GPU "study1 study2 ..."
set -uo pipefail
gpus=${1:-1}; k=${2:-4}; studies=${3:-"beverloo beverloo-methods block-impact block-impact-coupling block-impact-rounding column-collapse"}
out=${OUT:-/tmp/out}; root=/tmp/studies; mkdir -p "$root" "$out"
for s in $studies; do
  name=$(basename "$s" .toml)
  [ "${COLD:-0}" = 1 ] && python -c "import warp; warp.clear_kernel_cache()" >/dev/null 2>&1
  t0=$(date +%s.%N)
  python -m mpmdem.cli study "$s" --gpus "$gpus" --workers-per-gpu "$k" --out "$root/$name-g$gpus-k$k" \
    > "$root/$name-g$gpus-k$k.log" 2>&1
  rc=$?
  t1=$(date +%s.%N)
  python - "$name" "$gpus" "$k" "$t0" "$t1" "$rc" "$root/$name-g$gpus-k$k" <<'PY' | tee -a "$out/study_times.jsonl"
import json, subprocess, sys
s, g, k, t0, t1, rc, d = sys.argv[1:]
rows = [json.loads(l) for l in open(f"{d}/results.jsonl")] if rc == "0" else []
gpu = subprocess.run(["nvidia-smi", "--query-gpu=name", "--format=csv,noheader"], capture_output=True, text=True).stdout.split("\n")[0]
import os
print(json.dumps({"study": s, "gpus": int(g), "workers_per_gpu": int(k), "device": gpu, "rc": int(rc),
                  "cold_cache": os.environ.get("COLD", "0") == "1",
                  "seconds": round(float(t1) - float(t0), 1), "runs": len(rows),
                  "completed": sum(r.get("status") == "completed" for r in rows),
                  "run_seconds_sum": round(sum(r.get("wall_seconds") or 0 for r in rows), 1)}))
PY
done
tar czf "$out/studies.tgz" --exclude='*.h5' --exclude='*.xdmf' --exclude='*.csv' -C "$root" . 2>/dev/null
ls -la "$out"
