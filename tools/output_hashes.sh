#!/usr/bin/env bash
# sha256 of every output a refactor must keep byte-identical: a 2-patient phantom dataset in
# voxel and in mesh mode, gimm-drr, gimm-match
# and gimm-eval outputs on it.
#
#   tools/output_hashes.sh BUILD_DIR WORK_DIR > hashes.txt
#
# Compare two runs with diff (before and after a refactor).
set -euo pipefail
build=$(cd "$1" && pwd)
work=$2
rm -rf "$work" && mkdir -p "$work" && cd "$work"
bin=$build/examples
for mode in voxel mesh; do
  "$bin/gimm-dataset" --phantom 2 --style drr --out "ds_$mode" --rows 128 --cols 128 --pixel 2.0 \
    --vessels "$mode" --seed 5 --quiet > /dev/null
done
"$bin/gimm-phantom" --seed 9 --out ph > /dev/null
"$bin/gimm-drr" --volume ph/9.img.nii.gz --label ph/9.label.nii.gz --system RCA --primary -30 \
  --secondary 10 --rows 96 --cols 96 --pixel 2 --out drr --quiet
"$bin/gimm-drr" --volume ph/9.img.nii.gz --primary 0 --secondary 0 --rows 64 --cols 64 \
  --pixel 3 --projector trilinear --out drr_tri --quiet
weights=$(dirname "$build")/tests/data/nn/parity_anchor_weights.safetensors
"$bin/gimm-match" --dataset ds_voxel --weights "$weights" --out pred > /dev/null 2>&1
"$bin/gimm-eval" --dataset ds_voxel --predictions pred --out eval --name parity > /dev/null
find . -type f ! -name timings.json -print0 | sort -z | xargs -0 sha256sum
