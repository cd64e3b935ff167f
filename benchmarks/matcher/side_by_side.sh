#!/usr/bin/env bash
# The GIMM matcher, same model and weights, three engines side by side: the gimm engine
# (gimm_matcher_bench), PyTorch CPU (Debian python3-torch, OpenBLAS) and ONNX Runtime CPU
# (onnxruntime-node from the npm registry, model exported from PyTorch), at 256^2, 384^2 and
# 512^2, two threads each.
#   benchmarks/matcher/side_by_side.sh [BUILD_DIR] [OUT_DIR] [RUNS]
# Needs: scripts/install-deps.sh all (python3-torch, libopenblas0-pthread, python3-opencv),
# node and npm (onnxruntime-node is installed into OUT_DIR/ort on first use).
# Inputs: two views (LAO 30 / CRA 20 and RAO 30 / CAU 20, LCA injected) of phantom seed 0
# rendered by gimm-drr at each size, read from the 16-bit PNGs. Weights: tools/train/export.py
# --seed 0 (PyTorch's default initialisation) with threshold 0, so every mutual match is
# refined and the fine stage is exercised fully; the three engines must return the same
# matches (checked: same count, points within 0.01 px).
# Timing: in-process, median of RUNS pairs after one warm-up (PyTorch with OPENBLAS_NUM_THREADS=1,
# its fastest setting here); memory: each process's peak RSS
# (getrusage maxrss), one fresh process per engine and size.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
build=${1:-build}
out=${2:-$(mktemp -d)}
runs=${3:-10}
mkdir -p "$out/pairs" "$out/dump"
export OMP_NUM_THREADS=2
py=/usr/bin/python3
# docs/performance.md's figures are for binaries built for this CPU (-DGIMM_ARCH=native).
grep -qs '^GIMM_ARCH:STRING=native$' "$build/CMakeCache.txt" ||
  echo "note: $build is not built with -DGIMM_ARCH=native; figures will not match docs/performance.md" >&2
bench="$build/benchmarks/gimm_matcher_bench"
for tool in "$bench" "$build/examples/gimm-phantom" "$build/examples/gimm-drr"; do
  [ -x "$tool" ] || { echo "error: $tool not built (cmake --build $build --target all gimm_benchmarks)" >&2; exit 1; }
done
$py -c "import torch, cv2" 2>/dev/null || { echo "error: python3-torch/python3-opencv missing: scripts/install-deps.sh all" >&2; exit 1; }
command -v npm >/dev/null || { echo "error: npm missing (apt-get install npm)" >&2; exit 1; }
if [ ! -d "$out/ort/node_modules/onnxruntime-node" ]; then
  echo "side_by_side: installing onnxruntime-node into $out/ort" >&2
  ONNXRUNTIME_NODE_INSTALL_CUDA=skip npm install --silent --prefix "$out/ort" onnxruntime-node >&2
fi
export ORT_NODE_MODULES="$out/ort"

sizes=(256 384 512)
[ -f "$out/phantom/0.img.nii.gz" ] || "$build/examples/gimm-phantom" --seed 0 --out "$out/phantom" >&2
vol="$out/phantom/0"
for s in "${sizes[@]}"; do
  pixel=$($py -c "print(0.5 * 512 / $s)")
  for view in "a 30 20" "b -30 -20"; do
    set -- $view
    "$build/examples/gimm-drr" --volume "$vol.img.nii.gz" --label "$vol.label.nii.gz" --system LCA \
      --primary "$2" --secondary "$3" --rows "$s" --cols "$s" --pixel "$pixel" --out "$out/pairs/${1}_$s" >&2
  done
  $py - "$out/pairs" "$s" <<'PY'
import sys, cv2, numpy as np
d, s = sys.argv[1], sys.argv[2]
imgs = [cv2.imread(f"{d}/{v}_{s}.png", cv2.IMREAD_UNCHANGED).astype(np.float32) / 65535.0 for v in "ab"]
np.stack(imgs).astype(np.float32).tofile(f"{d}/pair_{s}.f32")
PY
done

$py "$root/tools/train/export.py" --seed 0 --threshold 0 --out "$out/model.safetensors" \
  --onnx "$out/model" --sizes "${sizes[@]}" 2>/dev/null >&2

results="$out/results.jsonl"
: > "$results"
for s in "${sizes[@]}"; do
  GIMM_MATCHER_WEIGHTS="$out/model.safetensors" GIMM_MATCHER_PAIRS="$out/pairs" GIMM_MATCHER_DUMP="$out/dump" \
    "$bench" --benchmark_filter="BM_MatchPair/$s/" --benchmark_repetitions="$runs" \
    --benchmark_min_time=0 --benchmark_format=json > "$out/gimm_$s.json"
  $py - "$out/gimm_$s.json" "$s" >> "$results" <<'PY'
import json, statistics, sys
runs = [b for b in json.load(open(sys.argv[1]))["benchmarks"] if b.get("run_type") == "iteration"]
t = [b["real_time"] / 1e3 for b in runs]  # ms -> s
print(json.dumps({"engine": "gimm", "size": int(sys.argv[2]), "median_s": statistics.median(t),
                  "min_s": min(t), "matches": int(runs[-1]["matches"]),
                  "peak_rss_mb": max(b["peak_rss_mb"] for b in runs)}))
PY
  # OpenBLAS's own threads on top of PyTorch's two OpenMP threads oversubscribe the two cores
  # (median 0.16-0.23 s at 256^2 against 0.08 s): PyTorch runs in its best configuration.
  OPENBLAS_NUM_THREADS=1 $py "$here/run_torch.py" "$out/model.safetensors" "$out/pairs" "$s" "$runs" "$out/dump" >> "$results"
  node "$here/run_ort.mjs" "$out/model_$s.onnx" "$out/pairs" "$s" "$runs" "$out/dump" >> "$results"
done
$py "$here/report.py" "$results" "$out/dump" "$out"
