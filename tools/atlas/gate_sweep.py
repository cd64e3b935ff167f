#!/usr/bin/env python3
"""Choose the learned matcher's inference settings on a tuning dataset, then score them once on
the held-out one: coarse confidence threshold x hard epipolar gate (exact F, snap on).

    tools/atlas/gate_sweep.py BIN_DIR WEIGHTS TUNE_DATASET HELDOUT_DATASET OUT
                              [--thresholds 0.05 0.1 0.2 0.3] [--deltas 2 3 4 5 6 8 10]
                              [--min-coverage 0.55]

A tighter gate drops the matches far from their epipolar lines, which are the worst ones, so the
2D error falls, and so does coverage (fewer than K = 20 matches per pair are left). The rule:
among the settings whose coverage on TUNE_DATASET is >= --min-coverage, the one with the lowest
2D mean error. --min-coverage sits above the goal's 0.5 so that the choice keeps its coverage on
other patients. HELDOUT_DATASET is scored with the chosen setting only (and with the settings
the docs quote for comparison), never used to choose.

Writes OUT/sweep.tsv (every setting on the tuning set), OUT/chosen.json (the setting and its
heldout figures), OUT/gate_sweep.png (2D mean against coverage, one line per threshold, gnuplot)
and prints a progress line per run.
"""
import argparse
import json
import os
import subprocess
import sys


def run_setting(bin_dir, weights, dataset, out, threshold, delta):
    """Match and score one setting; returns gimm-eval's pooled summary."""
    name = f"t{threshold:g}-d{delta:g}"
    pred, ev = (os.path.join(out, dataset_name(dataset), kind, name) for kind in ("pred", "eval"))
    if not os.path.exists(os.path.join(ev, "summary.json")):
        subprocess.run([os.path.join(bin_dir, "gimm-match"), "--dataset", dataset, "--weights",
                        weights, "--gate", "hard", "--delta", str(delta), "--snap", "--threshold",
                        str(threshold), "--out", pred], check=True, capture_output=True)
        subprocess.run([os.path.join(bin_dir, "gimm-eval"), "--dataset", dataset, "--predictions",
                        pred, "--out", ev, "--name", name], check=True, capture_output=True)
    with open(os.path.join(ev, "summary.json")) as f:
        return json.load(f)["pooled"]


def dataset_name(dataset):
    return os.path.basename(os.path.normpath(dataset))


def choose(rows, min_coverage):
    """The row of lowest 2D mean among those with coverage >= min_coverage (None if none)."""
    eligible = [r for r in rows if r["coverage"] >= min_coverage]
    return min(eligible, key=lambda r: r["mean_px"]) if eligible else None


def chart(rows, thresholds, min_coverage, path):
    data = path + ".dat"
    with open(data, "w") as f:
        for t in thresholds:
            f.write(f"# threshold {t:g}\n")
            for r in sorted((r for r in rows if r["threshold"] == t), key=lambda r: r["delta"]):
                f.write(f"{r['coverage']:.4f} {r['mean_px']:.4f} {r['delta']:g}\n")
            f.write("\n\n")
    plots = ", ".join(
        f"'{data}' index {i} using 1:2 with linespoints title 'threshold {t:g}', "
        f"'{data}' index {i} using 1:2:3 with labels offset 0.8,0.6 font ',8' notitle"
        for i, t in enumerate(thresholds))
    script = f"""set terminal pngcairo size 820,520
set output '{path}'
set title 'Learned matcher, hard gate (exact F) + snap: each point one --delta (px, labelled)'
set xlabel 'coverage (K = 20)'
set ylabel '2D mean error (px)'
set grid
set arrow from {min_coverage},graph 0 to {min_coverage},graph 1 nohead dt 2
set key top left
plot {plots}
"""
    subprocess.run(["gnuplot"], input=script, text=True, check=True)
    os.remove(data)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("bin_dir")
    p.add_argument("weights")
    p.add_argument("tune")
    p.add_argument("heldout")
    p.add_argument("out")
    p.add_argument("--thresholds", type=float, nargs="+", default=[0.05, 0.1, 0.2, 0.3])
    p.add_argument("--deltas", type=float, nargs="+", default=[2, 3, 4, 5, 6, 8, 10])
    p.add_argument("--min-coverage", type=float, default=0.55)
    args = p.parse_args()
    for path in (args.tune, args.heldout):
        if not os.path.isfile(os.path.join(path, "manifest.json")):
            sys.exit(f"gate_sweep: {path} is not a gimm dataset (no manifest.json)")
    if dataset_name(args.tune) == dataset_name(args.heldout):
        sys.exit("gate_sweep: the tuning and held-out datasets need different folder names")
    os.makedirs(args.out, exist_ok=True)

    rows = []
    settings = [(t, d) for t in args.thresholds for d in args.deltas]
    for i, (t, d) in enumerate(settings, 1):
        s = run_setting(args.bin_dir, args.weights, args.tune, args.out, t, d)
        rows.append(dict(threshold=t, delta=d, prec_3px=s["prec_3px"], mean_px=s["mean_px"],
                         coverage=s["coverage"]))
        print(f"gate_sweep: {i}/{len(settings)} threshold {t:g} delta {d:g}: Prec@3px "
              f"{s['prec_3px']:.3f} 2D mean {s['mean_px']:.2f} px coverage {s['coverage']:.3f}",
              file=sys.stderr)
    with open(os.path.join(args.out, "sweep.tsv"), "w") as f:
        f.write("threshold\tdelta_px\tprec_3px\tmean_px\tcoverage\n")
        for r in rows:
            f.write(f"{r['threshold']:g}\t{r['delta']:g}\t{r['prec_3px']:.3f}\t"
                    f"{r['mean_px']:.3f}\t{r['coverage']:.3f}\n")
    chart(rows, args.thresholds, args.min_coverage, os.path.join(args.out, "gate_sweep.png"))

    best = choose(rows, args.min_coverage)
    if best is None:
        sys.exit(f"gate_sweep: no setting reaches coverage {args.min_coverage} on {args.tune}")
    held = run_setting(args.bin_dir, args.weights, args.heldout, args.out, best["threshold"],
                       best["delta"])
    chosen = {"weights": args.weights, "tune": args.tune, "heldout": args.heldout,
              "min_coverage": args.min_coverage, "threshold": best["threshold"],
              "delta_px": best["delta"], "tune_figures": best,
              "heldout_figures": {k: held[k] for k in ("prec_1px", "prec_3px", "prec_5px",
                                                       "mean_px", "mean_mm", "coverage")}}
    with open(os.path.join(args.out, "chosen.json"), "w") as f:
        json.dump(chosen, f, indent=1)
    print(json.dumps(chosen, indent=1))


if __name__ == "__main__":
    main()
