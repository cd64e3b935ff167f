#!/usr/bin/env python3
"""gimm-baseline + gimm-eval end to end: the oracle at sigma 0 is perfect, noise lowers
Prec@1 as theory says, the epipolar baseline is scored, --compare joins runs, bad input fails.

Usage: eval_test.py BIN_DIR TMP_DIR
"""
import json
import os
import shutil
import sys

from harness import Harness

BIN, TMP = sys.argv[1], sys.argv[2]
h = Harness(BIN)
run, check = h.run, h.check


shutil.rmtree(TMP, ignore_errors=True)
ds = os.path.join(TMP, "ds")
run("gimm-dataset", "--phantom", 2, "--style", "drr", "--out", ds, "--rows", 128, "--cols", 128, "--pixel", 2,
    "--quiet")
pooled = {}
for name, extra in [("o0", ["--method", "oracle", "--sigma", 0]),
                    ("o2", ["--method", "oracle", "--sigma", 2]),
                    ("ep", ["--method", "epipolar"])]:
    run("gimm-baseline", "--dataset", ds, "--out", os.path.join(TMP, "p_" + name), *extra)
    run("gimm-eval", "--dataset", ds, "--predictions", os.path.join(TMP, "p_" + name), "--out",
        os.path.join(TMP, "e_" + name), "--name", name)
    summary = json.load(open(os.path.join(TMP, "e_" + name, "summary.json")))
    pooled[name] = summary.get("pooled", summary)
check(pooled["o0"]["prec_1px"] == 1.0 and pooled["o0"]["mean_mm"] == 0.0, f"oracle 0: {pooled['o0']}")
# sigma = 2 px per axis: P(error <= 1 px) = 1 - exp(-1/8) = 0.118 for the 2D error alone.
check(0.05 < pooled["o2"]["prec_1px"] < 0.3, f"oracle 2: Prec@1 {pooled['o2']['prec_1px']}")
check(pooled["ep"]["scored"] > 0 and pooled["ep"]["coverage"] > 0.5, f"epipolar: {pooled['ep']}")
check(all(os.path.getsize(os.path.join(TMP, "e_" + n, "topk.png")) > 1000 for n in pooled),
      "every run has its top-K chart")
p = run("gimm-eval", "--compare", *[os.path.join(TMP, "e_" + n) for n in ["o0", "o2", "ep"]],
        "--out", os.path.join(TMP, "cmp"))
check(all(n in p.stdout for n in ["o0", "o2", "ep"]), "compare table names every run")
check(os.path.getsize(os.path.join(TMP, "cmp", "compare.png")) > 1000, "compare chart")
p = run("gimm-eval", "--dataset", os.path.join(TMP, "nope"), "--predictions",
        os.path.join(TMP, "p_o0"), ok=False)
check("nope" in p.stderr, "missing dataset is named")
# Files of a dataset that parse but cannot be right are refused, naming the file: a mask of
# another size than its view, an F of zeros (both were scored: wrong pixels, null figures).
bad = os.path.join(TMP, "ds_bad")
shutil.rmtree(bad, ignore_errors=True)
shutil.copytree(ds, bad)
patient = sorted(os.listdir(os.path.join(bad, "patients")))[0]
pair_dir = os.path.join(bad, "patients", patient, "pairs")
first_pair = sorted(os.listdir(pair_dir))[0]
view_a = json.load(open(os.path.join(pair_dir, first_pair)))["view_a"]
mask = os.path.join(bad, "patients", patient, "views", view_a + ".mask.png")
shutil.copy(os.path.join(bad, "patients", patient, "views", view_a + ".mask.png"), mask + ".orig")
from PIL import Image  # noqa: E402
Image.new("L", (1, 1)).save(mask)
p = run("gimm-eval", "--dataset", bad, "--predictions", os.path.join(TMP, "p_o0"), ok=False,
        contains=view_a + ".mask.png' is 1 x 1 px, but")
run("gimm-baseline", "--dataset", bad, "--method", "oracle", "--out", os.path.join(TMP, "p_bad"),
    ok=False, contains="is 1 x 1 px")
shutil.move(mask + ".orig", mask)
labels = json.load(open(os.path.join(pair_dir, first_pair)))
labels["F"] = [[0, 0, 0]] * 3
json.dump(labels, open(os.path.join(pair_dir, first_pair), "w"))
run("gimm-eval", "--dataset", bad, "--predictions", os.path.join(TMP, "p_o0"), ok=False,
    contains="'F' is all zeros")

# Own truth: a dataset pair's matches scored against the truth of another pair are refused,
# naming both files; against their own pair's truth (named by "pair" or by the file's stem)
# they are scored.
preds = os.path.join(TMP, "p_o0")
patient = sorted(os.listdir(preds))[0]
first, second = sorted(f for f in os.listdir(os.path.join(preds, patient)))[:2]
matches = os.path.join(preds, patient, first)
own = os.path.join(TMP, first)  # named by its stem, as the matches' pair
json.dump({"points_a": [[10, 10]], "points_b": [[12, 14]]}, open(own, "w"))
run("gimm-eval", "--truth", own, "--matches", matches, "--out", os.path.join(TMP, "own_ok"))
other = os.path.join(TMP, "other.json")
json.dump({"pair": second[:-5], "points_a": [[10, 10]], "points_b": [[12, 14]]}, open(other, "w"))
run("gimm-eval", "--truth", other, "--matches", matches, "--out", os.path.join(TMP, "own_bad"),
    ok=False, contains=f"is the truth of pair '{second[:-5]}'")
check(not os.path.exists(os.path.join(TMP, "own_bad")), "a refused pairing left its --out")

h.finish("eval_test")
