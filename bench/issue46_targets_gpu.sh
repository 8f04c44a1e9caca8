#!/usr/bin/env bash
# Issue 46's six targets measured again in one GPU call, each with its reference in the same call
# (rows and times to $OUT; about 6 minutes on a kernel cache warmed by the CUDA suite, more cold):
#   times.txt                whole commands, alternated: a lone block-impact start, the 16-start
#                            ensemble (target <= 2 x the lone start), the Beverloo study (target <= 25 s)
#   grain_throughput.jsonl   1M lattice disks, the disk-disk pass beside the probe (target >= 2e9 grain-steps/s)
#   coupled_throughput.jsonl 1M points with 10k pentagons against the same points alone (target >= 0.8)
#   granular_overhead.jsonl  granular over plain on the 1M dense column (<= 1.5) and the cloud (<= 3)
# The targets are H100 figures: name the device in what you report.
#   OUT=$OUT PROBE=.gpu/b/bench/warp_dem2d.py bash bench/issue46_targets_gpu.sh
set -uo pipefail
out=${OUT:-/tmp/out}; mkdir -p "$out"
probe=${PROBE:-../shared/bench/warp_dem2d.py}
nvidia-smi --query-gpu=name --format=csv,noheader | tee "$out/device.txt"
t() { local label=$1; shift; local t0; t0=$(date +%s.%N); "$@" > "$out/$label.log" 2>&1; local rc=$?
  python -c "import sys; print('$label', 'rc=$rc', round($(date +%s.%N) - $t0, 2))" | tee -a "$out/times.txt"; }
lone=(python -m mpmdem.cli run sand-blocks --ensemble-seed 1 --cell-size 0.003125 --device cuda)
t lone0 "${lone[@]}" --out /tmp/lone0  # (warms the kernel cache)
for r in 1 2; do
  t "lone$r" "${lone[@]}" --out "/tmp/lone$r"
  t "ensemble$r" python -m mpmdem.cli study block-impact-ensemble --set=--cell-size=0.003125 --gpus 1 --out "/tmp/ens$r"
done
t beverloo1 python -m mpmdem.cli study beverloo --gpus 1 --out /tmp/bev1
python bench/grain_throughput.py --device cuda --sizes 1000000 --probe "$probe" \
  --out "$out/grain_throughput.jsonl" 2>&1 | tail -2 | cut -c1-300
python bench/coupled_throughput.py --device cuda --sizes 1000000 --bodies 10000 \
  --out "$out/coupled_throughput.jsonl" 2>&1 | tail -2 | cut -c1-300
python bench/granular_overhead.py --device cuda --scenes dense-column,dispersed-cloud --sizes 1048576 \
  --out "$out/granular_overhead.jsonl" 2>&1 > /dev/null | grep "granular/plain"
