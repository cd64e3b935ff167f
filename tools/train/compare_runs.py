#!/usr/bin/env python3
"""Two training runs side by side from their log.jsonl files: the mean training loss terms per
window of steps, and each validation (Prec@3px, coverage, 2D mean) with the other run's
validation nearest in step. Markdown on stdout. Used for the FiLM ablation (docs/training.md).

    tools/train/compare_runs.py NAME_A=RUN_A/log.jsonl NAME_B=RUN_B/log.jsonl [--window 1000]
"""
import argparse
import json
import sys


def read_log(path):
    steps, vals = [], []
    with open(path) as f:
        for line in f:
            line = line.strip()
            if not line:
                continue
            try:
                entry = json.loads(line)
            except json.JSONDecodeError as e:
                sys.exit(f"error: compare_runs: {path}: not JSON lines ({e})")
            if "val" in entry:
                vals.append(entry["val"])
            elif "step" in entry and "loss" in entry:
                steps.append(entry)
    if not steps and not vals:
        sys.exit(f"error: compare_runs: {path}: no training step or validation in it")
    return steps, vals


def window_means(steps, window, last):
    rows = {}
    for e in steps:
        w = e["step"] // window
        if e["step"] > last:
            continue
        r = rows.setdefault(w, {"n": 0, "loss": 0.0})
        r["n"] += 1
        r["loss"] += e["loss"]
    return {w: r["loss"] / r["n"] for w, r in rows.items()}


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("runs", nargs=2, help="NAME=path/to/log.jsonl")
    p.add_argument("--window", type=int, default=1000, help="steps per loss window")
    p.add_argument("--max-gap", type=int, default=500,
                   help="pair validations at most this many steps apart")
    a = p.parse_args()
    if a.window <= 0:
        sys.exit(f"error: compare_runs: --window must be > 0, got {a.window}")
    runs = []
    for spec in a.runs:
        if "=" not in spec:
            sys.exit(f"error: compare_runs: '{spec}' is not NAME=LOG")
        name, path = spec.split("=", 1)
        runs.append((name, *read_log(path)))
    # Compare only the steps both runs reached.
    last = min(max((e["step"] for e in r[1]), default=0) for r in runs)
    (na, sa, va), (nb, sb, vb) = runs
    ma, mb = window_means(sa, a.window, last), window_means(sb, a.window, last)
    print(f"Training loss (mean of the logged steps), whole windows up to step {last}:\n")
    print(f"| steps | {na} | {nb} |\n| --- | --- | --- |")
    for w in sorted(w for w in set(ma) & set(mb) if (w + 1) * a.window <= last):
        print(f"| {w * a.window}-{(w + 1) * a.window - 1} | {ma[w]:.4f} | {mb[w]:.4f} |")
    print(f"\nValidations of {na}, each beside the {nb} validation nearest in step:\n")
    print(f"| step {na} | Prec@3px | coverage | 2D mean px | step {nb} | Prec@3px | coverage | "
          "2D mean px |\n| --- | --- | --- | --- | --- | --- | --- | --- |")
    for v in va:
        near = [x for x in vb if abs(x["step"] - v["step"]) <= a.max_gap]
        if not near:
            continue
        o = min(near, key=lambda x: abs(x["step"] - v["step"]))
        print(f"| {v['step']} | {v['prec_3px']:.3f} | {v['coverage']:.3f} | {v['mean_px']:.2f} | "
              f"{o['step']} | {o['prec_3px']:.3f} | {o['coverage']:.3f} | {o['mean_px']:.2f} |")


if __name__ == "__main__":
    main()
