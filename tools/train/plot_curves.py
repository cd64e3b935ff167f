#!/usr/bin/env python3
"""Training curves of one run from its log.jsonl, drawn with gnuplot (no matplotlib needed):
the training loss (mean per window of steps) and the validation Prec@3px and coverage.

    /usr/bin/python3 tools/train/plot_curves.py RUN/log.jsonl OUT.png [--window 200]
"""
import argparse
import json
import os
import subprocess
import tempfile


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("log")
    parser.add_argument("png")
    parser.add_argument("--window", type=int, default=200, help="steps per loss window")
    args = parser.parse_args()
    train, val = {}, []
    with open(args.log) as f:
        for line in f:
            entry = json.loads(line)
            if "val" in entry:
                v = entry["val"]
                val.append((v["step"], v["prec_3px"], v["coverage"]))
            elif "loss" in entry:
                train.setdefault(entry["step"] // args.window, []).append(entry["loss"])
    if not train or not val:
        raise SystemExit(f"plot_curves: {args.log} has no training or no validation entries")
    with tempfile.TemporaryDirectory() as tmp:
        loss_tsv, val_tsv = os.path.join(tmp, "loss.tsv"), os.path.join(tmp, "val.tsv")
        with open(loss_tsv, "w") as f:
            for w in sorted(train):
                f.write(f"{(w + 0.5) * args.window}\t{sum(train[w]) / len(train[w])}\n")
        with open(val_tsv, "w") as f:
            for step, prec, cov in val:
                f.write(f"{step}\t{prec}\t{cov}\n")
        script = f"""set terminal png size 1100,420 noenhanced
set output "{args.png}.tmp.png"
set multiplot layout 1,2
set grid
set xlabel "step"
set ylabel "training loss (mean per {args.window} steps)"
plot "{loss_tsv}" using 1:2 with lines title "loss"
set ylabel "validation (150 pairs, no gating)"
set yrange [0:1]
set key bottom right
plot "{val_tsv}" using 1:2 with linespoints title "Prec@3px", "{val_tsv}" using 1:3 with linespoints title "coverage"
unset multiplot
"""
        subprocess.run(["gnuplot"], input=script, text=True, check=True)
    os.replace(args.png + ".tmp.png", args.png)
    print(f"plot_curves: {args.png} ({len(train)} loss windows, {len(val)} validations)")


if __name__ == "__main__":
    main()
