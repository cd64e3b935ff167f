#!/usr/bin/python3
"""Where matchers fail, pair by pair: every pair of a gimm dataset binned by one property of the
pair, each method's matches pooled per bin.

    tools/atlas/pair_sweep.py --by separation|crossings [--edges E0,E1,...] DATASET OUT
                              NAME=EVAL_DIR [...]

--by separation: the angle between the two cameras' viewing directions (deg).
--by crossings:  vessel overlap, the mean number of times an epipolar line crosses the other
                 view's vessel mask (separate runs of mask pixels along the line), over A's
                 vessel pixels (every 7th, their lines drawn in B) and B's (lines in A). 1 means
                 each point has one candidate on its line; 3 means two wrong ones beside it.

--edges: the bin edges, increasing (default: 0,20,40,60,80,100,180 degrees for separation;
         0,1.5,2,2.5,3,4,100 crossings), e.g. edges around the separations of a listed sweep.

EVAL_DIR: a gimm-eval --out folder made with --worst at least the number of pairs (atlas.sh does
this), so that its summary.json lists every pair. Writes OUT.md (a table per bin: pairs,
Prec@3px, 2D mean px, coverage for each method) and OUT.png (Prec@3px and 2D mean against the
bins, gnuplot). Pooling: Prec@3px and the 2D mean weighted by each pair's scored matches,
coverage = scored / slots, as gimm-eval pools. Needs numpy and PIL (Debian's python3).
"""
import argparse
import json
import math
import os
import subprocess
import sys

EDGES = {"separation": [0, 20, 40, 60, 80, 100, 180],  # degrees
         "crossings": [0, 1.5, 2, 2.5, 3, 4, 100]}        # crossings per epipolar line
UNITS = {"separation": "separation of the viewing directions (deg)",
         "crossings": "vessel crossings per epipolar line"}


def pair_views(pair_id):
    """'phantom-0003/LCA_00-04' -> ('phantom-0003', 'LCA_00', 'LCA_04')."""
    patient, pair = pair_id.split("/")
    system, views = pair.split("_", 1)
    va, vb = (f"{system}_{v}" for v in views.split("-"))
    return patient, va, vb


def viewing_direction(dataset, patient, view):
    path = os.path.join(dataset, "patients", patient, "views", view + ".camera.json")
    with open(path) as f:
        R = json.load(f)["R"]
    return R[2]  # the camera's +z axis in patient coordinates: source to detector


def separation_deg(dataset, pair_id):
    patient, va, vb = pair_views(pair_id)
    a, b = (viewing_direction(dataset, patient, v) for v in (va, vb))
    cos = sum(x * y for x, y in zip(a, b)) / math.sqrt(sum(x * x for x in a) *
                                                        sum(y * y for y in b))
    return math.degrees(math.acos(max(-1.0, min(1.0, cos))))


def line_crossings(lines, mask, step=0.5):
    """For each line (a, b, c) with a u + b v + c = 0 (pixels, centres at integers): how many
    separate runs of mask pixels it passes through inside the image, sampled every `step` px."""
    import numpy as np
    rows, cols = mask.shape
    length = math.hypot(rows, cols)
    t = np.arange(-length, length, step)
    counts = []
    for a, b, c in lines:
        n = math.hypot(a, b)
        if n == 0:
            counts.append(0)
            continue
        # The foot of the image centre on the line, then along the line's direction.
        cu, cv = (cols - 1) / 2, (rows - 1) / 2
        d = (a * cu + b * cv + c) / n
        u0, v0 = cu - d * a / n, cv - d * b / n
        u, v = np.rint(u0 - b / n * t).astype(int), np.rint(v0 + a / n * t).astype(int)
        inside = (u >= 0) & (u < cols) & (v >= 0) & (v < rows)
        on = np.zeros(t.shape, dtype=bool)
        on[inside] = mask[v[inside], u[inside]]
        counts.append(int(np.count_nonzero(on[1:] & ~on[:-1]) + on[0]))
    return counts


def crossings_per_line(dataset, pair_id, every=7):
    """Mean crossings of the epipolar lines of every `every`-th vessel pixel, both directions."""
    import numpy as np
    from PIL import Image
    patient, va, vb = pair_views(pair_id)
    folder = os.path.join(dataset, "patients", patient)
    with open(os.path.join(folder, "pairs", pair_id.split("/")[1] + ".json")) as f:
        F = np.array(json.load(f)["F"])
    masks = [np.array(Image.open(os.path.join(folder, "views", v + ".mask.png"))) > 0
             for v in (va, vb)]
    counts = []
    for src, dst, G in ((masks[0], masks[1], F), (masks[1], masks[0], F.T)):
        v, u = np.nonzero(src)
        pts = np.stack([u, v, np.ones_like(u)])[:, ::every].astype(float)
        counts += line_crossings((G @ pts).T, dst)
    return float(np.mean(counts)) if counts else 0.0


PAIR_VALUE = {"separation": separation_deg, "crossings": crossings_per_line}


