#!/usr/bin/env bash
# The matcher ablation on one split of a gimm dataset: the trained variants with each gating, and
# the baselines, scored by gimm-eval at K = 20, in one table (OUT/table.md) and one top-K chart.
#
#   tools/train/ablation.sh BUILD DATASET SPLIT OUT NAME=WEIGHTS [NAME=WEIGHTS ...]
#
# Rows per weights file: gating none, soft, logit, hard with F estimated from the matches (the
# reference's behaviour), hard with exact F from the cameras (2 px and 10 px), and hard 10 px
# with the B point snapped onto its epipolar line. Then oracle (sigma 1 px) and epipolar-nearest.
set -euo pipefail
build=$1 dataset=$2 split=$3 out=$4
shift 4
bin=$build/examples
mkdir -p "$out"
runs=()
run() {  # name, then gimm-match flags
  local name=$1
  shift
  local start=$(date +%s.%N)
  "$bin/gimm-match" --dataset "$dataset" --split "$split" --out "$out/pred/$name" "$@" \
    2> "$out/$name.match.log" > /dev/null
  local seconds=$(echo "$(date +%s.%N) - $start" | bc)
  "$bin/gimm-eval" --dataset "$dataset" --split "$split" --predictions "$out/pred/$name" \
    --out "$out/eval/$name" --name "$name" > /dev/null 2>&1
  echo "$name: $(tail -c 200 "$out/$name.match.log" | tr '\r' '\n' | grep -o '[0-9.]* s/pair' | tail -1) (wall ${seconds%.*} s)" >> "$out/times.txt"
  runs+=("$out/eval/$name")
  echo "ablation: $name done" >&2
}
: > "$out/times.txt"
for spec in "$@"; do
  name=${spec%%=*} weights=${spec#*=}
  run "$name-none" --weights "$weights" --gate none
  run "$name-soft" --weights "$weights" --gate soft
  run "$name-logit" --weights "$weights" --gate logit
  run "$name-hard-estimated" --weights "$weights" --gate hard --geometry matches
  run "$name-hard-exact" --weights "$weights" --gate hard
  run "$name-hard10-exact" --weights "$weights" --gate hard --delta 10
  run "$name-hard10-exact-snap" --weights "$weights" --gate hard --delta 10 --snap
done
run oracle-1px --method oracle --sigma 1
run epipolar-nearest --method epipolar
"$bin/gimm-eval" --compare "${runs[@]}" --out "$out/compare" > /dev/null
cp "$out/compare/compare.md" "$out/table.md"
cp "$out/compare/compare.png" "$out/topk.png"
echo "ablation: $out/table.md, $out/topk.png, $out/times.txt" >&2
