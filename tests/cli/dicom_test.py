#!/usr/bin/env python3
"""The DICOM path end to end, as a user with two XA files would take it: gimm-drr renders two
phantom views as XA DICOM (B with the table moved), gimm-carm --dicom rebuilds each camera from
the tags alone (equal to the rendering camera to 1e-9, the table included), gimm-match
--dicom-a/b matches them with the view classes from the angles, writes the exact F into the
predictions, the epipolar picture and the triangulated points, and gimm-eval scores those points
against the phantom's centerlines. Bad files fail naming the file and leave nothing behind.

Usage: dicom_test.py BIN_DIR TMP_DIR
"""
import json
import os
import re
import shutil
import sys

from harness import Harness

BIN, TMP = sys.argv[1], sys.argv[2]
h = Harness(BIN)
run, check = h.run, h.check
shutil.rmtree(TMP, ignore_errors=True)
os.makedirs(TMP)
T = lambda name: os.path.join(TMP, name)

run("gimm-phantom", "--seed", 7, "--out", T("p"))
common = ["--volume", T("p/7.img.nii.gz"), "--label", T("p/7.label.nii.gz"), "--system", "LCA",
          "--pixel", 1.0, "--dicom", "--quiet"]
# Two sizes, as two runs of a real study may have.
run("gimm-drr", *common, "--rows", 256, "--cols", 224, "--primary", 45, "--secondary", 22,
    "--out", T("a"))
run("gimm-drr", *common, "--rows", 240, "--cols", 256, "--primary", -30, "--secondary", 22,
    "--table", 6, -12, 25, "--out", T("b"))
cam = {v: json.load(open(T(v + ".camera.json"))) for v in "ab"}
iso = cam["a"]["isocenter"]


def max_rel_diff(p, q):
    scale = max(abs(x) for row in q for x in row)
    return max(abs(x - y) for rp, rq in zip(p, q) for x, y in zip(rp, rq)) / scale


# The camera from the tags alone equals the rendering camera (B: its table relative to A's).
for view, extra in (("a", []), ("b", ["--reference", T("a.dcm")])):
    p = run("gimm-carm", "--dicom", T(view + ".dcm"), *extra, "--isocenter", *iso)
    if p.returncode == 0:
        got = json.loads(p.stdout)
        d = max_rel_diff(got["P"], cam[view]["P"])
        check(d < 1e-9, f"gimm-carm --dicom {view}.dcm: P differs from the rendering camera by {d}")
explain = run("gimm-carm", "--dicom", T("b.dcm"), "--explain").stdout
for needle in ("(0018,1510) PositionerPrimaryAngle = -30", "(300A,0129) TableTopLongitudinalPosition = 25",
               "(0018,1162) IntensifierSize = absent"):
    check(needle in explain, f"--explain lacks {needle!r}:\n{explain}")

# A file with no pitch at all (ImagerPixelSpacing removed by GDCM's gdcmanon): refused naming
# the library's option and the CLI's flag beside it; the flag then reads it.
nopitch = T("nopitch.dcm")
if shutil.which("gdcmanon"):
    run_anon = __import__("subprocess").run(["gdcmanon", "--dumb", "--remove", "0018,1164",
                                             T("a.dcm"), nopitch], capture_output=True)
    check(run_anon.returncode == 0 and os.path.exists(nopitch), f"gdcmanon: {run_anon.stderr}")
    run("gimm-carm", "--dicom", nopitch, ok=False,
        contains="give the detector pixel pitch: DicomReadOptions::pitch_mm (--pixel), in mm")
    run("gimm-carm", "--dicom", nopitch, "--pixel", 1.0)
    run("gimm-match", "--dicom-a", nopitch, "--dicom-b", T("b.dcm"), "--method", "geometric",
        "--out", T("nopitch.json"), ok=False, contains="(--pixel-a, --pixel-b)")
    check(not os.path.exists(T("nopitch.json")), "a refused pair left its --out")

