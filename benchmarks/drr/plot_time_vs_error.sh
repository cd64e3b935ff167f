#!/usr/bin/env bash
# Chart: DRR time against error for both projectors over trilinear step sizes.
#   benchmarks/drr/plot_time_vs_error.sh [BUILD_DIR]   -> docs/images/drr_time_vs_error.png
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
build=${1:-$root/build}
tmp=$(mktemp -d)
"$build/benchmarks/gimm_drr_accuracy_bench" --benchmark_format=json \
  --benchmark_out="$tmp/acc.json" >/dev/null
/usr/bin/python3 - "$tmp" <<'PY'
import json, sys
d = json.load(open(f"{sys.argv[1]}/acc.json"))
with open(f"{sys.argv[1]}/siddon.dat", "w") as s, open(f"{sys.argv[1]}/tri.dat", "w") as t:
    for b in d["benchmarks"]:
        line = f"{b['real_time']:.2f} {b['rel_error']:.6g} {b['step_voxels']:.3g}\n"
        (s if "Siddon" in b["name"] else t).write(line)
    print("| projector | step (voxels) | time (ms) | mean rel. error |")
    print("| --- | --- | --- | --- |")
    for b in d["benchmarks"]:
        kind = "siddon" if "Siddon" in b["name"] else "trilinear"
        step = "exact" if kind == "siddon" else f"{b['step_voxels']:.2f}"
        print(f"| {kind} | {step} | {b['real_time']:.0f} | {b['rel_error']:.2e} |")
PY
mkdir -p "$root/docs/images"
gnuplot <<GP
set terminal pngcairo size 800,560 enhanced font "DejaVu Sans,11"
set output "$root/docs/images/drr_time_vs_error.png"
set title "DRR 256^3 -> 512^2 (2 threads): time against error vs analytic line integrals"
set xlabel "time per DRR (ms)"
set ylabel "mean relative error"
set logscale xy
set grid
set key top right
plot "$tmp/tri.dat" using 1:2 with linespoints pt 7 lw 2 title "trilinear (labels: step in voxels)", \
     "$tmp/tri.dat" using 1:2:(sprintf("%.2f", \$3)) with labels offset 0,1 notitle, \
     "$tmp/siddon.dat" using 1:2 with points pt 9 ps 2 title "siddon (exact)"
GP
echo "wrote $root/docs/images/drr_time_vs_error.png"
