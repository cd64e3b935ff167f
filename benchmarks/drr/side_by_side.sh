#!/usr/bin/env bash
# gimm-drr vs plastimatch drr on the same attenuation volumes (mm^-1) and geometry.
#   benchmarks/drr/side_by_side.sh [BUILD_DIR] [OUT_DIR] [RUNS]
# Needs: scripts/install-deps.sh bench (plastimatch, hyperfine, python3-numpy).
# Geometry: gimm's C-arm defaults (SID 1000 mm, SOD 750 mm, 512 x 512 detector of 0.5 mm,
# principal point at the centre), isocentre at the volume centre; plastimatch's --nrm/--vup are
# derived from gimm's camera.json (compare.py flags) and its image orientation is checked, not
# assumed (compare.py report). Volumes (benchmarks/drr/make_volume.py, 256^3 float32 .nii,
# 0.75 mm): thorax (timing, orientation, agreement), Gaussian blobs (analytic truth) and a
# 64^3 cube of ones (analytic chord lengths); and the thorax stored with direction cosines
# -1 on x and y (same object in the world: a direction-cosine check).
# Units: both read mu in mm^-1: gimm-drr --recipe none, plastimatch -P none (no HU conversion;
# its default, preprocess, would map HU to mu with mu_water 0.022 /mm). plastimatch divides its
# line integral by 10; compare.py multiplies it back.
# Timing: hyperfine, whole process, OMP_NUM_THREADS=2, RUNS runs after 1 warm-up, AP view.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
build=${1:-build}
out=${2:-$(mktemp -d)}
runs=${3:-10}
mkdir -p "$out"
export OMP_NUM_THREADS=2
py=/usr/bin/python3
# docs/performance.md's figures are for binaries built for this CPU (-DGIMM_ARCH=native).
grep -qs '^GIMM_ARCH:STRING=native$' "$build/CMakeCache.txt" ||
  echo "note: $build is not built with -DGIMM_ARCH=native; figures will not match docs/performance.md" >&2
gimm_drr="$build/examples/gimm-drr"
[ -x "$gimm_drr" ] || { echo "error: $gimm_drr not built" >&2; exit 1; }
for tool in plastimatch hyperfine; do
  command -v $tool >/dev/null || { echo "error: $tool missing: scripts/install-deps.sh bench" >&2; exit 1; }
done

[ -f "$out/thorax.nii" ] || $py "$here/make_volume.py" "$out/thorax.nii"
[ -f "$out/blobs.nii" ] || $py "$here/make_volume.py" --blobs "$out/blobs.nii" "$out/blobs.json"
[ -f "$out/thorax_flipped.nii" ] || $py "$here/make_volume.py" --thorax-flipped "$out/thorax_flipped.nii"
[ -f "$out/cube.nii" ] || $py "$here/make_volume.py" --cube "$out/cube.nii"

# One scene: VOLUME NAME PRIMARY SECONDARY -> the commands for all tools, run once, and the
# commands themselves in $out/NAME.cmds (for hyperfine).
scene() {
  local vol=$1 name=$2 primary=$3 secondary=$4
  local g=("$gimm_drr" --volume "$out/$vol.nii" --recipe none --primary "$primary"
           --secondary "$secondary" --isocenter 0 0 0 --quiet)
  "${g[@]}" --projector siddon --out "$out/${name}_g_siddon"
  read -r nx ny nz ux uy uz < <($py "$here/compare.py" flags "$out/${name}_g_siddon.camera.json")
  local pm="plastimatch drr -P none --sad 750 --sid 1000 -r '512 512' -z '256 256'"
  pm+=" -c '255.5 255.5' -n '$nx $ny $nz' --vup '$ux $uy $uz' -o '0 0 0' -t pfm"
  {
    echo "${g[*]} --projector siddon --out $out/${name}_g_siddon"
    echo "${g[*]} --projector trilinear --step 0.75 --out $out/${name}_g_tri075"
    echo "${g[*]} --projector trilinear --step 0.5625 --out $out/${name}_g_tri05625"
    echo "$pm -i exact -O $out/${name}_pm_exact $out/$vol.nii"
    echo "$pm -i uniform -O $out/${name}_pm_uniform $out/$vol.nii"
  } > "$out/$name.cmds"
  while read -r cmd; do eval "$cmd" >/dev/null; done < "$out/$name.cmds"
}
scene thorax thorax_ap 0 0
scene thorax thorax_lao 30 20
scene blobs blobs_lao 30 20
scene cube cube_lao 30 20
scene thorax_flipped thorax_flipped_ap 0 0  # direction cosines: same object, other storage

mapfile -t cmds < "$out/thorax_ap.cmds"
echo "load average before: $(cut -d' ' -f1-3 /proc/loadavg)" > "$out/load.txt"
hyperfine -N --warmup 1 --runs "$runs" --export-json "$out/times.json" "${cmds[@]}" >&2
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)" >> "$out/load.txt"
# In-process breakdown, 3 runs each: gimm-drr prints load/render/write, plastimatch prints
# "Total time" (rendering + writing the image; the rest of its wall time is start-up and load).
: > "$out/breakdown.txt"
for cmd in "${cmds[@]}"; do
  stem=$(sed -E 's/.* -(-out|O) [^ ]*thorax_ap_([a-z0-9_]+).*/\2/' <<< "$cmd")
  for _ in 1 2 3; do
    eval "${cmd/ --quiet/}" | grep -E "^gimm-drr:|^Total time" | sed "s/^/$stem: /" >> "$out/breakdown.txt"
  done
done
$py "$here/compare.py" report "$out"
