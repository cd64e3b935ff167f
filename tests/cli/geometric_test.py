#!/usr/bin/env python3
"""gimm-match --method geometric end to end: on a small phantom dataset (3 patients, 256 px) it
beats epipolar-nearest on Prec@3px and 2D mean by the margins measured when it was written
(Prec@3px 0.93 vs 0.49, 2D mean 2.2 vs 7.2 px on 24 patients; here pinned with slack), and on
Prec@3px when it segments the images itself; one pair
from images and cameras alone writes matches, the triangulated tree (JSON, VTK) and a picture;
--landmark puts a camera moved off its place back onto the labels' epipolar lines; bad input
fails cleanly and leaves nothing behind.

Usage: geometric_test.py BIN_DIR TMP_DIR
"""
import json
import os
import shutil
import sys

import numpy as np

from harness import Harness

BIN, TMP = sys.argv[1], sys.argv[2]
h = Harness(BIN)
run, check = h.run, h.check
shutil.rmtree(TMP, ignore_errors=True)
os.makedirs(TMP)


def summary(method, *flags):
    name = "".join([method, *map(str, flags)])
    pred, ev = os.path.join(TMP, "pred-" + name), os.path.join(TMP, "eval-" + name)
    run("gimm-match", "--dataset", ds, "--method", method, *flags, "--out", pred)
    run("gimm-eval", "--dataset", ds, "--predictions", pred, "--out", ev)
    with open(os.path.join(ev, "summary.json")) as f:
        return json.load(f)["pooled"]


ds = os.path.join(TMP, "ds")
run("gimm-dataset", "--phantom", 3, "--style", "drr", "--seed", 5, "--rows", 256, "--cols", 256, "--pixel", 1.0,
    "--out", ds, "--quiet")
geo, epi = summary("geometric"), summary("epipolar")
print(f"geometric Prec@3px {geo['prec_3px']:.3f} 2D mean {geo['mean_px']:.2f} coverage "
      f"{geo['coverage']:.3f}; epipolar {epi['prec_3px']:.3f} {epi['mean_px']:.2f}")
check(geo["prec_3px"] >= epi["prec_3px"] + 0.25,
      f"geometric Prec@3px {geo['prec_3px']:.3f} not 0.25 above epipolar's {epi['prec_3px']:.3f}")
check(geo["mean_px"] <= epi["mean_px"] - 2.0,
      f"geometric 2D mean {geo['mean_px']:.2f} px not 2 px below epipolar's {epi['mean_px']:.2f}")
check(geo["coverage"] >= 0.8, f"geometric coverage {geo['coverage']:.3f} < 0.8")
# Without masks (segmenting the images): ahead of epipolar-nearest (which is given the masks) on
# Prec@3px; on 24 held-out patients 0.82 against 0.49, 2D mean 6.2 against 7.2 px; here (3
# patients) 0.70 against 0.50, 2D mean 9.7 against 8.0 px (three patients are too few for a
# mean whose tail is a few vessels matched to a rib edge, so the test pins Prec@3px).
seg = summary("geometric", "--segment")
print(f"geometric segmented Prec@3px {seg['prec_3px']:.3f} 2D mean {seg['mean_px']:.2f} "
      f"coverage {seg['coverage']:.3f}")
check(seg["prec_3px"] >= epi["prec_3px"] + 0.10,
      f"segmented Prec@3px {seg['prec_3px']:.3f} not 0.10 above epipolar's {epi['prec_3px']:.3f}")
check(seg["coverage"] >= 0.1, f"segmented coverage {seg['coverage']:.3f} < 0.1")

# --min-confidence: a stricter threshold (on the DP margin) keeps a subset of the matches,
# ranked with the same confidences.
strict = summary("geometric", "--min-confidence", 2)
pred_default = os.path.join(TMP, "pred-geometric")
pred_strict = os.path.join(TMP, "pred-geometric--min-confidence2")
kept = total = 0
for patient in sorted(os.listdir(pred_strict)):
    for name in sorted(os.listdir(os.path.join(pred_strict, patient))):
        with open(os.path.join(pred_strict, patient, name)) as f:
            m = json.load(f)
        with open(os.path.join(pred_default, patient, name)) as f:
            d = json.load(f)
        # (a junction pixel ends two chains, so one place can be matched twice)
        default = {(tuple(a), tuple(b), c) for a, b, c in
                   zip(d["points_a"], d["points_b"], d["confidence"])}
        for a, b, c in zip(m["points_a"], m["points_b"], m["confidence"]):
            check((tuple(a), tuple(b), c) in default,
                  f"--min-confidence 2: {name} has a match the default run does not: {a} {b} {c}")
        kept, total = kept + len(m["confidence"]), total + len(d["confidence"])