# Matching from the DICOM files: classes from the angles, exact F written, tree, picture.
for method in ("geometric", "learned"):
    outs = {k: T(f"{method}.{k}") for k in ("json", "tree.json", "png")}
    # The learned matcher conditions on the view classes, so it needs the system; the
    # geometric one needs no classes and refuses --system.
    system = ["--system", "LCA"] if method == "learned" else []
    p = run("gimm-match", "--dicom-a", T("a.dcm"), "--dicom-b", T("b.dcm"), *system,
            "--isocenter", *iso, "--method", method, "--out", outs["json"], "--tree",
            outs["tree.json"], "--picture", outs["png"])
    if method == "learned":
        check("class 8 (LCA LAO Cranial" in p.stdout and "class 10 (LCA RAO Cranial" in p.stdout,
              f"{method}: view classes not chosen from the angles: {p.stdout}")
    # A phantom render has no collimator: its field is found in the image and keeps nearly
    # all of it (the phantom's sharp rectangular ribs at a border can cost a few per cent).
    fields = [int(f) for f in re.findall(r"field found in the image \((\d+)% of the image\)",
                                          p.stdout)]
    check(len(fields) == 2 and min(fields) >= 85, f"{method}: fields {fields}: {p.stdout}")
    check(all(os.path.exists(f) for f in outs.values()), f"{method}: an output is missing")
    if not os.path.exists(outs["json"]):
        continue
    m = json.load(open(outs["json"]))
    check(m.get("F_source") == "cameras", f"{method}: F_source is {m.get('F_source')}")
    F = run("gimm-carm", "--pair", T("a.camera.json"), T("b.camera.json")).stdout
    check(max_rel_diff(m["F"], json.loads(F)["F"]) < 1e-6, f"{method}: F differs from the cameras'")
    tree = json.load(open(outs["tree.json"]))
    if method == "learned":  # triangulated, each within the 5 px real-geometry limit
        check(len(tree["points"]) + tree["dropped_reprojection"] + tree["dropped_degenerate"] ==
              len(m["points_a"]), "learned: tree points + dropped != matches")
        check(all(max(q["reprojection_px"]) <= 5.0 for q in tree["points"]),
              "learned: a tree point reprojects further than 5 px")
    ev = run("gimm-eval", "--tree", outs["tree.json"], "--centerlines", T("p/7.centerlines.json"))
    last = ev.stdout.strip().splitlines()[-1] if ev.stdout.strip() else ""
    check(last.startswith(f"| pooled | {len(tree['points'])} |"), f"gimm-eval --tree: {last!r}")
    print(f"{method}: {len(m['points_a'])} matches; 3D error vs centerlines (mm): {last}")

# Bad input: named, nothing written.
with open(T("text.dcm"), "w") as f:
    f.write("not DICOM")
out = T("bad.json")
run("gimm-match", "--dicom-a", T("text.dcm"), "--dicom-b", T("b.dcm"), "--out", out, ok=False,
    contains="text.dcm: not a DICOM file")
run("gimm-match", "--dicom-a", T("a.dcm"), "--dicom-b", T("b.dcm"), "--frame-b", 3, "--out", out,
    ok=False, contains="frame 3 is out of range")
run("gimm-match", "--dicom-a", T("a.dcm"), "--dicom-b", T("b.dcm"), "--frame-a", -3, "--out", out,
    ok=False, contains="--frame-a: must be >= 0, got -3")
run("gimm-match", "--dicom-a", T("a.dcm"), "--dicom-b", T("b.dcm"), "--tree", T("bad.tree.json"),
    "--max-reprojection", -5, "--out", out, ok=False, contains="--max-reprojection: must be > 0, got -5")
run("gimm-match", "--dicom-a", T("a.dcm"), "--out", out, ok=False, contains="--dicom-b")
run("gimm-match", "--dicom-a", T("a.dcm"), "--dicom-b", T("b.dcm"), "--image-a", T("a.png"),
    ok=False, contains="no --image-a/b")
run("gimm-carm", "--dicom", T("a.dcm"), "--primary", 10, ok=False, contains="--primary")
run("gimm-match", "--dicom-a", T("a.dcm"), "--dicom-b", T("b.dcm"), "--method", "geometric",
    "--system", "LCA", "--out", out, ok=False, contains="--system is for --method learned")
run("gimm-match", "--dicom-a", T("a.dcm"), "--dicom-b", T("b.dcm"), "--out", out, ok=False,
    contains="cannot be told from the angles")
run("gimm-match", "--dicom-a", T("a.dcm"), "--dicom-b", T("b.dcm"), "--pixel-a", 0,
    "--method", "geometric", "--out", out, ok=False, contains="--pixel-a: must be in [0.001, 10000], got 0")
# One view's geometry given by hand: B's camera JSON replaces B's tags, A keeps its file's.
p = run("gimm-match", "--dicom-a", T("a.dcm"), "--dicom-b", T("b.dcm"), "--method", "geometric",
        "--isocenter", *iso, "--camera-b", T("b.camera.json"), "--table-a", 0, 0, 0)
check("camera given" in p.stdout and "replaced by (0 0 0)" in p.stdout,
      f"per-view corrections not reported: {p.stdout}")
check(not os.path.exists(out), "a failed gimm-match left its output behind")
h.finish("cli_dicom")
