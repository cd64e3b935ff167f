#!/usr/bin/env python3
"""Report of benchmarks/matcher/side_by_side.sh: a Markdown table, the agreement of the three
engines' matches, and a PNG of time per pair against input size (gnuplot).

    report.py RESULTS.jsonl DUMP_DIR OUT_DIR
"""
import json
import math
import os
import subprocess
import sys


def load_matches(path):
    with open(path) as f:
        m = json.load(f)
    return [tuple(p) + tuple(q) for p, q in zip(m.get("points0", []), m.get("points1", []))]


def paired_difference(ours, theirs):
    """(same matches?, max |point difference| px) of two engines' match lists, in any order.

    Each match is (xa, ya, xb, yb); a match of one engine is paired with the nearest of the
    other's (4D), and the lists agree when that pairing is one to one both ways. Sorting by the
    A point and comparing by index, as this did before, paired the wrong matches wherever two
    A points differed by a rounding error in x and by cells in y: hundreds of px "apart" for
    matches that were the same (the A point is refined, not a cell centre)."""
    if len(ours) != len(theirs):
        return False, math.inf
    if not ours:
        return True, 0.0
    import numpy as np
    from scipy.spatial import cKDTree
    a, b = np.asarray(ours, dtype=float), np.asarray(theirs, dtype=float)
    d_ab, to_b = cKDTree(b).query(a)
    _, to_a = cKDTree(a).query(b)
    one_to_one = len(set(to_b.tolist())) == len(b) and bool((to_a[to_b] == np.arange(len(a))).all())
    return one_to_one, float(np.abs(a - b[to_b]).max())


def agreement(dump, engine, size):
    """(same matches, max |point difference| px) of `engine` against gimm."""
    return paired_difference(load_matches(os.path.join(dump, f"gimm_{size}.json")),
                             load_matches(os.path.join(dump, f"{engine}_{size}.json")))


def main():
    results_path, dump, out = sys.argv[1:4]
    rows = [json.loads(line) for line in open(results_path) if line.strip()]
    by = {(r["engine"], r["size"]): r for r in rows}
    sizes = sorted({r["size"] for r in rows})
    lines = ["| input | engine | s / pair (median) | min | matches | peak RSS (MB) | vs gimm time | vs gimm memory | match agreement |",
             "|---|---|---|---|---|---|---|---|---|"]
    failures = []
    for s in sizes:
        g = by[("gimm", s)]
        for engine in ("gimm", "pytorch", "onnxruntime"):
            r = by.get((engine, s))
            if r is None:
                continue
            agree = "reference"
            if engine != "gimm":
                same, diff = agreement(dump, {"pytorch": "torch", "onnxruntime": "ort"}[engine], s)
                agree = f"same {r['matches']} matches, max diff {diff:.1e} px" if same else "DIFFERENT"
                if not same or diff > 1e-2:
                    failures.append(f"{engine} {s}: {agree}")
            lines.append(f"| {s}^2 | {engine} | {r['median_s']:.3f} | {r['min_s']:.3f} | {r['matches']} | "
                         f"{r['peak_rss_mb']:.0f} | {r['median_s'] / g['median_s']:.2f}x | "
                         f"{r['peak_rss_mb'] / g['peak_rss_mb']:.2f}x | {agree} |")
    table = "\n".join(lines)
    with open(os.path.join(out, "results.md"), "w") as f:
        f.write(table + "\n")
    print(table)
    tsv = os.path.join(out, "time_vs_size.tsv")
    with open(tsv, "w") as f:
        for s in sizes:
            f.write(f"{s} " + " ".join(f"{by[(e, s)]['median_s'] * 1e3:.1f}" for e in ("gimm", "pytorch", "onnxruntime")) + "\n")
    png = os.path.join(out, "matcher_time_vs_size.png")
    script = f"""set terminal png size 720,440 noenhanced
set output "{png}"
set title "GIMM matcher, one pair, 2 threads (same weights and matches)"
set xlabel "input size (px, square)"
set ylabel "time per pair (ms)"
set key top left
set grid
set xtics ({", ".join(str(s) for s in sizes)})
plot "{tsv}" using 1:2 with linespoints lw 2 title "gimm engine", \\
     "{tsv}" using 1:3 with linespoints lw 2 title "PyTorch 1.13 CPU", \\
     "{tsv}" using 1:4 with linespoints lw 2 title "ONNX Runtime CPU"
"""
    subprocess.run(["gnuplot"], input=script, text=True, check=True)
    print(f"chart: {png}")
    if failures:
        sys.exit("error: the engines disagree: " + "; ".join(failures))


if __name__ == "__main__":
    main()
