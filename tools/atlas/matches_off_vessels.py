#!/usr/bin/python3
"""Where a matcher's A points land: on the labelled coronary tree, or off it (the catheter, a
rib, the background), and how the matcher ranked each kind.

    tools/atlas/matches_off_vessels.py DATASET PREDICTIONS [--radius 2]

A point is on the tree when the view's mask (<view>.mask.png), grown by --radius px, covers it.
gimm-eval scores every match against the nearest label; this says how many matches had no
label near them at all, and whether their confidence was lower (it should be). Prints one line
of totals and the confidence quartiles of both kinds.
"""
import argparse
import glob
import json
import os
import sys

import numpy as np
from PIL import Image
from scipy.ndimage import binary_dilation


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dataset")
    ap.add_argument("predictions")
    ap.add_argument("--radius", type=int, default=2, help="mask growth, px (default 2)")
    args = ap.parse_args()
    if args.radius < 0:
        sys.exit(f"error: --radius must be >= 0, got {args.radius}")
    files = sorted(glob.glob(os.path.join(args.predictions, "*", "*.json")))
    if not files:
        sys.exit(f"error: no <patient>/<pair>.json under {args.predictions}")
    on_conf, off_conf = [], []
    for path in files:
        patient, pair = path.split(os.sep)[-2], os.path.basename(path)[:-5]
        matches = json.load(open(path))
        points = np.asarray(matches.get("points_a", []), float).reshape(-1, 2)
        if len(points) == 0:
            continue
        view_a = pair.split("-")[0]
        mask_path = os.path.join(args.dataset, "patients", patient, "views", view_a + ".mask.png")
        mask = np.asarray(Image.open(mask_path)) > 0
        if args.radius:
            mask = binary_dilation(mask, iterations=args.radius)
        cols = np.clip(np.round(points[:, 0]).astype(int), 0, mask.shape[1] - 1)
        rows = np.clip(np.round(points[:, 1]).astype(int), 0, mask.shape[0] - 1)
        on = mask[rows, cols]
        confidence = np.asarray(matches["confidence"], float)
        on_conf += list(confidence[on])
        off_conf += list(confidence[~on])
    total = len(on_conf) + len(off_conf)
    print(f"{len(files)} pairs, {total} matches: {len(off_conf) / max(1, total):.3f} off the "
          f"labelled tree (mask grown by {args.radius} px)")
    for name, values in (("on the tree", on_conf), ("off the tree", off_conf)):
        if values:
            q = np.percentile(values, [25, 50, 75])
            print(f"confidence {name}: quartiles {q[0]:.3f} {q[1]:.3f} {q[2]:.3f}")


if __name__ == "__main__":
    main()
