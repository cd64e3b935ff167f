#!/usr/bin/env python3
"""Draws one pair of a gimm dataset with its labels: both angiograms side by side, the dense
labels as dots (colour = branch), the sparse labels joined across the pair, and the epipolar
lines of three sparse points of A in B.

Usage: draw_pair.py DATASET_DIR PATIENT PAIR_STEM OUT.png   (needs python3-opencv, numpy)
"""
import json
import os
import sys

import cv2
import numpy as np

root, patient, stem, out = sys.argv[1:5]
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
for row in dense[::12]:  # sparse enough that the vessels stay visible
    colour = palette[int(row[7]) % len(palette)]
    cv2.circle(canvas, (int(round(row[0])), int(round(row[1]))), 1, colour, -1)
    cv2.circle(canvas, (int(round(row[2])) + w, int(round(row[3]))), 1, colour, -1)
F = np.array(lab["F"])
for k, i in enumerate(lab["sparse"]):
    ua, va, ub, vb = dense[i][:4]
    cv2.line(canvas, (int(ua), int(va)), (int(ub) + w, int(vb)), (255, 0, 255), 1, cv2.LINE_AA)
    cv2.circle(canvas, (int(ua), int(va)), 4, (0, 255, 0), 1, cv2.LINE_AA)
    cv2.circle(canvas, (int(ub) + w, int(vb)), 4, (0, 255, 0), 1, cv2.LINE_AA)
    if k < 3:  # epipolar line of this point of A, drawn in B: l = F x_a
        l = F @ np.array([ua, va, 1.0])
        p0 = (0, -l[2] / l[1]) if abs(l[1]) > 1e-12 else (-l[2] / l[0], 0)
        p1 = (w - 1, -(l[2] + l[0] * (w - 1)) / l[1]) if abs(l[1]) > 1e-12 else (p0[0], w - 1)
        cv2.line(canvas, (int(p0[0]) + w, int(p0[1])), (int(p1[0]) + w, int(p1[1])),
                 (0, 255, 255), 1, cv2.LINE_AA)
for x, text in [(8, f"A: {lab['view_a']} (class {lab['view_class_a']})"),
                (w + 8, f"B: {lab['view_b']} (class {lab['view_class_b']})")]:
    cv2.putText(canvas, text, (x, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.55, (255, 255, 255), 1,
                cv2.LINE_AA)
cv2.imwrite(out, canvas)
print(f"{out}: {len(dense)} dense labels, {len(lab['sparse'])} sparse")
