"""The sweep scripts of tools/atlas/: the per-pair properties they bin by, the pooling, and the
choice rule of gate_sweep.py, on small hand-made inputs whose answers are known.

Run by ctest (atlas_tools); alone: atlas_tools_test.py TMP_DIR
"""
import json
import math
import os
import shutil
import subprocess
import sys

import numpy as np
from PIL import Image

HERE = os.path.dirname(os.path.abspath(__file__))
TOOLS = os.path.join(HERE, "..", "..", "tools", "atlas")
sys.path.insert(0, TOOLS)
import gate_sweep  # noqa: E402
import pair_sweep  # noqa: E402
import separation_views  # noqa: E402

TMP = sys.argv[1]
shutil.rmtree(TMP, ignore_errors=True)
os.makedirs(TMP)
failures = []


def check(cond, what):
    if not cond:
        failures.append(what)
        print("FAIL: " + what)


# --- line_crossings: three vertical bars, crossed by lines whose answers are known. -----------
mask = np.zeros((40, 60), dtype=bool)
for u0 in (10, 30, 50):
    mask[:, u0:u0 + 3] = True
mask[5:8, :] = False  # a gap in every bar at rows 5-7
horizontal = (0.0, 1.0, -20.0)      # v = 20: crosses the three bars
through_gap = (0.0, 1.0, -6.0)      # v = 6: inside the gap, crosses nothing
vertical_in_bar = (1.0, 0.0, -31.0)  # u = 31: along the middle bar, broken by the gap: 2 runs
vertical_between = (1.0, 0.0, -20.0)  # u = 20: between bars
outside = (0.0, 1.0, 100.0)         # v = -100: off the image
diagonal = (1.0, -1.0, 0.0)         # u = v: the first two bars (rows 10-12, 30-32)
got = pair_sweep.line_crossings([horizontal, through_gap, vertical_in_bar, vertical_between,
                                 outside, diagonal], mask)
check(got == [3, 0, 2, 0, 0, 2], f"line_crossings: got {got}, expected [3, 0, 2, 0, 0, 2]")
# A line given with another scale and sign is the same line.
got = pair_sweep.line_crossings([(0.0, -4.0, 80.0)], mask)
check(got == [3], f"line_crossings: a scaled line gave {got}, expected [3]")
# Rows and columns are not swapped: a line v = 31 (horizontal) crosses three bars, not one.
check(pair_sweep.line_crossings([(0.0, 1.0, -31.0)], mask) == [3],
      "line_crossings: rows and columns swapped")

# --- a one-pair dataset: crossings and separation from its files. ------------------------------
ds = os.path.join(TMP, "ds")
patient = os.path.join(ds, "patients", "p0")
for sub in ("views", "pairs"):
    os.makedirs(os.path.join(patient, sub))
Image.fromarray(mask.astype(np.uint8) * 255).save(os.path.join(patient, "views", "LCA_00.mask.png"))
Image.fromarray(mask.astype(np.uint8) * 255).save(os.path.join(patient, "views", "LCA_01.mask.png"))
# F of a pure horizontal translation: the epipolar line of (u, v) is the row v in the other view.
F = [[0, 0, 0], [0, 0, -1], [0, 1, 0]]
with open(os.path.join(patient, "pairs", "LCA_00-01.json"), "w") as f:
    json.dump({"F": F}, f)
angle = math.radians(30)
for view, R2 in (("LCA_00", [0, 0, 1]), ("LCA_01", [math.sin(angle), 0, math.cos(angle)])):
    with open(os.path.join(patient, "views", view + ".camera.json"), "w") as f:
        json.dump({"R": [[1, 0, 0], [0, 1, 0], R2]}, f)
# Every vessel pixel's line is its own row: 3 crossings, except rows 5-7 (none: no pixels there).
c = pair_sweep.crossings_per_line(ds, "p0/LCA_00-01", every=1)
check(abs(c - 3.0) < 1e-9, f"crossings_per_line: {c}, expected 3")
s = pair_sweep.separation_deg(ds, "p0/LCA_00-01")
check(abs(s - 30.0) < 1e-9, f"separation_deg: {s}, expected 30")

