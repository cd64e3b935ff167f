#!/usr/bin/env python3
"""What the learned matcher's network sees, real frames beside synthetic views: each image at
the network's size (--size), as intensities and as the vessel-enhanced input
(gimm.network_image, include/gimm/match/network_input.hpp), one row per image.

    PYTHONPATH=build/python network_input_picture.py --out P.png --size 256 \\
        ../shared/data/clinical-xa/sample2/projection0/frame_20.jpg D/patients/phantom-0000/views/LCA_00.formed.png
"""
import argparse
import os
import sys

import numpy as np
from PIL import Image, ImageDraw

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import gimm  # noqa: E402
from gimm_data import read_png_unit, resize_for_network  # noqa: E402


def unit_image(path):
    if path.lower().endswith(".png"):
        return read_png_unit(path)
    return np.asarray(Image.open(path).convert("L")).astype(np.float32) / 255.0


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("images", nargs="+", help="frames (JPEG/PNG) or gimm views (16-bit PNG)")
    p.add_argument("--size", type=int, default=256, help="network input size, pixels")
    p.add_argument("--out", required=True)
    args = p.parse_args()
    rows = []
    for path in args.images:
        net = resize_for_network(unit_image(path), args.size)[0].numpy()
        row = np.hstack([net, gimm.network_image(net, "vesselness")])
        picture = Image.fromarray((np.clip(row, 0, 1) * 255).astype(np.uint8)).convert("RGB")
        label = os.path.join(*path.split(os.sep)[-3:])
        ImageDraw.Draw(picture).text((4, 4), label, fill=(255, 200, 0))
        ImageDraw.Draw(picture).text((net.shape[1] + 4, 4), "vesselness input", fill=(255, 80, 0))
        rows.append(np.asarray(picture))
    width = max(r.shape[1] for r in rows)
    rows = [np.pad(r, ((0, 0), (0, width - r.shape[1]), (0, 0))) for r in rows]
    Image.fromarray(np.vstack(rows)).save(args.out)
    print(f"network_input_picture: {len(rows)} images -> {args.out}")


if __name__ == "__main__":
    main()
