#!/usr/bin/env python3
"""Where matchers fail as the two views come together: every pair of a gimm dataset binned by the
angle between its two cameras' viewing directions, each method's matches pooled per bin.

    tools/atlas/separation_sweep.py DATASET OUT NAME=EVAL_DIR [NAME=EVAL_DIR ...]

EVAL_DIR: a gimm-eval --out folder made with --worst at least the number of pairs (atlas.sh does
this), so that its summary.json lists every pair. Writes OUT.md (a table per bin: pairs,
Prec@3px, 2D mean px, coverage for each method) and OUT.png (Prec@3px and 2D mean against the
separation, gnuplot). Pooling: Prec@3px and the 2D mean weighted by each pair's scored matches,
coverage = scored / slots, as gimm-eval pools.
"""
import json
import math
import os
import subprocess
import sys

EDGES = [0, 20, 40, 60, 80, 100, 180]  # degrees


def viewing_direction(dataset, patient, view):
    path = os.path.join(dataset, "patients", patient, "views", view + ".camera.json")
    with open(path) as f:
        R = json.load(f)["R"]
    return R[2]  # the camera's +z axis in patient coordinates: source to detector


def separation_deg(dataset, pair_id):
    patient, pair = pair_id.split("/")
    system, views = pair.split("_", 1)
    va, vb = (f"{system}_{v}" for v in views.split("-"))
    a, b = (viewing_direction(dataset, patient, v) for v in (va, vb))
    cos = sum(x * y for x, y in zip(a, b)) / math.sqrt(sum(x * x for x in a) *
                                                        sum(y * y for y in b))
    return math.degrees(math.acos(max(-1.0, min(1.0, cos))))


def bin_of(angle):
    for lo, hi in zip(EDGES, EDGES[1:]):
        if lo <= angle < hi:
            return lo, hi
    raise ValueError(f"separation {angle} deg outside {EDGES[0]}-{EDGES[-1]}")


def pooled(rows):
    scored = sum(r["scored"] for r in rows)
    slots = sum(r["slots"] for r in rows)

    def weighted(key):
        num = sum(r[key] * r["scored"] for r in rows if r["scored"] and r[key] is not None)
        return num / scored if scored else None
    return {"pairs": len(rows), "prec_3px": weighted("prec_3px"), "mean_px": weighted("mean_px"),
            "coverage": scored / slots if slots else None}


def main(argv):
    if len(argv) < 3 or any("=" not in spec for spec in argv[2:]):
        sys.exit(__doc__)
    dataset, out = argv[0], argv[1]
    methods = [spec.split("=", 1) for spec in argv[2:]]
    separations, table = {}, {}
    for name, folder in methods:
        path = os.path.join(folder, "summary.json")
        with open(path) as f:
            summary = json.load(f)
        rows = summary["worst_pairs"]
        total = summary["pooled"]["pairs"]
        if len(rows) < total:
            sys.exit(f"separation_sweep: {path} lists {len(rows)} of {total} pairs: run gimm-eval "
                     f"with --worst {total} or more")
        bins = {}
        for r in rows:
            if r["pair"] not in separations:
                separations[r["pair"]] = separation_deg(dataset, r["pair"])
            bins.setdefault(bin_of(separations[r["pair"]]), []).append(r)
        table[name] = {b: pooled(rs) for b, rs in bins.items()}
    used = sorted({b for per in table.values() for b in per})
    fmt = lambda v, d: "-" if v is None else f"{v:.{d}f}"  # noqa: E731
    lines = ["| separation (deg) | pairs | " + " | ".join(
        f"{n} Prec@3px | {n} 2D mean px | {n} coverage" for n, _ in methods) + " |",
        "| --- | --- |" + " --- | --- | --- |" * len(methods)]
    for b in used:
        pairs = max(table[n].get(b, {"pairs": 0})["pairs"] for n, _ in methods)
        cells = []
        for n, _ in methods:
            p = table[n].get(b, {"prec_3px": None, "mean_px": None, "coverage": None})
            cells += [fmt(p["prec_3px"], 3), fmt(p["mean_px"], 2), fmt(p["coverage"], 3)]
        lines.append(f"| {b[0]}-{b[1]} | {pairs} | " + " | ".join(cells) + " |")
    with open(out + ".md", "w") as f:
        f.write("\n".join(lines) + "\n")
    data = out + ".tsv"
    with open(data, "w") as f:
        f.write("centre\t" + "\t".join(f"{n}_prec3\t{n}_mean" for n, _ in methods) + "\n")
        for b in used:
            vals = []
            for n, _ in methods:
                p = table[n].get(b, {})
                vals += [fmt(p.get("prec_3px"), 4), fmt(p.get("mean_px"), 3)]
            f.write(f"{(b[0] + b[1]) / 2}\t" + "\t".join(vals) + "\n")
    plots = lambda col0: ", ".join(  # noqa: E731
        f"'{data}' using 1:{col0 + 2 * k} with linespoints title '{n}'"
        for k, (n, _) in enumerate(methods))
    script = f"""set terminal pngcairo size 1100,420 noenhanced
set output '{out}.png'
set datafile missing '-'
set multiplot layout 1,2 title 'Matchers against the angle between the two views ({dataset})'
set xlabel 'separation of the viewing directions (deg, bin centres)'
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
    print(f"separation_sweep: {out}.md, {out}.png ({len(separations)} pairs)")


if __name__ == "__main__":
    main(sys.argv[1:])
