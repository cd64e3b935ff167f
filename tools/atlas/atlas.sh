#!/usr/bin/env bash
# The matcher atlas on one split of a gimm dataset: every matcher and gating variant, scored by
# gimm-eval at K = 20, in one table (OUT/table.md), one top-K chart (OUT/topk.png) and one chart
# of time per pair against error (OUT/time_vs_error.png, tools/atlas/chart.py).
#
#   tools/atlas/atlas.sh BUILD DATASET SPLIT OUT [NAME=WEIGHTS ...]
#
# Rows per weights file (the learned matcher): gating none, soft, logit, hard with F estimated
# from the matches (the reference's behaviour), hard with exact F from the cameras (2 px and
# 10 px), and hard 4 px (the shipped weights' recorded gate) and 10 px with the B point snapped
# onto its epipolar line. Then the
# training-free rows: geometric (dataset masks; segmented from the images), epipolar-nearest,
# oracle (sigma 1 and 2 px). Time per pair = wall time of gimm-match / pairs (PNG reading
# included), one process on whatever else the machine runs: compare rows of one run only.
set -euo pipefail
build=$1 dataset=$2 split=$3 out=$4
shift 4
bin=$build/examples
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$out"
runs=()
run() {  # name, then gimm-match flags
  local name=$1
  shift
  local start end
  start=$(date +%s.%N)
  "$bin/gimm-match" --dataset "$dataset" --split "$split" --out "$out/pred/$name" "$@" \
    2> "$out/$name.match.log" > "$out/$name.match.out"
  end=$(date +%s.%N)
  "$bin/gimm-eval" --dataset "$dataset" --split "$split" --predictions "$out/pred/$name" \
    --out "$out/eval/$name" --name "$name" --worst 1000000 > /dev/null 2>&1
  local pairs
  pairs=$(grep -o '^gimm-match: [0-9]* pairs' "$out/$name.match.out" | grep -o '[0-9]*')
  python3 -c "print('$name\t%.5f' % (($end - $start) / $pairs))" >> "$out/times.tsv"
  runs+=("$out/eval/$name")
  echo "atlas: $name done" >&2
}
printf 'method\tseconds_per_pair\n' > "$out/times.tsv"
for spec in "$@"; do
  name=${spec%%=*} weights=${spec#*=}
  # Every gate flag explicit: the weights record a default gate (the shipped ones: hard 4 px
  # + snap) that would otherwise fill in what a row leaves out.
  run "$name-none" --weights "$weights" --gate none --snap=false
  run "$name-soft" --weights "$weights" --gate soft --snap=false
  run "$name-logit" --weights "$weights" --gate logit --snap=false
  run "$name-hard-estimated" --weights "$weights" --gate hard --delta 2 --snap=false --geometry matches
  run "$name-hard-exact" --weights "$weights" --gate hard --delta 2 --snap=false
  run "$name-hard4-exact-snap" --weights "$weights" --gate hard --delta 4 --snap
  run "$name-hard10-exact" --weights "$weights" --gate hard --delta 10 --snap=false
  run "$name-hard10-exact-snap" --weights "$weights" --gate hard --delta 10 --snap
done
run geometric --method geometric
run geometric-segmented --method geometric --segment
run epipolar-nearest --method epipolar
run oracle-1px --method oracle --sigma 1
run oracle-2px --method oracle --sigma 2
"$bin/gimm-eval" --compare "${runs[@]}" --out "$out/compare" > /dev/null
cp "$out/compare/compare.md" "$out/table.md"
cp "$out/compare/compare.png" "$out/topk.png"
python3 "$here/chart.py" "$out"
echo "atlas: $out/table.md, $out/topk.png, $out/time_vs_error.png, $out/times.tsv" >&2
