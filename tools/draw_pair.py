#!/usr/bin/env python3
"""Draws one pair of a gimm dataset: both angiograms side by side.

Without predictions: the dense labels as dots (colour = branch), the sparse labels joined
across the pair, and the epipolar lines in B of three sparse points of A.
With a predictions folder (gimm-matches/1, docs/evaluation.md): the paper's qualitative
figure - the top-K predicted matches in green joined by magenta lines, the ground truth of
each (the label nearest the predicted A point and its partner) in orange (A) and cyan (B),
and, with --epipolar, the exact epipolar line in B of each predicted A point.

Usage: draw_pair.py DATASET_DIR PATIENT PAIR_STEM OUT.png [PRED_DIR [TOP_K] [--epipolar]]
(needs python3-opencv, numpy)
"""
import json
import os
import sys

import cv2
import numpy as np

args = [a for a in sys.argv[1:] if a != "--epipolar"]
with_epipolar = "--epipolar" in sys.argv
root, patient, stem, out = args[:4]
pred_dir = args[4] if len(args) > 4 else None
top_k = int(args[5]) if len(args) > 5 else 20
pdir = os.path.join(root, "patients", patient)
lab = json.load(open(os.path.join(pdir, "pairs", stem + ".json")))


def load(view):
    img = cv2.imread(os.path.join(pdir, "views", view + ".png"), cv2.IMREAD_UNCHANGED)
    return cv2.cvtColor((img / 257).astype(np.uint8), cv2.COLOR_GRAY2BGR)


a, b = load(lab["view_a"]), load(lab["view_b"])
w = a.shape[1]
canvas = np.hstack([a, b])
dense = np.array(lab["dense"])
palette = [(255, 128, 0), (0, 200, 255), (80, 220, 80), (255, 0, 255), (0, 128, 255),
           (255, 255, 0), (128, 0, 255), (0, 255, 128)]
F = np.array(lab["F"])


def epipolar_line(ua, va, colour):
    """The line l = F x_a, drawn across B."""
    l = F @ np.array([ua, va, 1.0])
    if abs(l[1]) > 1e-12:
        p0, p1 = (0, -l[2] / l[1]), (w - 1, -(l[2] + l[0] * (w - 1)) / l[1])
    else:
        p0, p1 = (-l[2] / l[0], 0), (-l[2] / l[0], w - 1)
    cv2.line(canvas, (int(p0[0]) + w, int(p0[1])), (int(p1[0]) + w, int(p1[1])), colour, 1,
             cv2.LINE_AA)


if pred_dir:
    pred = json.load(open(os.path.join(pred_dir, patient, stem + ".json")))
    order = sorted(range(len(pred["confidence"])), key=lambda i: (-pred["confidence"][i], i))
    for i in order[:top_k]:
        (ua, va), (ub, vb) = pred["points_a"][i], pred["points_b"][i]
        nearest = dense[np.argmin(np.hypot(dense[:, 0] - ua, dense[:, 1] - va))]
        cv2.circle(canvas, (int(round(nearest[0])), int(round(nearest[1]))), 5, (0, 165, 255), 1,
                   cv2.LINE_AA)
        cv2.circle(canvas, (int(round(nearest[2])) + w, int(round(nearest[3]))), 5, (255, 255, 0),
                   1, cv2.LINE_AA)
        if with_epipolar:
            epipolar_line(ua, va, (0, 255, 255))
        cv2.line(canvas, (int(ua), int(va)), (int(ub) + w, int(vb)), (255, 0, 255), 1, cv2.LINE_AA)
        cv2.circle(canvas, (int(round(ua)), int(round(va))), 3, (0, 255, 0), -1, cv2.LINE_AA)
        cv2.circle(canvas, (int(round(ub)) + w, int(round(vb))), 3, (0, 255, 0), -1, cv2.LINE_AA)
for row in ([] if pred_dir else dense[::12]):  # sparse enough that the vessels stay visible
    colour = palette[int(row[7]) % len(palette)]
    cv2.circle(canvas, (int(round(row[0])), int(round(row[1]))), 1, colour, -1)
    cv2.circle(canvas, (int(round(row[2])) + w, int(round(row[3]))), 1, colour, -1)
for k, i in enumerate([] if pred_dir else lab["sparse"]):
    ua, va, ub, vb = dense[i][:4]
    cv2.line(canvas, (int(ua), int(va)), (int(ub) + w, int(vb)), (255, 0, 255), 1, cv2.LINE_AA)
    cv2.circle(canvas, (int(ua), int(va)), 4, (0, 255, 0), 1, cv2.LINE_AA)
    cv2.circle(canvas, (int(ub) + w, int(vb)), 4, (0, 255, 0), 1, cv2.LINE_AA)
    if k < 3:
        epipolar_line(ua, va, (0, 255, 255))
for x, text in [(8, f"A: {lab['view_a']} (class {lab['view_class_a']})"),
                (w + 8, f"B: {lab['view_b']} (class {lab['view_class_b']})")]:
    # On a dark box: the edges of an angiogram are often white (air), which hid white text.
    (tw, th), base = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, 0.55, 1)
    cv2.rectangle(canvas, (x - 4, 20 - th - 4), (x + tw + 4, 20 + base + 2), (0, 0, 0), -1)
    cv2.putText(canvas, text, (x, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.55, (255, 255, 255), 1,
                cv2.LINE_AA)
cv2.imwrite(out, canvas)
print(f"{out}: {len(dense)} dense labels, {len(lab['sparse'])} sparse"
      + (f", top {top_k} predictions from {pred_dir}" if pred_dir else ""))
