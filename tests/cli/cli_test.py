#!/usr/bin/env python3
"""End-to-end checks of the example binaries: good runs, bad input, and NIfTI orientation
against nibabel (an independent reader and writer).

Usage: cli_test.py BIN_DIR TMP_DIR
"""
import json
import os
import shutil
import sys

import nibabel as nib
import numpy as np
from PIL import Image

from flag_contract import check_flags
from harness import Harness

BIN, TMP = sys.argv[1], sys.argv[2]
h = Harness(BIN)
check = h.check


def run(*args, ok=True, contains=None):
    return h.run(*args, ok=ok, contains=contains).stdout


shutil.rmtree(TMP, ignore_errors=True)
os.makedirs(TMP)

# Every CLI: --help, --version, usage errors (exit 2, one line), non-finite and negative numbers.
check_flags(check, BIN, TMP)

# gimm-carm: JSON fields, conventions, bad flags.
cam = json.loads(run("gimm-carm", "--primary", 30, "--secondary", 20))
for key in ["P", "K", "R", "t", "center", "image_size", "model", "primary_deg", "secondary_deg",
            "sid_mm", "sod_mm", "pixel_mm"]:
    check(key in cam, f"gimm-carm JSON lacks {key}")
check(cam["center"][0] < 0, "LAO 30 must put the source on the patient's right (x < 0)")
check(cam["center"][2] < 0, "cranial 20 must put the source towards the feet (z < 0)")
check(len(json.loads(run("gimm-carm", "--routine"))) == 11, "--routine prints 11 views")
run("gimm-carm", "--primary", 30, "--bogus", ok=False, contains="--bogus")
run("gimm-carm", "--primary", 30, "--secondary", 0, "--sid", -5, ok=False, contains="-5")
run("gimm-carm", "--primary", 30, "--secondary", 0, "--model", "fisheye", ok=False,
    contains="fisheye")

# gimm-phantom writes ImageCAS-form files that nibabel reads with the expected RAS affine.
ph = os.path.join(TMP, "ph")
run("gimm-phantom", "--seed", 3, "--out", ph)
img = nib.load(os.path.join(ph, "3.img.nii.gz"))
lab = nib.load(os.path.join(ph, "3.label.nii.gz"))
check(img.shape == (128, 128, 64), f"phantom shape {img.shape}")
check(img.get_data_dtype() == np.int16 and lab.get_data_dtype() == np.uint8, "phantom dtypes")
check(np.allclose(img.affine[:3, :3], np.diag([-1.6, -1.6, 2.0]), atol=1e-6),
      f"phantom affine (RAS) {img.affine}")
check(np.allclose(img.affine, img.get_qform(), atol=1e-4), "qform equals sform")
# Every centerline point (LPS mm) lands, through nibabel's affine, in a labelled voxel.
tree = json.load(open(os.path.join(ph, "3.centerlines.json")))
label = np.asarray(lab.dataobj)
inv = np.linalg.inv(lab.affine)
missed = total = 0
for br in tree["branches"]:
    for p in br["points"]:
        ras = np.array([-p[0], -p[1], p[2], 1.0])
        ijk = np.rint(inv @ ras)[:3].astype(int)
        total += 1
        missed += label[tuple(ijk)] != 1
check(total > 500 and missed == 0, f"{missed}/{total} centerline points outside the label")
check(set(np.unique(label)) == {0, 1}, "label values")

# gimm-drr: outputs, formats, and bad input that leaves nothing behind.
out = os.path.join(TMP, "drr_lao")
run("gimm-drr", "--volume", os.path.join(ph, "3.img.nii.gz"), "--label",
    os.path.join(ph, "3.label.nii.gz"), "--system", "LCA", "--primary", 45, "--secondary", 25,
    "--rows", 128, "--cols", 160, "--pixel", 1.5, "--out", out, "--quiet")
