#!/usr/bin/env bash
# Regenerates the pictures of docs/ that come from a few commands on the built-in phantom (the
# rest come from long runs and name their own command beside them: training films, sweeps,
# side-by-side charts). Writes into docs/images/ unless OUT is given.
#   tools/doc_pictures.sh [BUILD_DIR] [OUT_DIR]
# Needs python3-opencv and numpy (scripts/install-deps.sh bench). Made here:
#   pair_labels.png       a pair of the seed-1 ImageCAS-size phantom with its labels (dataset.md)
#   matches_epipolar.png  the epipolar-nearest baseline on that pair, epipolar lines drawn
#                         (evaluation.md)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
out=${2:-$root/docs/images}
bin=$build/examples
for tool in gimm-phantom gimm-dataset gimm-baseline; do
  [ -x "$bin/$tool" ] || { echo "error: $bin/$tool not built" >&2; exit 1; }
done
/usr/bin/python3 -c "import cv2, numpy" 2>/dev/null ||
  { echo "error: python3-opencv/numpy missing: scripts/install-deps.sh bench" >&2; exit 1; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$out"
"$bin/gimm-phantom" --seed 1 --size imagecas --out "$work/icas" >/dev/null
"$bin/gimm-dataset" --input "$work/icas" --out "$work/ds" --quiet >/dev/null 2>&1
pair=LCA_03-05
/usr/bin/python3 "$root/tools/draw_pair.py" "$work/ds" 1 "$pair" "$out/pair_labels.png"
"$bin/gimm-baseline" --dataset "$work/ds" --method epipolar --out "$work/pred" >/dev/null
/usr/bin/python3 "$root/tools/draw_pair.py" "$work/ds" 1 "$pair" "$out/matches_epipolar.png" \
  "$work/pred" 20 --epipolar
# The captions name the pair's angles: print them for the docs.
for v in $(/usr/bin/python3 -c "import json; p = json.load(open('$work/ds/patients/1/pairs/$pair.json')); print(p['view_a'], p['view_b'])"); do
  /usr/bin/python3 -c "import json; c = json.load(open('$work/ds/patients/1/views/$v.camera.json')); print('$v', c['view_name'], 'primary', round(c['primary_deg'], 1), 'secondary', round(c['secondary_deg'], 1))"
done
echo "doc_pictures: $out/pair_labels.png $out/matches_epipolar.png"
