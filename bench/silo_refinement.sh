#!/usr/bin/env bash
# The silo refinement studies on this machine's GPU(s) (issue μ(I)): beverloo-mu-i, beverloo-refined,
# beverloo-mu-i-grain, in results/<study>/ (a later call resumes them), each study's wall time in
# $OUT/study_times.jsonl, and the tables, fits and charts (no .h5) packed into $OUT/refinement.tgz.
#   bash bench/silo_refinement.sh WORKERS_PER_GPU "study1 study2 ..." [DEADLINE_S]
set -uo pipefail
k=${1:-12}; studies=${2:-"beverloo-mu-i beverloo-refined beverloo-mu-i-grain"}; deadline=${3:-560}
out=${OUT:-/tmp/out}; mkdir -p results "$out"
t_start=$(date +%s)
for s in $studies; do
  left=$(( deadline - ($(date +%s) - t_start) ))
  [ "$left" -le 20 ] && break
  t0=$(date +%s.%N)
  timeout "$left" python -m mpmdem.cli study "$s" --gpus 1 --workers-per-gpu "$k" --out "results/$s" > "results/$s.log" 2>&1
  rc=$?
  t1=$(date +%s.%N)
  python - "$s" "$k" "$t0" "$t1" "$rc" <<'PY' | tee -a "$out/study_times.jsonl"
import json, subprocess, sys, os
s, k, t0, t1, rc = sys.argv[1:]
p = f"results/{s}/results.jsonl"
rows = [json.loads(l) for l in open(p)] if os.path.exists(p) else []
gpu = subprocess.run(["nvidia-smi", "--query-gpu=name", "--format=csv,noheader"], capture_output=True, text=True).stdout.split("\n")[0]
print(json.dumps({"study": s, "workers_per_gpu": int(k), "device": gpu, "rc": int(rc), "seconds": round(float(t1) - float(t0), 1),
                  "rows": len(rows), "completed": sum(r.get("status") == "completed" for r in rows)}))
PY
done
tar czf "$out/refinement.tgz" --exclude='*.h5' --exclude='*.xdmf' --exclude='energy.csv' results/beverloo-* 2>/dev/null
ls -la "$out"