def bin_of(value, edges):
    for lo, hi in zip(edges, edges[1:]):
        if lo <= value < hi:
            return lo, hi
    raise ValueError(f"{value} outside {edges[0]}-{edges[-1]}")


def pooled(rows):
    scored = sum(r["scored"] for r in rows)
    slots = sum(r["slots"] for r in rows)

    def weighted(key):
        num = sum(r[key] * r["scored"] for r in rows if r["scored"] and r[key] is not None)
        return num / scored if scored else None
    return {"pairs": len(rows), "prec_3px": weighted("prec_3px"), "mean_px": weighted("mean_px"),
            "coverage": scored / slots if slots else None}


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--by", choices=sorted(PAIR_VALUE), required=True)
    p.add_argument("--edges", help="bin edges, comma-separated, increasing")
    p.add_argument("dataset")
    p.add_argument("out")
    p.add_argument("methods", nargs="+", metavar="NAME=EVAL_DIR")
    args = p.parse_args()
    if any("=" not in spec for spec in args.methods):
        p.error("each method is NAME=EVAL_DIR")
    methods = [spec.split("=", 1) for spec in args.methods]
    edges, value_of = EDGES[args.by], PAIR_VALUE[args.by]
    if args.edges:
        try:
            edges = [float(e) for e in args.edges.split(",")]
        except ValueError:
            p.error(f"--edges must be comma-separated numbers, got '{args.edges}'")
        if len(edges) < 2 or any(b <= a for a, b in zip(edges, edges[1:])):
            p.error(f"--edges must be at least two increasing numbers, got '{args.edges}'")
    values, table = {}, {}
    for name, folder in methods:
        path = os.path.join(folder, "summary.json")
        with open(path) as f:
            summary = json.load(f)
        rows = summary["worst_pairs"]
        total = summary["pooled"]["pairs"]
        if len(rows) < total:
            sys.exit(f"pair_sweep: {path} lists {len(rows)} of {total} pairs: run gimm-eval "
                     f"with --worst {total} or more")
        bins = {}
        for r in rows:
            if r["pair"] not in values:
                values[r["pair"]] = value_of(args.dataset, r["pair"])
            try:
                b = bin_of(values[r["pair"]], edges)
            except ValueError as e:
                sys.exit(f"pair_sweep: pair {r['pair']}: {e} (--edges)")
            bins.setdefault(b, []).append(r)
        table[name] = {b: pooled(rs) for b, rs in bins.items()}
    used = sorted({b for per in table.values() for b in per})
    fmt = lambda v, d: "-" if v is None else f"{v:.{d}f}"  # noqa: E731
    lines = [f"| {args.by} | pairs | " + " | ".join(
        f"{n} Prec@3px | {n} 2D mean px | {n} coverage" for n, _ in methods) + " |",
        "| --- | --- |" + " --- | --- | --- |" * len(methods)]
    for b in used:
        pairs = max(table[n].get(b, {"pairs": 0})["pairs"] for n, _ in methods)
        cells = []
        for n, _ in methods:
            q = table[n].get(b, {"prec_3px": None, "mean_px": None, "coverage": None})
            cells += [fmt(q["prec_3px"], 3), fmt(q["mean_px"], 2), fmt(q["coverage"], 3)]
        lines.append(f"| {b[0]:g}-{b[1]:g} | {pairs} | " + " | ".join(cells) + " |")
    out = args.out
    with open(out + ".md", "w") as f:
        f.write("\n".join(lines) + "\n")
    data = out + ".tsv"
    with open(data, "w") as f:
        f.write("centre\t" + "\t".join(f"{n}_prec3\t{n}_mean" for n, _ in methods) + "\n")
        for b in used:
            vals = []
            for n, _ in methods:
                q = table[n].get(b, {})
                vals += [fmt(q.get("prec_3px"), 4), fmt(q.get("mean_px"), 3)]
            # The last bin is open-ended: place it one step past the one before.
            open_last = not args.edges and b[1] == edges[-1]
            centre = b[0] + (b[0] - edges[-3]) / 2 if open_last else (b[0] + b[1]) / 2
            f.write(f"{centre}\t" + "\t".join(vals) + "\n")
    plots = lambda col0: ", ".join(  # noqa: E731
        f"'{data}' using 1:{col0 + 2 * k} with linespoints title '{n}'"
        for k, (n, _) in enumerate(methods))
    script = f"""set terminal pngcairo size 1100,420 noenhanced
set output '{out}.png'
set datafile missing '-'
set multiplot layout 1,2 title 'Matchers against the {args.by} of the pairs ({args.dataset})'
set xlabel '{UNITS[args.by]} (bin centres)'
set key bottom right
set ylabel 'Prec@3px'
set yrange [0:1]
plot {plots(2)}
set ylabel '2D mean error (px)'
set autoscale y
set key top right
plot {plots(3)}
unset multiplot
"""
    subprocess.run(["gnuplot"], input=script, text=True, check=True)
    os.remove(data)
    print(f"pair_sweep: {out}.md, {out}.png ({len(values)} pairs)")


if __name__ == "__main__":
    main()
