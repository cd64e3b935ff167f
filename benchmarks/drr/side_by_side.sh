#!/usr/bin/env bash
# gimm-drr vs plastimatch drr on the same attenuation volume and geometry, whole process.
#   benchmarks/drr/side_by_side.sh [BUILD_DIR] [OUT_DIR]
# Needs: scripts/install-deps.sh bench (plastimatch, python3-numpy, gnuplot).
# Geometry: AP view, SID 1000 mm, SOD 750 mm, 512 x 512 detector of 0.5 mm, isocentre at the
# volume centre; volume: benchmarks/drr/make_volume.py (256^3 float32, 0.75 mm, .nii).
# Both run with OMP_NUM_THREADS=2; times are the best of 3 whole-process runs (wall clock).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
build=${1:-build}
out=${2:-$(mktemp -d)}
mkdir -p "$out"
export OMP_NUM_THREADS=2
py=/usr/bin/python3
gimm_drr="$build/examples/gimm-drr"
[ -x "$gimm_drr" ] || { echo "error: $gimm_drr not built" >&2; exit 1; }
command -v plastimatch >/dev/null || { echo "error: plastimatch missing: scripts/install-deps.sh bench" >&2; exit 1; }

[ -f "$out/mu.nii" ] || $py "$here/make_volume.py" "$out/mu.nii"

best_of_3() {  # prints the best wall time in seconds of a command run 3 times
  local best=999
  for _ in 1 2 3; do
    local t0 t1
    t0=$(date +%s.%N)
    "$@" >/dev/null 2>&1
    t1=$(date +%s.%N)
    best=$($py -c "print(min($best, $t1 - $t0))")
  done
  echo "$best"
}

# plastimatch: -n is the unit vector from the isocentre towards the source (posterior, +y
# in LPS for AP), vup the image's up direction (head).
pm_common=(drr -P none --sad 750 --sid 1000 -r "512 512" -z "256 256" -n "0 1 0" --vup "0 0 1"
           -o "0 0 0" -t pfm)
t_pm_exact=$(best_of_3 plastimatch "${pm_common[@]}" -i exact -O "$out/pm_exact" "$out/mu.nii")
t_pm_uniform=$(best_of_3 plastimatch "${pm_common[@]}" -i uniform -O "$out/pm_uniform" "$out/mu.nii")
g_common=(--volume "$out/mu.nii" --recipe none --primary 0 --secondary 0 --isocenter 0 0 0 --quiet)
t_g_siddon=$(best_of_3 "$gimm_drr" "${g_common[@]}" --projector siddon --out "$out/gimm_siddon")
t_g_tri=$(best_of_3 "$gimm_drr" "${g_common[@]}" --projector trilinear --step 0.75 --out "$out/gimm_trilinear")

$py "$here/compare.py" "$out" "$t_pm_exact" "$t_pm_uniform" "$t_g_siddon" "$t_g_tri"
