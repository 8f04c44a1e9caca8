#!/usr/bin/env bash
# The bench figures of two source trees on this machine, one after the other in one call, so a
# refactor's "within noise" claim compares like with like (issue 28: re-measure after the change).
#   bash bench/compare_trees.sh LABEL=DIR [LABEL=DIR ...]
# For each tree: bench/small_scenes.py (the four small cases, 5000 steps), bench/mpm_throughput.py
# at 1M points (its in-file MLS-MPM reference and the shared probe PROBE_MPM, default
# .gpu/b/bench/warp_mlsmpm2d.py, in the same process), bench/dem_throughput.py at 1M pentagons with
# the shared DEM probe (PROBE_DEM, default .gpu/b/bench/warp_dem2d.py) and
# bench/coupled_throughput.py (1M points + 10k pentagons). Rows go to $OUT/compare.jsonl, each
# tagged with "tree"; logs to $OUT/compare_<label>.log. Each tree runs its own bench scripts.
set -uo pipefail
out=${OUT:-/tmp/out}; mkdir -p "$out"
probe=$(realpath "${PROBE_DEM:-.gpu/b/bench/warp_dem2d.py}")
probe_mpm=$(realpath "${PROBE_MPM:-.gpu/b/bench/warp_mlsmpm2d.py}")
for spec in "$@"; do
  label=${spec%%=*}; dir=$(realpath "${spec#*=}")
  rows=$(mktemp)
  (
    cd "$dir" || exit 1
    export PYTHONPATH="$dir:${PYTHONPATH:-}"
    python -c "import mpmdem, mpmdem.kernels.transfer as t; print('tree', mpmdem.__file__, t.__file__)"
    python bench/small_scenes.py --device cuda --out "$rows"
    python bench/mpm_throughput.py --device cuda --sizes 1048576 --probe "$probe_mpm" --out "$rows"
    python bench/dem_throughput.py --device cuda --sizes 1000000 --probe "$probe" --out "$rows"
    python bench/coupled_throughput.py --device cuda --sizes 1048576 --bodies 10000 --walls --out "$rows"
  ) > "$out/compare_$label.log" 2>&1
  python - "$label" "$rows" <<'PY' | tee -a "$out/compare.jsonl"
import json, sys
label, path = sys.argv[1:]
for line in open(path):
    if line.strip():
        row = json.loads(line)
        row["tree"] = label
        print(json.dumps(row))
PY
  rm -f "$rows"
done