arr = np.load(out + ".npy")
check(arr.shape == (128, 160) and arr.dtype == np.float32, f"npy {arr.shape} {arr.dtype}")
png = open(out + ".png", "rb").read()
check(png[:8] == b"\x89PNG\r\n\x1a\n" and png[24] == 16, "16-bit PNG")
camj = json.load(open(out + ".camera.json"))
check(camj["image_size"] == [128, 160] or camj["image_size"] == {"rows": 128, "cols": 160}
      or camj["image_size"] == [160, 128], f"camera image_size {camj['image_size']}")
# The PNG's window is recorded (as the dataset's views record theirs): it maps the 16-bit values
# back to the intensity exp(-line integral) of the .npy.
win = camj.get("intensity_window", {})
value = np.asarray(Image.open(out + ".png"), dtype=np.float64)
back = win.get("min", 0) + (win.get("max", 0) - win.get("min", 0)) * value / 65535
worst = float(np.abs(back - np.exp(-arr.astype(np.float64))).max()) if win else float("inf")
check(worst <= (win.get("max", 1) - win.get("min", 0)) / 65535,
      f"gimm-drr intensity_window {win}: the PNG maps back to exp(-npy) within {worst}")

bad = os.path.join(TMP, "bad.nii.gz")
open(bad, "wb").write(open(os.path.join(ph, "3.img.nii.gz"), "rb").read()[:5000])
prefix = os.path.join(TMP, "never")
run("gimm-drr", "--volume", bad, "--primary", 0, "--secondary", 0, "--out", prefix, ok=False,
    contains="bad.nii.gz")
check(not any(f.startswith("never") for f in os.listdir(TMP)), "failed run left files behind")
run("gimm-drr", "--volume", os.path.join(ph, "3.img.nii.gz"), "--label",
    os.path.join(ph, "3.label.nii.gz"), "--primary", 0, "--secondary", 0, "--out", prefix,
    ok=False, contains="--system")
run("gimm-drr", "--volume", os.path.join(ph, "3.img.nii.gz"), "--primary", 0, "--secondary", 0,
    "--out", os.path.join(TMP, "no_dir", "x"), ok=False, contains="no_dir")
run("gimm-drr", "--volume", os.path.join(ph, "3.img.nii.gz"), "--primary", 0, "--secondary", 0,
    "--projector", "cone", "--out", prefix, ok=False, contains="cone")
other = np.zeros((10, 10, 10), np.uint8)
other[2:5, 2:5, 2:5] = 1
nib.save(nib.Nifti1Image(other, np.diag([-1.6, -1.6, 2.0, 1])), os.path.join(TMP, "small.nii.gz"))
run("gimm-drr", "--volume", os.path.join(ph, "3.img.nii.gz"), "--label",
    os.path.join(TMP, "small.nii.gz"), "--system", "LCA", "--primary", 0, "--secondary", 0,
    "--out", prefix, ok=False, contains="grid")
# Same dimensions, another spacing (and another origin): refused as gimm-dataset refuses it (one
# grid check); before, only the dimensions were compared and this rendered.
label_img = nib.load(os.path.join(ph, "3.label.nii.gz"))
for name, affine in [("spacing", label_img.affine @ np.diag([1.5, 1, 1, 1])),
                     ("origin", label_img.affine + np.array([[0, 0, 0, 7.0]] + [[0, 0, 0, 0]] * 3))]:
    shifted = os.path.join(TMP, f"label_{name}.nii.gz")
    nib.save(nib.Nifti1Image(np.asarray(label_img.dataobj).astype(np.uint8), affine), shifted)
    run("gimm-drr", "--volume", os.path.join(ph, "3.img.nii.gz"), "--label", shifted, "--system",
        "LCA", "--primary", 0, "--secondary", 0, "--out", prefix, ok=False,
        contains=f"grids disagree: {name}")
    check(not any(f.startswith("never") for f in os.listdir(TMP)), f"{name}: files left behind")

