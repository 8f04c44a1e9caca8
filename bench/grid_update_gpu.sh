#!/usr/bin/env bash
# The granular grid update's register cap and batch of copies (Tuning.grid_update_registers and
# Tuning.grid_update_copies) in one GPU call: Nsight Compute found the four-copy batch, capped at 32
# registers, spilling to local memory on the 1M cloud. Its CUDA tests first, then the settings
# registers:copies alternated twice (tuning_ab_gpu.sh; about 5 minutes warm)
#   OUT=$OUT bash bench/grid_update_gpu.sh
set -uo pipefail
python -m pytest -m cuda -q -p no:cacheprovider tests/sim/test_register_caps.py 2>&1 | tail -1
settings=()
for s in 32:4 32:2 32:1 40:2 48:4 None:4 None:2; do
  settings+=("grid_update_registers=${s%:*},grid_update_copies=${s#*:}")
done
bash bench/tuning_ab_gpu.sh "${settings[@]}"
