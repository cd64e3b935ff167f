#!/usr/bin/env bash
# Real-data path on phantoms: each pair rendered as two XA DICOM files (B with the table moved),
# matched from the DICOM files alone (gimm-match --dicom-a/b, learned and geometric), the
# matches triangulated (--tree) and scored in 3D against the phantom's analytic centerlines.
#
#   tools/dicom/phantom_pairs.sh BUILD OUT [PATIENTS]     (default 6 patients, 3 pairs each)
# Writes OUT/<seed>/..., OUT/learned.md and OUT/geometric.md (gimm-eval --tree tables).
set -euo pipefail
build=${1:?usage: phantom_pairs.sh BUILD OUT [PATIENTS]}
out=${2:?usage: phantom_pairs.sh BUILD OUT [PATIENTS]}
patients=${3:-6}
bin="$build/examples"
mkdir -p "$out"
# LCA view pairs (primary, secondary) of routine classes: LAO cranial / RAO cranial, LAO caudal /
# RAO caudal, AP / LAO cranial. B's table moves by a different amount in each pair (mm).
pairs=("45 22 -30 22 0 15 -20" "45 -28 -18 -20 5 -10 30" "0 0 45 22 -8 20 12")
learned=() geometric=() centerlines=()
for seed in $(seq 101 $((100 + patients))); do
  dir="$out/$seed"
  mkdir -p "$dir"
  "$bin/gimm-phantom" --seed "$seed" --out "$dir" > /dev/null
  n=0
  for p in "${pairs[@]}"; do
    read -r pa sa pb sb tx ty tz <<< "$p"
    common=(--volume "$dir/$seed.img.nii.gz" --label "$dir/$seed.label.nii.gz" --system LCA
            --rows 256 --cols 256 --pixel 1.0 --dicom --quiet)
    "$bin/gimm-drr" "${common[@]}" --primary "$pa" --secondary "$sa" --out "$dir/pair$n-a"
    "$bin/gimm-drr" "${common[@]}" --primary "$pb" --secondary "$sb" --table "$tx" "$ty" "$tz" \
      --out "$dir/pair$n-b"
    iso=$(python3 -c "import json; print(*json.load(open('$dir/pair$n-a.camera.json'))['isocenter'])")
    for method in learned geometric; do
      system=()  # the learned matcher's view classes need the system; the geometric refuses it
      [ "$method" = learned ] && system=(--system LCA)
      "$bin/gimm-match" --dicom-a "$dir/pair$n-a.dcm" --dicom-b "$dir/pair$n-b.dcm" "${system[@]}" \
        --isocenter $iso --method "$method" --out "$dir/pair$n.$method.json" \
        --tree "$dir/pair$n.$method.tree.json" --picture "$dir/pair$n.$method.png" > "$dir/pair$n.$method.log"
    done
    learned+=("$dir/pair$n.learned.tree.json")
    geometric+=("$dir/pair$n.geometric.tree.json")
    centerlines+=("$dir/$seed.centerlines.json")
    n=$((n + 1))
  done
  echo "phantom_pairs: patient $seed done ($((seed - 100))/$patients)" >&2
done
"$bin/gimm-eval" --tree "${learned[@]}" --centerlines "${centerlines[@]}" > "$out/learned.md"
"$bin/gimm-eval" --tree "${geometric[@]}" --centerlines "${centerlines[@]}" > "$out/geometric.md"
tail -n 1 "$out/learned.md" "$out/geometric.md"
