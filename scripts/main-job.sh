#!/usr/bin/env bash
# The main job on the built-in phantom, end to end: a DRR dataset of four procedural CCTA
# patients (none of them in the shipped weights' training data) -> gimm-match with the shipped
# weights and the gate they record: hard 4 px with the exact F of the cameras, the B points then
# snapped to their epipolar lines (the setting tuned on a tuning set: weights/README.md) ->
# gimm-eval with the paper's protocol -> one pair's matches drawn -> the summary table.
#
#   scripts/main-job.sh [BUILD_DIR] [OUT_DIR]        (defaults: build, out)
set -euo pipefail
build=${1:-build}
out=${2:-out}
bin=$build/examples
for tool in gimm-dataset gimm-match gimm-eval; do
  [ -x "$bin/$tool" ] || { echo "main-job: $bin/$tool is not built" >&2; exit 2; }
done
# 256 x 256 detector of 1 mm pixels: the images the shipped weights were trained on.
"$bin/gimm-dataset" --phantom 4 --style drr --rows 256 --cols 256 --pixel 1.0 --out "$out/dataset"
"$bin/gimm-match" --dataset "$out/dataset" --out "$out/matches"
"$bin/gimm-eval" --dataset "$out/dataset" --predictions "$out/matches" --out "$out/eval" \
  --name "GIMM (shipped weights, exact F)" > /dev/null
views=$out/dataset/patients/phantom-0000/views
"$bin/gimm-match" --image-a "$views/LCA_00.png" --image-b "$views/LCA_03.png" \
  --class-a "$(sed -n 's/.*"view_class": *\([0-9]*\).*/\1/p' "$views/LCA_00.camera.json")" \
  --class-b "$(sed -n 's/.*"view_class": *\([0-9]*\).*/\1/p' "$views/LCA_03.camera.json")" \
  --camera-a "$views/LCA_00.camera.json" --camera-b "$views/LCA_03.camera.json" \
  --picture "$out/pair.png" > /dev/null
echo
sed -n '1,5p' "$out/eval/table.md"
echo
echo "main-job: dataset $out/dataset, matches $out/matches, scores $out/eval, picture $out/pair.png"