# Orientation against nibabel: a bright voxel written by nibabel (oblique, qform only, int16
# with scl_slope) appears in gimm's DRR where gimm's own camera matrix projects the point
# nibabel says it is at.
data = np.zeros((40, 36, 30), np.int16)
data[31, 7, 21] = 1000
theta = 0.4
rot = np.array([[np.cos(theta), -np.sin(theta), 0], [np.sin(theta), np.cos(theta), 0], [0, 0, 1]])
affine = np.eye(4)
affine[:3, :3] = rot @ np.diag([2.0, 2.5, 3.0])
affine[:3, 3] = [-30, 20, -40]
for form in ["qform", "sform"]:
    im = nib.Nifti1Image(data, None)
    if form == "qform":
        im.set_qform(affine, code=1)
        im.set_sform(None, code=0)
    else:
        im.set_sform(affine, code=2)
        im.set_qform(None, code=0)
    im.header.set_slope_inter(0.01, 0.0)  # stored 1000 -> 10 mm^-1 ... scaled on read
    path = os.path.join(TMP, f"marker_{form}.nii.gz")
    nib.save(im, path)
    world_ras = (affine @ np.array([31, 7, 21, 1.0]))[:3]
    world_lps = world_ras * np.array([-1, -1, 1])
    for primary, secondary in [(0, 0), (40, -25)]:
        o = os.path.join(TMP, f"marker_{form}_{primary}")
        run("gimm-drr", "--volume", path, "--recipe", "none", "--primary", primary,
            "--secondary", secondary, "--rows", 200, "--cols", 200, "--pixel", 1.0,
            "--isocenter", 0, 0, 0, "--out", o, "--quiet")
        img2 = np.load(o + ".npy")
        # The voxel's footprint spans several pixels: take its weighted centre.
        vs, us = np.nonzero(img2 > 0)
        w = img2[vs, us]
        v, u = (vs * w).sum() / w.sum(), (us * w).sum() / w.sum()
        P = np.array(json.load(open(o + ".camera.json"))["P"])
        x = P @ np.append(world_lps, 1.0)
        uv = x[:2] / x[2]
        check(abs(u - uv[0]) <= 0.3 and abs(v - uv[1]) <= 0.3,
              f"{form} marker at view ({primary},{secondary}): image max at (u={u}, v={v}), "
              f"camera projects it to {uv}")

# The reported crash (SIGSEGV in the exact traversal): a chest CT's grid stored RAS first,
# 0.9765625 x 0.9765625 x 2 mm, gimm-drr's defaults (AP, isocentre at the volume centre); rays
# leave through voxel edges on the grid's boundary. Every recipe, with and without padding.
slab = np.full((512, 512, 20), -1000, np.int16)
slab[:, 136:491, :] = 40
slab_affine = np.diag([-0.9765625, -0.9765625, 2.0, 1.0])
slab_affine[:3, 3] = [249.51171875, 437.51171875, -804.5]
slab_img = nib.Nifti1Image(slab, slab_affine)
slab_img.set_sform(slab_affine, code=1)
slab_img.set_qform(slab_affine, code=1)
slab_path = os.path.join(TMP, "slab.nii.gz")
nib.save(slab_img, slab_path)
for recipe in ["angiography", "reference"]:
    for pad in [0, 80]:
        o = os.path.join(TMP, f"slab_{recipe}_{pad}")
        run("gimm-drr", "--volume", slab_path, "--recipe", recipe, "--pad-mm", pad, "--primary", 0,
            "--secondary", 0, "--out", o, "--quiet")
        integrals = np.load(o + ".npy")
        check(np.isfinite(integrals).all() and integrals.max() > 0,
              f"slab DRR ({recipe}, pad {pad}) must be finite and see the slab")
# The same CT in HU read as attenuation (--recipe none): -1000 in air is refused, by name.
run("gimm-drr", "--volume", slab_path, "--recipe", "none", "--primary", 0, "--secondary", 0,
    "--out", os.path.join(TMP, "slab_none"), ok=False, contains="slab.nii.gz")
check(not os.path.exists(os.path.join(TMP, "slab_none.png")), "a refused volume writes nothing")

# A full disk (simulated: every file limited to some bytes, harness.run_on_full_disk), every CLI
# that writes files: it fails naming the file and the reason and leaves nothing of its own, and
# what its output place held before stays as it was. Limits sit between the sizes of the files
# a command writes where they differ (pair predictions, compare.md and its chart), so that some
# files are written before the failure. (gnuplot ignores the failed write and leaves a truncated
# chart: that counts as a failure too.)
disk = os.path.join(TMP, "full_disk")
os.makedirs(disk)
ds = os.path.join(disk, "ds")
run("gimm-dataset", "--phantom", 1, "--style", "drr", "--seed", 3, "--rows", 96, "--cols", 96, "--pixel", 2.5,
    "--quiet", "--out", ds)