check(0 < kept < total, f"--min-confidence 2 kept {kept} of {total} matches")
check(strict["coverage"] < geo["coverage"], "--min-confidence 2 did not lower the coverage")

# Degraded images (--noise-photons, --blur-px): the matcher sees them, the truth does not; the
# same seed gives the same predictions.
segmented = {}
for name, flags in (("clean", []), ("noisy0", ["--noise-photons", 300, "--blur-px", 1.0]),
                    ("noisy1", ["--noise-photons", 300, "--blur-px", 1.0])):
    pred = os.path.join(TMP, "pred-segmented-" + name)
    run("gimm-match", "--dataset", ds, "--method", "geometric", "--segment",
        *flags, "--out", pred)
    with open(os.path.join(pred, "phantom-0000", "LCA_00-01.json")) as f:
        segmented[name] = json.load(f)
check(segmented["noisy0"] == segmented["noisy1"], "--noise-photons: two runs with one seed differ")
check(segmented["noisy0"]["points_a"] != segmented["clean"]["points_a"],
      "--noise-photons/--blur-px changed nothing the segmented matcher found")

# One pair from what a real user has: images and cameras (the matcher segments the vessels).
views = os.path.join(ds, "patients", "phantom-0000", "views")
A, B = os.path.join(views, "LCA_00.png"), os.path.join(views, "LCA_01.png")
CA, CB = os.path.join(views, "LCA_00.camera.json"), os.path.join(views, "LCA_01.camera.json")
outs = {k: os.path.join(TMP, "pair." + k) for k in ("json", "tree.json", "vtk", "png")}
pair = ["--method", "geometric", "--image-a", A, "--image-b", B, "--camera-a", CA, "--camera-b", CB]
p = run("gimm-match", *pair, "--out", outs["json"], "--tree", outs["tree.json"], "--tree-vtk",
        outs["vtk"], "--picture", outs["png"])
check(all(os.path.exists(f) for f in outs.values()), "single pair: an output is missing")
if os.path.exists(outs["tree.json"]):
    with open(outs["tree.json"]) as f:
        tree = json.load(f)
    with open(outs["json"]) as f:
        matches = json.load(f)
    check(tree["format"] == "gimm-tree/1" and len(tree["points"]) == len(matches["points_a"]),
          "tree.json: format or point count differs from the matches")
    check(all(len(q["world_mm"]) == 3 for q in tree["points"]), "tree.json: a point lacks world_mm")
if os.path.exists(outs["vtk"]):
    with open(outs["vtk"]) as f:
        vtk = f.read()
    check(vtk.startswith("# vtk DataFile") and "POLYDATA" in vtk and "LINES" in vtk,
          "tree.vtk is not VTK polydata with lines")

# --landmark: B's camera 8 mm off (an unrecorded table move) puts the pair's labels pixels off
# their epipolar lines under the F the matches carry; two landmarks from the labels put every
# label back on its line (F is the cameras' F, so this checks the camera gimm-match used).
with open(CB) as f:
    cam = json.load(f)
R, t = np.array(cam["R"]), np.array(cam["t"]).reshape(3)
across = np.cross(R[2], [0, 0, 1])
cam["t"] = list(t - R @ (8 * across / np.linalg.norm(across)))  # the source moved across B's axis
del cam["P"]
moved = os.path.join(TMP, "moved.camera.json")
with open(moved, "w") as f:
    json.dump(cam, f)
with open(os.path.join(ds, "patients", "phantom-0000", "pairs", "LCA_00-01.json")) as f:
    dense = np.array(json.load(f)["dense"])[:, :4]
