#!/usr/bin/python3
"""F estimated from matches (the reference's behaviour: gimm.fundamental_from_matches, the 256
most confident matches, at least 32) against the number of matches and their outlier rate, on
the view pairs of a gimm dataset: how far the true correspondences lie from the estimated F's
epipolar lines.

    PYTHONPATH=build/python tools/atlas/f_from_matches.py DATASET OUT [--predictions PRED_DIR]
                           [--pairs 120] [--seed 0]

Two parts, both written to OUT.md (tables) and OUT.png (gnuplot):
1. Controlled: per pair, N of the pair's true labels (1 px Gaussian noise on both points) of
   which a fraction r has its B point replaced by a uniform random pixel; N in 8..256, r in
   0..0.5. Confidences are random, so the top-256 rule picks at random.
2. Matcher output (with --predictions, e.g. `gimm-match --gate none`): each pair's own matches,
   binned by their outlier rate (a match is an outlier when its symmetric epipolar distance
   under the true F exceeds 3 px) and by their count.

The error of one F: the median, over every dense label of the pair, of the symmetric epipolar
distance sqrt(d(x_b, F x_a)^2 + d(x_a, F^T x_b)^2) in px. A cell: the median over pairs, and
the share of pairs where F failed (fewer than 32 matches, or a degenerate fit) or its error
exceeds 5 px. Deterministic for a given --seed.
"""
import argparse
import json
import os
import subprocess
import sys

import numpy as np

try:
    import gimm
except ImportError:
    sys.exit("f_from_matches: cannot import gimm: build the Python module and set "
             "PYTHONPATH=build/python (docs/python.md)")

COUNTS = [8, 16, 32, 64, 128, 256]
OUTLIER_RATES = [0.0, 0.1, 0.25, 0.5]
BAD_PX = 5.0


def pair_files(dataset):
    with open(os.path.join(dataset, "manifest.json")) as f:
        manifest = json.load(f)
    out = []
    for p in manifest["patients"]:
        if p.get("status") != "ok":
            continue
        folder = os.path.join(dataset, "patients", p["id"], "pairs")
        out += [(p["id"], name[:-5], os.path.join(folder, name))
                for name in sorted(os.listdir(folder)) if name.endswith(".json")]
    return out


def read_pair(path):
    with open(path) as f:
        j = json.load(f)
    fields = j["dense_fields"]
    dense = np.array(j["dense"], dtype=float).reshape(-1, len(fields))
    col = {n: fields.index(n) for n in ("u_a", "v_a", "u_b", "v_b")}
    a = dense[:, [col["u_a"], col["v_a"]]]
    b = dense[:, [col["u_b"], col["v_b"]]]
    return np.array(j["F"], dtype=float), a, b


def f_error(F_est, a, b):
    """Median symmetric epipolar distance (px) of the true labels under F_est (inf if none)."""
    if F_est is None:
        return float("inf")
    d2 = gimm.symmetric_epipolar_distance_sq(F_est, a, b)
    return float(np.median(np.sqrt(d2)))


def estimate(pa, pb, conf):
    return gimm.fundamental_from_matches(pa, pb, conf, top_k=256, min_matches=32)


def cell(errors):
    e = np.array(errors)
    failed = float(np.mean(~np.isfinite(e) | (e > BAD_PX)))
    return (float(np.median(e)) if np.isfinite(np.median(e)) else float("inf")), failed, len(e)


def fmt(median, failed):
    m = "no F" if not np.isfinite(median) else f"{median:.2f}"
    return f"{m} ({failed:.0%})"


def controlled(pairs, rng, size):
    rows, cols = size
    table = {}
    for F_true, a, b in pairs:
        for n in COUNTS:
            if len(a) < n:
                continue
            pick = rng.choice(len(a), n, replace=False)
            for r in OUTLIER_RATES:
                pa = a[pick] + rng.normal(0, 1, (n, 2))
                pb = b[pick] + rng.normal(0, 1, (n, 2))
                k = int(round(r * n))
                pb[:k] = rng.uniform([0, 0], [cols - 1, rows - 1], (k, 2))
                conf = rng.uniform(0.2, 1.0, n)
                table.setdefault((n, r), []).append(f_error(estimate(pa, pb, conf), a, b))
    return table


