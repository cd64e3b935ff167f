#!/usr/bin/env bash
# Where the image-reading matchers fail as the images degrade: dose (Poisson noise) and blur
# applied to the rendered angiograms the matcher sees (gimm-match --noise-photons/--blur-px,
# render/image_degradation.hpp), the truth untouched. Rows: clean, then each dose, then each
# blur; columns: the learned matcher (exact F, hard 4 px + snap) and the geometric matcher
# segmenting the images. The mask-based matchers (geometric with masks, epipolar-nearest,
# oracle) do not read the images and are not affected. Deterministic (seed 0).
#
#   tools/atlas/noise_sweep.sh BUILD DATASET SPLIT OUT WEIGHTS
#
# Writes OUT/table.md and OUT/eval/<method>-<setting>/ (gimm-eval folders).
set -euo pipefail
build=$1 dataset=$2 split=$3 out=$4 weights=$5
bin=$build/examples
mkdir -p "$out"
settings=("clean:" "photons-3000:--noise-photons 3000" "photons-1000:--noise-photons 1000"
          "photons-300:--noise-photons 300" "photons-100:--noise-photons 100"
          "blur-1px:--blur-px 1" "blur-2px:--blur-px 2")
for spec in "${settings[@]}"; do
  name=${spec%%:*} flags=${spec#*:}
  for method in gimm geometric-segmented; do
    case $method in
      gimm) mflags=(--weights "$weights" --gate hard --delta 4 --snap) ;;
      geometric-segmented) mflags=(--method geometric --segment) ;;
    esac
    # shellcheck disable=SC2086  # $flags holds zero or two words
    "$bin/gimm-match" --dataset "$dataset" --split "$split" "${mflags[@]}" $flags \
      --out "$out/pred/$method-$name" > /dev/null 2>&1
    "$bin/gimm-eval" --dataset "$dataset" --split "$split" --predictions "$out/pred/$method-$name" \
      --out "$out/eval/$method-$name" --name "$method-$name" > /dev/null 2>&1
    echo "noise_sweep: $method $name done" >&2
  done
done
python3 - "$out" "${settings[@]}" <<'PY'
import json, os, sys
out, settings = sys.argv[1], [s.split(":")[0] for s in sys.argv[2:]]
methods = ["gimm", "geometric-segmented"]
lines = ["| images | " + " | ".join(f"{m} Prec@3px | {m} 2D mean px | {m} coverage"
                                   for m in methods) + " |",
         "| --- |" + " --- | --- | --- |" * len(methods)]
for s in settings:
    cells = []
    for m in methods:
        with open(os.path.join(out, "eval", f"{m}-{s}", "summary.json")) as f:
            p = json.load(f)["pooled"]
        cells += [f"{p['prec_3px']:.3f}", f"{p['mean_px']:.2f}", f"{p['coverage']:.3f}"]
    lines.append(f"| {s} | " + " | ".join(cells) + " |")
with open(os.path.join(out, "table.md"), "w") as f:
    f.write("\n".join(lines) + "\n")
print("\n".join(lines))
PY
