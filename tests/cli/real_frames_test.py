#!/usr/bin/env python3
"""Both matchers on real clinical frames (../shared/data/clinical-xa, when it is there): every
match lies inside the exposed field as an independent detector sees it (tools/realism's
half-rise rectangle: no match on the collimator frame), and the figures a reader wants are
printed: matches per pair, the share on vessels (tools/realism's segmentation, 2 px around) and,
ungated, the share within 5 px of the epipolar line of the pair's exported geometry. The table
is not recorded, so that geometry is tens of px off (docs/dicom.md): where a landmark could be
placed by eye (sample1's catheter tip at the left main ostium), B's camera is aligned to it
(gimm-match --landmark; the aligned camera recomputed here, independently, for the epipolar
share); sample2's stays as exported. Skips cleanly without ../shared. The images stay in
../shared: PNG copies go to TMP only.

Usage: real_frames_test.py BIN_DIR TMP_DIR [WEIGHTS]
(WEIGHTS: the learned matcher's weights to measure; default the shipped ones.)
"""
import json
import os
import shutil
import subprocess
import sys

import numpy as np
from PIL import Image

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.join(HERE, "..", "..")
sys.path.insert(0, os.path.join(ROOT, "tools", "realism"))
import realism  # noqa: E402
from harness import Harness  # noqa: E402

BIN, TMP = sys.argv[1], sys.argv[2]
WEIGHTS = ["--weights", sys.argv[3]] if len(sys.argv) > 3 else []
CLINICAL = os.path.normpath(os.path.join(ROOT, "..", "shared", "data", "clinical-xa"))
if not os.path.isdir(CLINICAL):
    print(f"skipped: {CLINICAL} is absent (the real frames live beside the project)")
    sys.exit(0)
shutil.rmtree(TMP, ignore_errors=True)
os.makedirs(TMP)
h = Harness(BIN)
check = h.check
T = lambda name: os.path.join(TMP, name)  # noqa: E731
# (folder A, frame A, folder B, frame B, LCA view classes from the angles)
PAIRS = [("sample1", "projection0", None, "projection1", None, 7, 9),
         ("sample2", "projection0", 20, "projection1", 20, 11, 9)]
# One point in both views, by eye (docs/dicom.md): A (u, v), B (u, v).
LANDMARKS = {"sample1": (130, 97, 183, 170)}


def view(sample, folder, frame, tag):
    """The frame as a PNG in TMP and its camera from the exported geometry (dicominfo.txt)."""
    src = os.path.join(CLINICAL, sample, folder)
    name = "frame.jpg" if frame is None else f"frame_{frame:02d}.jpg"
    grey = np.asarray(Image.open(os.path.join(src, name)).convert("L"))
    png = T(f"{sample}-{tag}.png")
    Image.fromarray(grey).save(png)
    info = open(os.path.join(src, "dicominfo.txt"), encoding="latin-1").read()
    num = lambda key: info.split(key + ":")[1].split()[0]  # noqa: E731
    camera = h.run("gimm-carm", "--primary", num("PositionerPrimaryAngle"), "--secondary",
                   num("PositionerSecondaryAngle"), "--sid", num("DistanceSourceToDetector"),
                   "--sod", num("DistanceSourceToPatient"), "--pixel", 0.308, "--rows",
                   grey.shape[0], "--cols", grey.shape[1]).stdout
    path = T(f"{sample}-{tag}.camera.json")
    open(path, "w").write(camera)
    return png, path, grey.astype(np.float64) / 255.0


def aligned_camera(path_a, path_b, landmark, out):
    """B's camera moved so that the landmark's two rays meet, the shortest way (the rays' common
    normal n, shift n (n . (C_A - C_B))): geometry/landmark_alignment.hpp's rule for one
    landmark, written again here."""
    cams = [json.load(open(p)) for p in (path_a, path_b)]
    K, R, t = ([np.array(c[k], float).reshape(3, -1) for c in cams] for k in ("K", "R", "t"))
    centre = [-R[i].T @ t[i][:, 0] for i in range(2)]
    ray = [R[i].T @ np.linalg.solve(K[i], [landmark[2 * i], landmark[2 * i + 1], 1.0])
           for i in range(2)]
    n = np.cross(ray[0], ray[1])
    n /= np.linalg.norm(n)
    shift = n * n.dot(centre[0] - centre[1])
    moved = dict(cams[1], t=list(t[1][:, 0] - R[1] @ shift))
    moved.pop("P", None)
    json.dump(moved, open(out, "w"))
    return out


def epipolar_px(F, a, b):
    l = np.hstack([a, np.ones((len(a), 1))]) @ F.T  # lines in B
    return np.abs(np.sum(l[:, :2] * b, 1) + l[:, 2]) / np.hypot(l[:, 0], l[:, 1])


for sample, fa, na, fb, nb, class_a, class_b in PAIRS:
    (png_a, cam_a, img_a), (png_b, cam_b, img_b) = (view(sample, fa, na, "a"),
                                                    view(sample, fb, nb, "b"))
    fields = [realism.rect_mask(img.shape, realism.exposed_field(img)[0]) for img in (img_a, img_b)]
    vessels = [np.asarray(realism.segment(img, f)) for img, f in zip((img_a, img_b), fields)]
    near_vessel = [realism.ndi.binary_dilation(v, iterations=2) for v in vessels]
    landmark = LANDMARKS.get(sample)
    aligned = aligned_camera(cam_a, cam_b, landmark, T(f"{sample}-b.aligned.json")) if landmark \
        else cam_b
    F = np.array(json.loads(h.run("gimm-carm", "--pair", cam_a, aligned).stdout)["F"])
    if landmark:
        a0, b0 = np.array([landmark[:2]], float), np.array([landmark[2:]], float)
        check(epipolar_px(F, a0, b0)[0] < 0.05,
              f"{sample}: the landmark is {epipolar_px(F, a0, b0)[0]:.2f} px off after aligning")
    marks = ["--landmark", *landmark] if landmark else []
    for method, extra in (("geometric", ["--tolerance", 5]),
                          ("learned", ["--gate", "none", "--class-a", class_a,
                                       "--class-b", class_b, *WEIGHTS])):
        out = T(f"{sample}.{method}.json")
        h.run("gimm-match", "--image-a", png_a, "--image-b", png_b, "--camera-a", cam_a,
              "--camera-b", cam_b, "--method", method, *extra, *marks, "--out", out)
        if not os.path.exists(out):
            continue
        m = json.load(open(out))
        a, b = np.array(m["points_a"]).reshape(-1, 2), np.array(m["points_b"]).reshape(-1, 2)
        inside = on_vessel = 0
        for pts, field, near in ((a, fields[0], near_vessel[0]), (b, fields[1], near_vessel[1])):
            rc = np.clip(np.rint(pts[:, ::-1]).astype(int), 0, np.array(field.shape) - 1)
            inside += int(field[rc[:, 0], rc[:, 1]].sum())
            on_vessel += int(near[rc[:, 0], rc[:, 1]].sum())
        n = len(a)
        check(inside == 2 * n, f"{sample} {method}: {2 * n - inside} match ends on the "
                               f"collimator frame (outside tools/realism's field)")
        near_line = float(np.mean(epipolar_px(F, a, b) <= 5)) if n else float("nan")
        print(f"{sample} {method}: {n} matches; ends on vessels {on_vessel / max(2 * n, 1):.2f}; "
              f"within 5 px of the epipolar line {near_line:.2f}"
              f"{' (B aligned to the landmark)' if landmark else ''}")
h.finish("real_frames")
