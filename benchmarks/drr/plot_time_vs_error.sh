#!/usr/bin/env bash
# Charts: DRR time against error for both projectors over trilinear step sizes.
#   benchmarks/drr/plot_time_vs_error.sh [BUILD_DIR] [SIDE_BY_SIDE_OUT_DIR]
# 1. docs/images/drr_time_vs_error.png: gimm only, Google Benchmark render times
#    (gimm_drr_accuracy_bench: 60 Gaussian blobs, 256^3 -> 512^2, LAO 30 / cranial 20).
# 2. docs/images/drr_time_vs_error_plastimatch.png (when SIDE_BY_SIDE_OUT_DIR, the output of
#    side_by_side.sh, is given): gimm-drr and plastimatch drr on that script's blob volume
#    (same kind of scene, its own seed), LAO 30 / cranial 20, render time as each tool reports it
#    (gimm-drr "render", plastimatch "Total time": rendering + writing the image, no volume
#    load), median of 3 runs, OMP_NUM_THREADS=2; error against the analytic line integrals.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
build=${1:-$root/build}
sbs=${2:-}
tmp=$(mktemp -d)
export OMP_NUM_THREADS=2
[ -x "$build/benchmarks/gimm_drr_accuracy_bench" ] ||
  { echo "error: $build/benchmarks/gimm_drr_accuracy_bench not built (cmake --build $build --target gimm_benchmarks)" >&2; exit 1; }
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
     "$tmp/tri.dat" using 1:(\$2*(int(\$0)%2 ? 0.93 : 1.07)):(sprintf("%.2f", \$3)) with labels notitle, \
     "$tmp/siddon.dat" using 1:2 with points pt 9 ps 2 title "siddon (exact)"
GP
echo "wrote $root/docs/images/drr_time_vs_error.png"
[ -n "$sbs" ] || exit 0

# 2. gimm-drr and plastimatch drr on the side-by-side blob volume.
median3() { /usr/bin/python3 -c "import sys; print(sorted(map(float, sys.argv[1:]))[1])" "$@"; }
g=("$build/examples/gimm-drr" --volume "$sbs/blobs.nii" --recipe none --primary 30 --secondary 20
   --isocenter 0 0 0)
read -r nx ny nz ux uy uz < <(/usr/bin/python3 "$here/compare.py" flags \
  "$sbs/blobs_lao_g_siddon.camera.json")
pm=(plastimatch drr -P none --sad 750 --sid 1000 -r "512 512" -z "256 256" -c "255.5 255.5"
    -n "$nx $ny $nz" --vup "$ux $uy $uz" -o "0 0 0" -t pfm)
: > "$tmp/runs.txt"
gimm_run() {  # STEP_MM (0 = siddon)
  local args=(--projector siddon) ts=()
  [ "$1" = 0 ] || args=(--projector trilinear --step "$1")
  for _ in 1 2 3; do
    ts+=("$("${g[@]}" "${args[@]}" --out "$tmp/g_$1" | sed -E 's/.*render ([0-9.]+) ms.*/\1/')")
  done
  echo "gimm_$([ "$1" = 0 ] && echo siddon || echo trilinear) $1 $(median3 "${ts[@]}") $tmp/g_$1.npy" >> "$tmp/runs.txt"
}
pm_run() {  # exact|uniform
  local ts=()
  for _ in 1 2 3; do
    ts+=("$("${pm[@]}" -i "$1" -O "$tmp/pm_$1" "$sbs/blobs.nii" | sed -nE 's/Total time: ([0-9.e+-]+) secs/\1/p')")
  done
  local s; s=$(median3 "${ts[@]}")
  echo "plastimatch_$1 $([ "$1" = exact ] && echo 0 || echo 0.5625) $(/usr/bin/python3 -c "print($s * 1000)") $tmp/pm_$1""0000.pfm" >> "$tmp/runs.txt"
}
gimm_run 0
for step in 3 1.5 0.75 0.5625 0.375 0.1875; do gimm_run $step; done
pm_run exact
pm_run uniform
/usr/bin/python3 "$here/compare.py" chart "$sbs" "$tmp/runs.txt" > "$tmp/chart.dat"
echo
echo "| tool | step (mm) | render time (ms, median of 3) | mean rel. error | mean abs error |"
echo "| --- | --- | --- | --- | --- |"
awk '{printf "| %s | %s | %.0f | %.3e | %.3e |\n", $1, ($1 ~ /siddon|exact/ ? "exact" : $2), $3, $4, $5}' "$tmp/chart.dat"
grep gimm_trilinear "$tmp/chart.dat" > "$tmp/g_tri.dat"
grep gimm_siddon "$tmp/chart.dat" > "$tmp/g_sid.dat"
grep plastimatch_exact "$tmp/chart.dat" > "$tmp/pm_exact.dat"
grep plastimatch_uniform "$tmp/chart.dat" > "$tmp/pm_uniform.dat"
gnuplot <<GP
set terminal pngcairo size 800,560 enhanced font "DejaVu Sans,11"
set output "$root/docs/images/drr_time_vs_error_plastimatch.png"
set title "gimm-drr vs plastimatch drr, 256^3 blobs -> 512^2, LAO 30 / CRA 20, 2 threads"
set xlabel "render time as reported by each tool (ms)"
set ylabel "mean relative error vs analytic line integrals"
set logscale xy
set grid
set key top right
plot "$tmp/g_tri.dat" using 3:4 with linespoints pt 7 lw 2 title "gimm trilinear (labels: step in mm)", \
     "$tmp/g_tri.dat" using 3:(\$4*(int(\$0)%2 ? 0.93 : 1.07)):2 with labels notitle, \
     "$tmp/g_sid.dat" using 3:4 with points pt 9 ps 2 title "gimm siddon (exact)", \
     "$tmp/pm_exact.dat" using 3:4 with points pt 5 ps 1.6 title "plastimatch exact", \
     "$tmp/pm_uniform.dat" using 3:4 with points pt 13 ps 1.8 title "plastimatch uniform (0.5625 mm)"
GP
echo "wrote $root/docs/images/drr_time_vs_error_plastimatch.png"