marks = [float(v) for k in (0, len(dense) // 2) for v in dense[k]]


def label_distance(camera_b, *flags):
    """The pair's labels' worst distance in B from their epipolar lines under the written F."""
    out = os.path.join(TMP, "lm.json")
    p = run("gimm-match", *pair[:-2], "--camera-b", camera_b, *flags, "--out", out)
    with open(out) as f:
        F = np.array(json.load(f)["F"])
    lines = np.c_[dense[:, :2], np.ones(len(dense))] @ F.T
    d = np.abs(np.sum(lines * np.c_[dense[:, 2:], np.ones(len(dense))], 1)) / np.hypot(
        lines[:, 0], lines[:, 1])
    return d.max(), p.stdout


exact, _ = label_distance(CB)
off, _ = label_distance(moved)
aligned, said = label_distance(moved, "--landmark", *marks[:4], "--landmark", *marks[4:])
print(f"--landmark: labels at most {exact:.3f} px off their lines with the exact camera, "
      f"{off:.1f} px with B 8 mm off, {aligned:.3f} px aligned to two of them")
check(off > 10, f"--landmark: B 8 mm off leaves the labels only {off:.2f} px off")
check(aligned < 0.05, f"--landmark: aligned, the labels are {aligned:.3f} px off their lines")
check("B aligned to 2 landmarks" in said and said.count("-> 0.0 px") == 2,
      f"--landmark: report {said!r}")

# Bad input: clear message naming what is wrong, no output left behind.
other = os.path.join(TMP, "other.camera.json")
with open(CB) as f:
    cam = json.load(f)
cam["image_size"] = {"rows": 128, "cols": 128}
with open(other, "w") as f:
    json.dump(cam, f)
cases = [
    ("no cameras", ["--method", "geometric", "--image-a", A, "--image-b", B], "--camera-a"),
    ("camera size", [*pair[:-2], "--camera-b", other], "camera B is 128x128 px, image B 256x256"),
    ("tree without cameras", ["--image-a", A, "--image-b", B, "--tree",
                              os.path.join(TMP, "t.json")], "give --camera-a/b"),
    ("noise on one pair", [*pair, "--noise-photons", 100], "--noise-photons is for the dataset"),
    ("camera error on one pair", [*pair, "--camera-error-mm", 2], "--camera-error-mm is for"),
    ("noise for a matcher without images", ["--dataset", ds, "--method", "epipolar",
                                            "--blur-px", 1], "does not look at them"),
    ("photons below 1", ["--dataset", ds, "--noise-photons", 0.5], "got 0.5"),
    # Flags the chosen matcher would ignore are refused, naming the flag and its method.
    ("noise for the geometric matcher on masks", ["--dataset", ds, "--method", "geometric",
                                                  "--noise-photons", 300], "does not look at them"),
    ("exact vesselness on masks", ["--dataset", ds, "--method", "geometric",
                                   "--exact-vesselness"], "it needs --segment"),
    ("keep catheter on masks", ["--dataset", ds, "--method", "geometric", "--keep-catheter"],
     "--keep-catheter is about segmented chains"),
    ("keep catheter for the learned matcher", ["--dataset", ds, "--keep-catheter"],
     "--keep-catheter is for --method geometric, not learned"),
    ("segment for the learned matcher", ["--dataset", ds, "--segment"],
     "--segment is for --method geometric, not learned"),
    ("tolerance for the epipolar baseline", ["--dataset", ds, "--method", "epipolar",
                                             "--tolerance", 3], "--tolerance is for --method geometric"),
    ("gate for the geometric matcher", [*pair, "--delta", 5], "--delta is for --method learned"),
    ("ordering for the learned matcher", ["--dataset", ds, "--order-cost", 1],
     "--order-cost is for --method geometric, not learned"),
    ("tree prior for the learned matcher", ["--dataset", ds, "--junction-mm", 5],
     "--junction-mm is for --method geometric, not learned"),
    ("negative ordering cost", [*pair, "--order-cost", -1], "--order-cost: must be >= 0, got -1"),
    ("nan ordering cost", [*pair, "--order-cost", "nan"], "--order-cost: must be a finite number, got nan"),
    ("negative tree prior", [*pair, "--junction-mm", -1], "--junction-mm: must be >= 0, got -1"),
    ("nan tree prior", [*pair, "--junction-mm", "nan"], "--junction-mm: must be a finite number, got nan"),
    ("min confidence for the learned matcher", ["--dataset", ds, "--min-confidence", 1],
     "--min-confidence is for --method geometric, not learned"),
    ("negative min confidence", [*pair, "--min-confidence", -0.5],
     "--min-confidence: must be >= 0, got -0.5"),
    ("sigma for the learned matcher", ["--dataset", ds, "--sigma", 2], "--sigma is for --method oracle"),
    ("landmark of 3 numbers", [*pair, "--landmark", 1, 2, 3], "--landmark takes 4 numbers"),
    ("landmark without cameras", ["--image-a", A, "--image-b", B, "--landmark", 1, 2, 3, 4],
     "--landmark moves B's camera"),
    ("landmark off the detector", [*pair, "--landmark", 10, 10, 900, 10],
     "--landmark: landmark alignment: landmark 1"),
    ("landmark in dataset mode", ["--dataset", ds, "--landmark", 1, 2, 3, 4], "or --landmark"),
]
for name, args, needle in cases:
    out = os.path.join(TMP, f"bad_{name.replace(' ', '_')}.json")
    p = run("gimm-match", *args, "--out", out, ok=False)
    check(needle in p.stderr and p.stderr.startswith("error:"),
          f"{name}: message {p.stderr.strip()!r} lacks {needle!r}")
    # A camera that does not fit its image is a bad input (exit 1); the rest are usage errors.
    expected = 1 if name == "camera size" else 2
    check(p.returncode == expected, f"{name}: exit {p.returncode}, expected {expected}")
    check(not os.path.exists(out), f"{name}: an output file was left behind")

h.finish("geometric_test")