# --- pooling, as gimm-eval pools: weighted by scored matches, coverage = scored / slots. -------
rows = [{"scored": 30, "slots": 40, "prec_3px": 1.0, "mean_px": 1.0},
        {"scored": 10, "slots": 40, "prec_3px": 0.0, "mean_px": 9.0},
        {"scored": 0, "slots": 40, "prec_3px": None, "mean_px": None}]
p = pair_sweep.pooled(rows)
check(p["pairs"] == 3 and abs(p["prec_3px"] - 0.75) < 1e-12 and abs(p["mean_px"] - 3.0) < 1e-12
      and abs(p["coverage"] - 40 / 120) < 1e-12, f"pooled: {p}")

# --- the whole script on that dataset: one bin, the table, the chart. --------------------------
ev = os.path.join(TMP, "eval")
os.makedirs(ev)
with open(os.path.join(ev, "summary.json"), "w") as f:
    json.dump({"pooled": {"pairs": 1}, "worst_pairs": [
        {"pair": "p0/LCA_00-01", "scored": 20, "slots": 40, "prec_3px": 0.5, "mean_px": 4.0}]}, f)
out = os.path.join(TMP, "sweep")
proc = subprocess.run([sys.executable, os.path.join(TOOLS, "pair_sweep.py"), "--by", "crossings",
                       ds, out, "m=" + ev], capture_output=True, text=True)
check(proc.returncode == 0, f"pair_sweep.py failed: {proc.stderr[-500:]}")
if proc.returncode == 0:
    table = open(out + ".md").read()
    check("| 3-4 | 1 | 0.500 | 4.00 | 0.500 |" in table, f"pair_sweep table:\n{table}")
    check(os.path.getsize(out + ".png") > 1000, "pair_sweep: no chart")
# Bins of one's own: the pair's crossings (3-4 above) fall in 2.9-9; bad edges refused.
proc = subprocess.run([sys.executable, os.path.join(TOOLS, "pair_sweep.py"), "--by", "crossings",
                       "--edges", "0,2.9,9", ds, out, "m=" + ev], capture_output=True, text=True)
check(proc.returncode == 0 and "| 2.9-9 | 1 | 0.500 | 4.00 | 0.500 |" in open(out + ".md").read(),
      f"pair_sweep --edges: exit {proc.returncode}, {proc.stderr[-300:]!r}")
proc = subprocess.run([sys.executable, os.path.join(TOOLS, "pair_sweep.py"), "--by", "crossings",
                       "--edges", "0,1,2", ds, out, "m=" + ev], capture_output=True, text=True)
check(proc.returncode == 1 and "p0/LCA_00-01" in proc.stderr and "Traceback" not in proc.stderr,
      f"pair_sweep, a pair outside --edges: exit {proc.returncode}, {proc.stderr[-300:]!r}")
for edges in ["0,5,5", "10,0", "0,x"]:
    proc = subprocess.run([sys.executable, os.path.join(TOOLS, "pair_sweep.py"), "--by",
                           "crossings", "--edges", edges, ds, out, "m=" + ev],
                          capture_output=True, text=True)
    check(proc.returncode == 2 and f"'{edges}'" in proc.stderr,
          f"pair_sweep --edges {edges}: exit {proc.returncode}, {proc.stderr[-300:]!r}")
# An eval folder that lists fewer pairs than it scored is refused, naming the fix.
with open(os.path.join(ev, "summary.json"), "w") as f:
    json.dump({"pooled": {"pairs": 2}, "worst_pairs": []}, f)
proc = subprocess.run([sys.executable, os.path.join(TOOLS, "pair_sweep.py"), "--by", "separation",
                       ds, out, "m=" + ev], capture_output=True, text=True)
check(proc.returncode != 0 and "--worst 2" in proc.stderr,
      f"pair_sweep with a short pair list: exit {proc.returncode}, {proc.stderr[-300:]!r}")

