#!/usr/bin/env bash
# Calibration error sweep: the cameras given to the matchers are off (gimm-match
# --camera-error-deg/-mm, geometry/camera_error.hpp; seed 0) while the images stay exact. Rows:
# the geometric matcher (dataset masks), the learned matcher with exact-F hard gating (2 and
# 10 px; 4 px + snap, the shipped weights' recorded gate) and, for reference, with F estimated
# from its matches (needs no cameras; at coarse threshold 0.05, since the reference's estimate
# needs 32 matches and the shipped threshold leaves about 16 per pair). Writes
# OUT/sweep.tsv (one line per matcher and error: Prec@3px, 2D mean, coverage) and prints it.
#
#   tools/atlas/calibration_sweep.sh BUILD DATASET SPLIT OUT WEIGHTS
set -euo pipefail
build=$1 dataset=$2 split=$3 out=$4 weights=$5
bin=$build/examples
mkdir -p "$out"
printf 'matcher\terror\tprec_3px\tmean_px\tcoverage\n' > "$out/sweep.tsv"
score() {  # matcher, error label, prediction dir
  "$bin/gimm-eval" --dataset "$dataset" --split "$split" --predictions "$3" --out "$3.eval" \
    > /dev/null 2>&1
  python3 -c "
import json; p = json.load(open('$3.eval/summary.json'))['pooled']
print('$1\t$2\t%.3f\t%.3f\t%.3f' % (p['prec_3px'], p['mean_px'], p['coverage']))" >> "$out/sweep.tsv"
}
match() {  # name, error label, then gimm-match flags
  local name=$1 label=$2
  shift 2
  local pred="$out/pred/$name-$label"
  "$bin/gimm-match" --dataset "$dataset" --split "$split" --out "$pred" "$@" > /dev/null 2>&1
  score "$name" "$label" "$pred"
}
for error in "0 0" "0.5 0" "1 0" "2 0" "3 0" "0 2" "0 5" "0 10"; do
  set -- $error
  label="${1}deg_${2}mm"
  flags=(--camera-error-deg "$1" --camera-error-mm "$2")
  match geometric "$label" --method geometric "${flags[@]}"
  match learned-hard2-exact "$label" --weights "$weights" --gate hard --delta 2 --snap=false \
    "${flags[@]}"
  match learned-hard4-snap "$label" --weights "$weights" --gate hard --delta 4 --snap "${flags[@]}"
  match learned-hard10-exact "$label" --weights "$weights" --gate hard --delta 10 --snap=false \
    "${flags[@]}"
  echo "sweep: $label done" >&2
done
match learned-t0.05-hard2-estimated any --weights "$weights" --threshold 0.05 --gate hard \
  --delta 2 --snap=false --geometry matches
column -t -s $'\t' "$out/sweep.tsv"