pred, ev = os.path.join(disk, "pred"), os.path.join(disk, "eval")
run("gimm-baseline", "--dataset", ds, "--method", "oracle", "--sigma", 0, "--out", pred)
run("gimm-eval", "--dataset", ds, "--predictions", pred, "--out", ev)
# Pairs are written in id order: the first file fits, a later one does not.
pred_files = sorted(os.path.join(d, f) for d, _, fs in os.walk(pred) for f in fs)
pred_limit = os.path.getsize(pred_files[0]) + 1
check(max(map(os.path.getsize, pred_files)) >= pred_limit,
      f"full disk: no prediction file is larger than the first ({pred_limit - 1} bytes)")
shutil.copytree(ph, os.path.join(disk, "ph"))
for ext in [".png", ".npy", ".camera.json"]:
    shutil.copy(os.path.join(TMP, "drr_lao") + ext, os.path.join(disk, "drr" + ext))
full_disk_runs = [
    ("gimm-phantom", ["--seed", 5, "--out", os.path.join(disk, "phantom_new")], 100_000),
    ("gimm-phantom", ["--seed", 5, "--preview", "--out", os.path.join(disk, "ph")], 100_000),
    ("gimm-drr", ["--volume", os.path.join(ph, "3.img.nii.gz"), "--primary", 10, "--secondary", 5,
                  "--rows", 128, "--cols", 160, "--pixel", 1.5, "--quiet", "--out",
                  os.path.join(disk, "drr")], 20_000),
    ("gimm-centerlines", ["--label", os.path.join(ph, "3.label.nii.gz"), "--out",
                          os.path.join(disk, "ph", "3.centerlines.json")], 10_000),
    ("gimm-baseline", ["--dataset", ds, "--method", "oracle", "--out",
                       os.path.join(disk, "pred_new")], pred_limit),
    ("gimm-baseline", ["--dataset", ds, "--method", "oracle", "--sigma", 2, "--out", pred],
     pred_limit),
    ("gimm-match", ["--dataset", ds, "--method", "oracle", "--out", os.path.join(disk, "m_new")],
     pred_limit),
    ("gimm-match", ["--dataset", ds, "--method", "oracle", "--sigma", 2, "--out", pred], pred_limit),
    ("gimm-eval", ["--dataset", ds, "--predictions", pred, "--out", os.path.join(disk, "ev_new")],
     2_000),
    ("gimm-eval", ["--dataset", ds, "--predictions", pred, "--top-k", 5, "--out", ev], 2_000),
    ("gimm-eval", ["--compare", ev, ev, "--out", os.path.join(disk, "cmp_new")], 2_000),
]
for name, args, limit in full_disk_runs:
    h.run_on_full_disk(name, *args, limit=limit, watch=disk)

# No run writes over what it reads (an output that is, or resolves to, an input; a dataset
# written over its own source volumes): refused naming both flags, the input unchanged.
def unchanged_after(path, *args, contains):
    before = open(path, "rb").read()
    run(*args, ok=False, contains=contains)
    check(open(path, "rb").read() == before, f"{args[0]} changed its input {path}")


label = os.path.join(ph, "3.label.nii.gz")
unchanged_after(label, "gimm-centerlines", "--label", label, "--out", label,
                contains="--out " + label + " is the input --label")
tree_in = os.path.join(TMP, "tree_in.json")
run("gimm-centerlines", "--label", label, "--out", tree_in)
unchanged_after(tree_in, "gimm-centerlines", "--label", label, "--truth", tree_in, "--out",
                os.path.join(TMP, ".", "tree_in.json"), contains="is the input --truth")
# A bad --truth fails the run before --out exists (it was written first, then the truth read).
bad_truth = os.path.join(TMP, "bad_truth.json")
open(bad_truth, "w").write("{bad")
never = os.path.join(TMP, "never_written.json")
if os.path.exists(never):
    os.remove(never)
