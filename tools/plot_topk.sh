#!/usr/bin/env bash
# Top-K curves of gimm-eval runs in one PNG (gnuplot): 2D mean error (px) and Prec@3px
# against K (log scale), one line per run, from each run's topk.tsv.
#
#   tools/plot_topk.sh OUT.png RUN1 [RUN2 ...]      RUN = a `gimm-eval --out` directory
#
# The legend uses each run's method name (summary.json "method"), else the folder name.
set -euo pipefail
if [ $# -lt 2 ]; then
  echo "usage: tools/plot_topk.sh OUT.png RUN1 [RUN2 ...]" >&2
  exit 2
fi
command -v gnuplot >/dev/null || { echo "error: gnuplot is not installed (apt-get install gnuplot-nox)" >&2; exit 1; }
out=$1
shift
left="" right=""
for run in "$@"; do
  tsv="$run/topk.tsv"
  [ -f "$tsv" ] || { echo "error: '$run' has no topk.tsv (not a gimm-eval --out directory?)" >&2; exit 1; }
  name=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1])).get("method",""))' \
         "$run/summary.json" 2>/dev/null || true)
  [ -n "$name" ] || name=$(basename "$run")
  name=${name//\"/}
  left+="${left:+, }\"$tsv\" using 1:5 with linespoints title \"$name\""
  right+="${right:+, }\"$tsv\" using 1:3 with linespoints title \"$name\""
done
gnuplot <<GP
set terminal png size 1100,420 noenhanced
set output "$out"
set datafile missing "-"
set multiplot layout 1,2
set logscale x
set grid
set key top left
set xlabel "K (most confident matches per pair)"
set ylabel "2D mean error (px)"
plot $left
set ylabel "Prec@3px"
set yrange [0:1]
set key bottom left
plot $right
unset multiplot
GP
echo "tools/plot_topk.sh: wrote $out"