def matcher_output(pred_dir, files, truths):
    rows = []
    for (patient, pair, _), (F_true, a, b) in zip(files, truths):
        path = os.path.join(pred_dir, patient, pair + ".json")
        if not os.path.exists(path):
            continue
        with open(path) as f:
            m = json.load(f)
        pa = np.array(m["points_a"], dtype=float).reshape(-1, 2)
        pb = np.array(m["points_b"], dtype=float).reshape(-1, 2)
        conf = np.array(m.get("confidence", [1.0] * len(pa)), dtype=float)
        if len(pa) == 0:
            rows.append((0, 1.0, float("inf")))
            continue
        d = np.sqrt(gimm.symmetric_epipolar_distance_sq(F_true, pa, pb))
        rows.append((len(pa), float(np.mean(d > 3.0)), f_error(estimate(pa, pb, conf), a, b)))
    return rows


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("dataset")
    p.add_argument("out")
    p.add_argument("--predictions")
    p.add_argument("--pairs", type=int, default=120, help="pairs of the controlled part")
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args()
    if not os.path.isfile(os.path.join(args.dataset, "manifest.json")):
        sys.exit(f"f_from_matches: {args.dataset} is not a gimm dataset (no manifest.json)")
    if args.pairs < 1:
        sys.exit(f"f_from_matches: --pairs must be >= 1, got {args.pairs}")
    files = pair_files(args.dataset)
    truths = [read_pair(path) for _, _, path in files]
    first_view = json.load(open(files[0][2]))["view_a"]
    with open(os.path.join(args.dataset, "patients", files[0][0], "views",
                           first_view + ".camera.json")) as f:
        size = json.load(f)["image_size"]
    rng = np.random.default_rng(args.seed)
    chosen = rng.choice(len(truths), min(args.pairs, len(truths)), replace=False)
    table = controlled([truths[i] for i in sorted(chosen)], rng, (size["rows"], size["cols"]))

    lines = [f"Controlled: {len(chosen)} pairs of {args.dataset}, seed {args.seed}. Cell: median "
             "over pairs of the true labels' median epipolar distance under the estimated F (px); "
             f"in brackets the share of pairs with no F or above {BAD_PX:g} px.", "",
             "| matches | " + " | ".join(f"{r:.0%} outliers" for r in OUTLIER_RATES) + " |",
             "| --- |" + " --- |" * len(OUTLIER_RATES)]
    data = args.out + ".dat"
    with open(data, "w") as f:
        for n in COUNTS:
            cells = [cell(table.get((n, r), [float("inf")])) for r in OUTLIER_RATES]
            lines.append(f"| {n} | " + " | ".join(fmt(c[0], c[1]) for c in cells) + " |")
            f.write(f"{n} " + " ".join(f"{c[1]:.4f}" for c in cells) + "\n")
    if args.predictions:
        rows = matcher_output(args.predictions, files, truths)
        lines += ["", f"Matcher output: {args.predictions}, {len(rows)} pairs, binned by outlier "
                  "rate (symmetric epipolar distance under the true F > 3 px).", "",
                  "| outlier rate | pairs | median matches | F error px (no F or > 5 px) |",
                  "| --- | --- | --- | --- |"]
        for lo, hi in ((0, 0.1), (0.1, 0.25), (0.25, 0.5), (0.5, 0.75), (0.75, 1.01)):
            sel = [r for r in rows if lo <= r[1] < hi]
            if sel:
                m, failed, _ = cell([r[2] for r in sel])
                lines.append(f"| {lo:.0%}-{min(hi, 1):.0%} | {len(sel)} | "
                             f"{int(np.median([r[0] for r in sel]))} | {fmt(m, failed)} |")
        lines += ["", "| matches | pairs | median outlier rate | F error px (no F or > 5 px) |",
                  "| --- | --- | --- | --- |"]
        for lo, hi in ((0, 32), (32, 64), (64, 128), (128, 256), (256, 10**9)):
            sel = [r for r in rows if lo <= r[0] < hi]
            if sel:
                m, failed, _ = cell([r[2] for r in sel])
                label = f"{lo}-{hi - 1}" if hi < 10**9 else f">= {lo}"
                lines.append(f"| {label} | {len(sel)} | {np.median([r[1] for r in sel]):.2f} | "
                             f"{fmt(m, failed)} |")
    with open(args.out + ".md", "w") as f:
        f.write("\n".join(lines) + "\n")
    plots = ", ".join(f"'{data}' using 1:{k + 2} with linespoints title '{r:.0%} outliers'"
                      for k, r in enumerate(OUTLIER_RATES))
    script = f"""set terminal pngcairo size 720,440 noenhanced
set output '{args.out}.png'
set title 'F from matches (reference rule): pairs where it fails or is off by > {BAD_PX:g} px'
set xlabel 'matches given (log scale)'
set ylabel 'share of pairs'
set logscale x 2
set yrange [0:1.05]
set key top right
set grid
plot {plots}
"""
    subprocess.run(["gnuplot"], input=script, text=True, check=True)
    os.remove(data)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