run("gimm-centerlines", "--label", label, "--truth", bad_truth, "--out", never, ok=False,
    contains="bad_truth.json")
check(not os.path.exists(never), "gimm-centerlines wrote --out before it read a bad --truth")
cam_in = os.path.join(TMP, "cam_in.json")
open(cam_in, "w").write(run("gimm-carm", "--primary", 30, "--secondary", 20, "--rows", 64,
                            "--cols", 64))
link = os.path.join(TMP, "cam_link.json")
if not os.path.exists(link):
    os.symlink(cam_in, link)
png = os.path.join(TMP, "flat.png")
Image.fromarray(np.full((64, 64), 128, np.uint8)).save(png)
unchanged_after(cam_in, "gimm-match", "--method", "geometric", "--image-a", png, "--image-b", png,
                "--camera-a", cam_in, "--camera-b", cam_in, "--out", link,
                contains="is the input --camera-a")
unchanged_after(png, "gimm-match", "--method", "geometric", "--image-a", png, "--image-b", png,
                "--camera-a", cam_in, "--camera-b", cam_in, "--picture", png,
                contains="--picture " + png + " is the input --image-a")
# Two outputs that are one file: refused before anything is written (it failed "cannot move"
# and left the file behind).
both = os.path.join(TMP, "both_outputs")
if os.path.exists(both):
    os.remove(both)
run("gimm-match", "--method", "geometric", "--image-a", png, "--image-b", png, "--camera-a",
    cam_in, "--camera-b", cam_in, "--out", both, "--picture", both, ok=False,
    contains="are one file")
check(not os.path.exists(both), "gimm-match left a file behind when --out and --picture clash")
weights_in = os.path.join(TMP, "w.safetensors")
shutil.copy(os.path.join(os.path.dirname(__file__), "..", "..", "weights",
                         "gimm-phantom-128.safetensors"), weights_in)
unchanged_after(weights_in, "gimm-match", "--image-a", png, "--image-b", png, "--weights",
                weights_in, "--out", weights_in, contains="is the input --weights")
src = os.path.join(TMP, "src_ds")
run("gimm-phantom", "--seed", 4, "--out", os.path.join(src, "patients", "7"))
volume = os.path.join(src, "patients", "7", "4.img.nii.gz")
unchanged_after(volume, "gimm-dataset", "--input", os.path.join(src, "patients", "7"), "--out",
                src, contains="lies inside the output --out")

# Errors name what is wrong even when the input is hostile.
# Header bytes are escaped: a NUL no longer cuts the message, an ESC cannot drive the terminal.
nul = os.path.join(TMP, "nul.nrrd")
open(nul, "wb").write(b"NRRD0004\ntype: float\ndimension: 3\nsizes: 4 4 4\nspacings: 1 1 1\n"
                      b"encoding: raw\nendian: little\nfoo\x00bar: 1\n\n" + bytes(256))
proc = h.run("gimm-centerlines", "--label", nul, "--out", os.path.join(TMP, "n.json"), ok=False,
             contains="foo\\x00bar")
esc = os.path.join(TMP, "esc.mha")
open(esc, "wb").write(b"ObjectType = Image\nNDims = 3\nDimSize = 4 4 4\n"
                      b"ElementType = MET_\x1b[31mFLOAT\x07\nElementDataFile = LOCAL\n")
proc = h.run("gimm-centerlines", "--label", esc, "--out", os.path.join(TMP, "n.json"), ok=False,
             contains="MET_\\x1b[31mFLOAT\\x07")
check("\x1b" not in proc.stderr and "\x07" not in proc.stderr, "a header's ESC/BEL reached stderr")
# A volume larger than the process may allocate: the error names the header, not bad_alloc.
big = os.path.join(TMP, "big.nhdr")
open(big, "w").write("NRRD0004\ntype: float\ndimension: 3\nsizes: 1024 1024 256\n"
                     "spacings: 0.5 0.5 0.5\nencoding: raw\nendian: little\ndata file: big.raw\n")
