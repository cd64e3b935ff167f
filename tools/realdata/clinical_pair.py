#!/usr/bin/env python3
"""One real clinical pair through gimm, as a user with two angiograms and their geometry would
take it: the two frames (JPEG/PNG, grey), the C-arm angles, SID, SOD and pitch read from each
view's `dicominfo.txt` (the export of ../shared/data/clinical-xa), the cameras built with
gimm-carm, the pair matched with gimm-match (picture with epipolar lines, matches, 3D tree).

    clinical_pair.py BUILD VIEW_A_DIR VIEW_B_DIR OUT [--frame-a F] [--frame-b F]
                     [--method geometric|learned] [--system LCA|RCA] [--tolerance PX]

VIEW_*_DIR holds dicominfo.txt and frame.jpg or frame_NN.jpg (--frame-a/b NN picks one of a run).
No table position is recorded for these views: both isocentres are taken as one. Writes
OUT/a.png, OUT/b.png, OUT/a.camera.json, OUT/b.camera.json, OUT/matches.json, OUT/pair.png,
OUT/tree.json, OUT/tree.vtk and prints gimm-match's report. Exit 2 on a usage error.
"""
import argparse
import os
import re
import subprocess
import sys

import numpy as np
from PIL import Image


def fail(message, code=1):
    print(f"clinical_pair.py: error: {message}", file=sys.stderr)
    sys.exit(code)


def read_info(folder):
    """The geometry fields of a MATLAB dicominfo dump: angles, SID, SOD, pitch."""
    path = os.path.join(folder, "dicominfo.txt")
    if not os.path.isfile(path):
        fail(f"{path}: no such file (each view folder needs its dicominfo.txt)", 2)
    text = open(path, encoding="latin-1").read()

    def number(name):
        m = re.search(rf"^\s*{name}:\s*([-+0-9.eE]+)\s*$", text, re.M)
        if not m:
            fail(f"{path}: no numeric '{name}'")
        return float(m.group(1))

    spacing = re.search(r"ImagerPixelSpacing:.*=\s*\[\s*([0-9.]+)\s*,\s*([0-9.]+)\s*\]", text)
    if not spacing:
        fail(f"{path}: no ImagerPixelSpacing")
    return {"primary": number("PositionerPrimaryAngle"),
            "secondary": number("PositionerSecondaryAngle"),
            "sid": number("DistanceSourceToDetector"), "sod": number("DistanceSourceToPatient"),
            "pitch": float(spacing.group(2))}


def frame_file(folder, frame):
    if frame is None:
        single = os.path.join(folder, "frame.jpg")
        if os.path.isfile(single):
            return single
        fail(f"{folder}: a run of frames: choose one with --frame-a/--frame-b", 2)
    path = os.path.join(folder, f"frame_{frame:02d}.jpg")
    if not os.path.isfile(path):
        fail(f"{path}: no such frame", 2)
    return path


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("build")
    ap.add_argument("view_a")
    ap.add_argument("view_b")
    ap.add_argument("out")
    ap.add_argument("--frame-a", type=int)
    ap.add_argument("--frame-b", type=int)
    ap.add_argument("--method", default="geometric", choices=["geometric", "learned"])
    ap.add_argument("--system", choices=["LCA", "RCA"])
    ap.add_argument("--tolerance", type=float, help="geometric: epipolar tolerance, px")
    ap.add_argument("--extra", default="", help="further gimm-match flags, one string")
    args = ap.parse_args()
    bin_dir = os.path.join(args.build, "examples")
    if not os.path.isfile(os.path.join(bin_dir, "gimm-match")):
        fail(f"{bin_dir}/gimm-match: not built", 2)
    os.makedirs(args.out, exist_ok=True)
    O = lambda name: os.path.join(args.out, name)
    for tag, folder, frame in (("a", args.view_a, args.frame_a), ("b", args.view_b, args.frame_b)):
        info = read_info(folder)
        grey = np.asarray(Image.open(frame_file(folder, frame)).convert("L"))
        Image.fromarray(grey).save(O(f"{tag}.png"))
        rows, cols = grey.shape
        camera = subprocess.run(
            [os.path.join(bin_dir, "gimm-carm"), "--primary", str(info["primary"]), "--secondary",
             str(info["secondary"]), "--sid", str(info["sid"]), "--sod", str(info["sod"]),
             "--pixel", str(info["pitch"]), "--rows", str(rows), "--cols", str(cols)],
            capture_output=True, text=True)
        if camera.returncode:
            fail(f"gimm-carm for view {tag}: {camera.stderr.strip()}")
        open(O(f"{tag}.camera.json"), "w").write(camera.stdout)
        print(f"view {tag}: {folder} frame {frame}: primary {info['primary']}, secondary "
              f"{info['secondary']}, SID {info['sid']}, SOD {info['sod']}, pitch {info['pitch']}")
    cmd = [os.path.join(bin_dir, "gimm-match"), "--image-a", O("a.png"), "--image-b", O("b.png"),
           "--camera-a", O("a.camera.json"), "--camera-b", O("b.camera.json"), "--method",
           args.method, "--out", O("matches.json"), "--picture", O("pair.png"), "--tree",
           O("tree.json"), "--tree-vtk", O("tree.vtk")]
    if args.tolerance is not None:
        cmd += ["--tolerance", str(args.tolerance)]
    if args.method == "learned":
        cmd += ["--gate", "none"]
    cmd += args.extra.split()
    p = subprocess.run(cmd, capture_output=True, text=True)
    sys.stdout.write(p.stdout)
    sys.stderr.write(p.stderr)
    sys.exit(p.returncode)


if __name__ == "__main__":
    main()
