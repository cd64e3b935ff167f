#!/usr/bin/env bash
# The geometric matcher's speed at 256^2 and 512^2: a 1-patient phantom dataset at each size
# (same field of view), then gimm_geometric_bench on its first pair, with glibc's default
# allocator settings and with gimm-match's (freed memory kept mapped).
#   benchmarks/matcher/geometric.sh BUILD [WORK_DIR]
set -euo pipefail
build=$1 work=${2:-$(mktemp -d)}
[ -x "$build/benchmarks/gimm_geometric_bench" ] ||
  { echo "error: $build/benchmarks/gimm_geometric_bench not built (cmake --build $build --target gimm_benchmarks)" >&2; exit 1; }
for size in 256 512; do
  ds=$work/geometric-$size
  [ -f "$ds/manifest.json" ] || "$build/examples/gimm-dataset" --phantom 1 --style drr --seed 7 --rows $size \
    --cols $size --pixel "$(python3 -c "print(256.0 / $size)")" --out "$ds" --quiet
  # glibc's defaults (a program that calls the library), then gimm-match's policy
  # (examples/cli_common.hpp, keep_freed_memory: freed memory stays mapped for the next pair).
  for policy in default kept; do
    echo "== $size x $size, glibc allocator: $policy"
    env=()
    [ $policy = kept ] && env=(MALLOC_MMAP_THRESHOLD_=33554432 MALLOC_TRIM_THRESHOLD_=268435456
      MALLOC_TOP_PAD_=67108864)
    env "${env[@]}" GIMM_GEOMETRIC_DATASET="$ds" "$build/benchmarks/gimm_geometric_bench" \
      --benchmark_repetitions=3 --benchmark_report_aggregates_only=true
  done
done