# --- separation_views: each partner exactly SEP degrees from its base. ------------------------
# The direction model against two known poses: LAO 90 looks along the patient's x axis, and a
# cranial turn alone moves the direction by the turn.
check(np.allclose(np.abs(separation_views.direction(90, 0)), [1, 0, 0]), "LAO 90 direction")
check(abs(separation_views.angle_between((0, 0), (0, 30)) - 30) < 1e-9, "cranial 30 alone")
pairs = separation_views.sweep_pairs([5, 90])
check(len(pairs) == 22, f"separation_views: {len(pairs)} pairs for 11 classes x 2")
for q in pairs:
    a, b = q["a"], q["b"]
    sep = separation_views.angle_between((a["primary"], a["secondary"]),
                                         (b["primary"], b["secondary"]))
    check(min(abs(sep - 5), abs(sep - 90)) < 1e-4 and a["secondary"] == b["secondary"] and
          abs(b["primary"]) <= 180, f"separation_views pair {q}: {sep} deg")
views_out = os.path.join(TMP, "views.json")
proc = subprocess.run([sys.executable, os.path.join(TOOLS, "separation_views.py"), views_out,
                       "--separations", "5,0.5"], capture_output=True, text=True)
check(proc.returncode == 2 and "[0.5]" in proc.stderr and not os.path.exists(views_out),
      f"separation_views 0.5 deg: exit {proc.returncode}, {proc.stderr[-300:]!r}")
proc = subprocess.run([sys.executable, os.path.join(TOOLS, "separation_views.py"), views_out,
                       "--separations", "5,10,5"], capture_output=True, text=True)
check(proc.returncode == 2 and "twice" in proc.stderr and not os.path.exists(views_out),
      f"separation_views 5 twice: exit {proc.returncode}, {proc.stderr[-300:]!r}")

# --- gate_sweep's rule: lowest 2D mean among the settings with enough coverage. ----------------
settings = [dict(threshold=0.05, delta=2, mean_px=4.0, coverage=0.40),
            dict(threshold=0.05, delta=4, mean_px=4.7, coverage=0.60),
            dict(threshold=0.2, delta=4, mean_px=4.4, coverage=0.56),
            dict(threshold=0.2, delta=10, mean_px=5.2, coverage=0.70)]
best = gate_sweep.choose(settings, 0.55)
check(best is settings[2], f"gate_sweep.choose: {best}")
check(gate_sweep.choose(settings, 0.8) is None, "gate_sweep.choose: chose below the coverage")

# --- matches_off_vessels.py: 3 matches on a mask bar, 1 beside it (within the growth), 2 off. ---
off_ds = os.path.join(TMP, "off_ds")
os.makedirs(os.path.join(off_ds, "patients", "p0", "views"))
bar = np.zeros((40, 60), np.uint8)
bar[:, 20:23] = 255
Image.fromarray(bar).save(os.path.join(off_ds, "patients", "p0", "views", "LCA_00.mask.png"))
os.makedirs(os.path.join(TMP, "off_pred", "p0"))
json.dump({"points_a": [[21, 5], [20.4, 10], [22, 30], [24, 12], [40, 5], [5, 39]],
           "points_b": [[0, 0]] * 6, "confidence": [0.1, 0.2, 0.3, 0.4, 0.9, 0.7]},
          open(os.path.join(TMP, "off_pred", "p0", "LCA_00-01.json"), "w"))
off = subprocess.run([sys.executable, os.path.join(TOOLS, "matches_off_vessels.py"), off_ds,
                      os.path.join(TMP, "off_pred")], capture_output=True, text=True)
check(off.returncode == 0 and "6 matches: 0.333 off" in off.stdout
      and "off the tree: quartiles 0.750 0.800 0.850" in off.stdout,
      f"matches_off_vessels: {off.stdout} {off.stderr}")
off = subprocess.run([sys.executable, os.path.join(TOOLS, "matches_off_vessels.py"), off_ds,
                      os.path.join(TMP, "off_pred"), "--radius", "0"], capture_output=True, text=True)
check("6 matches: 0.500 off" in off.stdout, f"matches_off_vessels --radius 0: {off.stdout}")

print("\n".join("FAIL: " + f for f in failures) or "atlas_tools_test: all checks passed")
sys.exit(1 if failures else 0)