with open(os.path.join(TMP, "big.raw"), "wb") as f:
    f.truncate(1 << 30)  # sparse: no disk used


def limit_memory():
    import resource
    resource.setrlimit(resource.RLIMIT_AS, (700 << 20, 700 << 20))


import subprocess
proc = subprocess.run([os.path.join(BIN, "gimm-centerlines"), "--label", big, "--out",
                       os.path.join(TMP, "n.json")], capture_output=True, text=True,
                      preexec_fn=limit_memory)
if "Sanitizer" in proc.stderr:  # ASan reserves terabytes of shadow memory: no RLIMIT_AS there
    print("cli_test: the memory-limit case skipped (a sanitizer build cannot run under RLIMIT_AS)")
else:
    check(proc.returncode == 1 and "big.nhdr" in proc.stderr and "not enough memory" in proc.stderr
          and "std::bad_alloc" not in proc.stderr,
          f"a volume over the memory limit: want a named error, got {proc.returncode} "
          f"{proc.stderr!r}")
# Pictures too small or too wide for the matchers, and a camera of absurd magnitude.
tiny = os.path.join(TMP, "tiny.png")
Image.fromarray(np.zeros((1, 1), np.uint8)).save(tiny)
run("gimm-match", "--method", "geometric", "--image-a", tiny, "--image-b", png, "--camera-a",
    cam_in, "--camera-b", cam_in, ok=False, contains="--image-a '" + tiny + "' is 1 x 1 px")
wide = os.path.join(TMP, "wide.png")
Image.fromarray(np.zeros((2, 40000), np.uint8)).save(wide)
run("gimm-match", "--method", "geometric", "--image-a", png, "--image-b", wide, "--camera-a",
    cam_in, "--camera-b", cam_in, ok=False, contains="header 40000 x 2 px")
huge_k = json.load(open(cam_in))
huge_k["K"][0][0] = 1e308
huge_k.pop("P")
cam_huge = os.path.join(TMP, "cam_huge.json")
json.dump(huge_k, open(cam_huge, "w"))
run("gimm-match", "--method", "geometric", "--image-a", png, "--image-b", png, "--camera-a",
    cam_huge, "--camera-b", cam_in, ok=False, contains="1e+308")

# A detached header whose data file is an output: refused, the data left as it was (gimm-drr
# replaced o.npy, the volume's voxels; gimm-centerlines wrote its JSON over a label's data).
det = os.path.join(TMP, "detached")
os.makedirs(det, exist_ok=True)
open(os.path.join(det, "o.npy"), "wb").write(np.zeros(16 * 16 * 8, np.int16).tobytes())
open(os.path.join(det, "v.nhdr"), "w").write(
    "NRRD0004\ntype: short\ndimension: 3\nsizes: 16 16 8\nspacings: 1 1 1\nencoding: raw\n"
    "endian: little\ndata file: o.npy\n")
unchanged_after(os.path.join(det, "o.npy"), "gimm-drr", "--volume", os.path.join(det, "v.nhdr"),
                "--primary", 30, "--secondary", 0, "--rows", 32, "--cols", 32, "--out",
                os.path.join(det, "o"), contains="--volume's data file")
unchanged_after(os.path.join(det, "o.npy"), "gimm-centerlines", "--label",
                os.path.join(det, "v.nhdr"), "--out", os.path.join(det, "o.npy"),
                contains="--label's data file")
# A trilinear step far below a voxel hung the renderer: a usage error naming --step.
run("gimm-drr", "--volume", os.path.join(det, "v.nhdr"), "--primary", 30, "--secondary", 0,
    "--rows", 32, "--cols", 32, "--projector", "trilinear", "--step", "1e-9", "--out",
    os.path.join(det, "s"), ok=False, contains="--step 1e-09")

# One camera given as both views: no epipolar geometry, and the error names the two files.
run("gimm-match", "--method", "geometric", "--image-a", png, "--image-b", png, "--camera-a",
    cam_in, "--camera-b", cam_in, ok=False, contains="--camera-b " + cam_in)
run("gimm-carm", "--pair", cam_in, cam_in, ok=False, contains="--pair " + cam_in)

h.finish("cli_test")
