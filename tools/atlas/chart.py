#!/usr/bin/env python3
"""The atlas chart: time per pair (log x) against 2D mean error and against Prec@3px, one point
per method, from OUT/times.tsv and OUT/eval/<method>/summary.json; the paper's rows (Table 1,
their ImageCAS data, 512 px images) as reference lines. Writes OUT/time_vs_error.png (gnuplot)
and OUT/atlas.tsv.

Usage: chart.py OUT
"""
import json
import os
import subprocess
import sys

PAPER = [("paper GIMM", 4.738, 0.547), ("paper LoFTR", 5.394, 0.505)]  # 2D mean px, Prec@3px


def short_label(name):
    """The learned variants crowd one spot: label the best of them and the training-free rows."""
    learned = "-" in name and not name.startswith(("geometric", "oracle", "epipolar"))
    return name if not learned or name.endswith(("hard10-exact-snap", "hard-estimated")) else "."


def main(out):
    rows = []
    with open(os.path.join(out, "times.tsv")) as f:
        for line in f.read().splitlines()[1:]:
            name, seconds = line.split("\t")
            with open(os.path.join(out, "eval", name, "summary.json")) as s:
                pooled = json.load(s)["pooled"]
            rows.append((name, max(float(seconds), 1e-4), pooled["mean_px"], pooled["prec_3px"],
                         pooled["coverage"]))
    tsv = os.path.join(out, "atlas.tsv")
    with open(tsv, "w") as f:
        f.write("method\tseconds_per_pair\tmean_px\tprec_3px\tcoverage\tlabel\n")
        for r in rows:
            f.write("%s\t%.5f\t%.3f\t%.3f\t%.3f\t%s\n" % (*r, short_label(r[0])))
    png = os.path.join(out, "time_vs_error.png")
    lines = [f'set terminal pngcairo size 1200,520 font ",10"', f'set output "{png}.tmp"',
             "set multiplot layout 1,2", "set logscale x", "set grid",
             'set xlabel "time per pair, s (log; 2 cores, PNG reading included)"',
             "unset key", "set termoption noenhanced", "set datafile separator '\\t'"]
    for col, label, index in (("3", "2D mean error, px (lower is better)", 1),
                              ("4", "Prec@3px (higher is better)", 2)):
        lines.append(f'set ylabel "{label}"')
        lines.append("unset arrow; unset label")
        for k, (name, mean_px, prec) in enumerate(PAPER):
            y = mean_px if index == 1 else prec
            lines.append(f"set arrow from graph 0, first {y} to graph 1, first {y} nohead "
                         f"dashtype 2 lc rgb 'gray40'")
            lines.append(f'set label "{name} (their data, 512 px)" at graph 0.02, first {y} '
                         f"offset 0,0.6 tc rgb 'gray30' font ',8'")
        # Learned variants crowd one spot: label the trained model's rows only, dot the rest.
        lines.append(f"plot '{tsv}' every ::1 using 2:{col} with points pt 7 ps 1.3 lc rgb "
                     f"'#6a3d9a', '' every ::1 using 2:{col}:(strcol(6) eq '.' ? '' : strcol(6)) "
                     f"with labels offset 0,0.9 font ',8'")
    lines.append("unset multiplot")
    script = png + ".gp"
    with open(script, "w") as f:
        f.write("\n".join(lines) + "\n")
    subprocess.run(["gnuplot", script], check=True)
    os.replace(png + ".tmp", png)
    print(f"chart: {png}")


if __name__ == "__main__":
    main(sys.argv[1])
