#!/usr/bin/env python3
"""gimm-dataset end to end: labels reproject, split by patient, a run killed at any moment
and restarted equals an uninterrupted run byte for byte, N shards merged equal one run, and
bad patients are recorded while the rest goes on.

Usage: dataset_test.py BIN_DIR TMP_DIR
"""
import filecmp
import json
import os
import shutil
import signal
import subprocess
import sys
import time

import numpy as np

from harness import Harness

BIN, TMP = sys.argv[1], sys.argv[2]
DATASET = os.path.join(BIN, "gimm-dataset")
COMMON = ["--phantom", "4", "--seed", "7", "--rows", "128", "--cols", "128", "--pixel", "2.0",
          "--quiet"]
h = Harness(BIN)
check = h.check


def run(args, env=None, ok=True):
    return h.run("gimm-dataset", *args, env=env, ok=ok)


def tree_files(root):
    out = []
    for d, _, files in os.walk(root):
        out += [os.path.relpath(os.path.join(d, f), root) for f in files]
    return sorted(out)


def same_tree(a, b, what):
    fa, fb = tree_files(a), tree_files(b)
    if fa != fb:
        check(False, f"{what}: file lists differ: {sorted(set(fa) ^ set(fb))[:10]}")
        return
    diff = [f for f in fa if not filecmp.cmp(os.path.join(a, f), os.path.join(b, f), shallow=False)]
    check(not diff, f"{what}: {len(diff)} files differ, e.g. {diff[:5]}")


def check_pair_labels(pdir, what):
    """Every dense label of a patient reprojects with its cameras and satisfies the exact F."""
    pairs = sorted(os.listdir(os.path.join(pdir, "pairs")))
    check(len(pairs) == 27, f"{what}: 27 pairs per patient in shared mode, got {len(pairs)}")
    check(len(os.listdir(os.path.join(pdir, "views"))) == 44,
          f"{what}: 11 views x (png, mask, camera, points)")
    worst_px = worst_epi = 0.0
    for name in pairs:
        lab = json.load(open(os.path.join(pdir, "pairs", name)))
        Pa = np.array(json.load(open(os.path.join(pdir, "views", lab["view_a"] + ".camera.json")))["P"])
        Pb = np.array(json.load(open(os.path.join(pdir, "views", lab["view_b"] + ".camera.json")))["P"])
        F = np.array(lab["F"])
        d = np.array(lab["dense"])
        check(len(d) > 50, f"{what} {name}: only {len(d)} dense labels")
        check(len(lab["sparse"]) == 20, f"{what} {name}: {len(lab['sparse'])} sparse labels")
        X = np.c_[d[:, 4:7], np.ones(len(d))]
        for P, uv in [(Pa, d[:, 0:2]), (Pb, d[:, 2:4])]:
            x = X @ P.T
            worst_px = max(worst_px, np.abs(x[:, :2] / x[:, 2:] - uv).max())
        xa, xb = np.c_[d[:, 0:2], np.ones(len(d))], np.c_[d[:, 2:4], np.ones(len(d))]
        lines = xa @ F.T
        dist = np.abs((xb * lines).sum(1)) / np.hypot(lines[:, 0], lines[:, 1])
        worst_epi = max(worst_epi, dist.max())
    check(worst_px < 1e-3, f"{what}: labels reproject to {worst_px} px")
    check(worst_epi < 1e-6, f"{what}: labels lie {worst_epi} px off their epipolar lines")
    return pairs


shutil.rmtree(TMP, ignore_errors=True)
os.makedirs(TMP)
full = os.path.join(TMP, "full")
run(COMMON + ["--out", full])

# Labels: every dense label reprojects with its cameras and satisfies the exact F.
manifest = json.load(open(os.path.join(full, "manifest.json")))
check(len(manifest["patients"]) == 4 and all(p["status"] == "ok" for p in manifest["patients"]),
      "four ok patients")
pdir = os.path.join(full, "patients", "phantom-0001")
pairs = check_pair_labels(pdir, "voxel vessels")
# Per-view points: the branch/point indices address centerlines.json, and the pair labels are
# exactly the points valid (in image, on mask) in both views.
tree = json.load(open(os.path.join(pdir, "centerlines.json")))
lab = json.load(open(os.path.join(pdir, "pairs", pairs[0])))
va = json.load(open(os.path.join(pdir, "views", lab["view_a"] + ".points.json")))
vb = json.load(open(os.path.join(pdir, "views", lab["view_b"] + ".points.json")))
valid = [n for n in range(len(va["u"])) if va["in_image"][n] and va["on_mask"][n]
         and vb["in_image"][n] and vb["on_mask"][n]]
check(len(valid) == len(lab["dense"]), f"{len(valid)} valid points vs {len(lab['dense'])} labels")
for row, n in zip(lab["dense"][:50], valid[:50]):
    xyz = tree["branches"][va["branch"][n]]["points"][va["point"][n]]
    check(np.allclose(row[4:7], xyz) and row[7] == va["branch"][n] and
          abs(row[0] - va["u"][n]) < 1e-9, f"label {row[:9]} vs centerline point {xyz}")

# Mesh vessels (Embree chords and visibility, traced on the writer thread too): labels hold, the
# bytes do not depend on the thread count, and occluded points are marked.
MESH = ["--phantom", "2", "--seed", "7", "--rows", "128", "--cols", "128", "--pixel", "2.0",
        "--quiet", "--vessels", "mesh"]
mesh_out = os.path.join(TMP, "mesh")
run(MESH + ["--out", mesh_out])
check_pair_labels(os.path.join(mesh_out, "patients", "phantom-0001"), "mesh vessels")
hidden = 0
for root, _, files in os.walk(os.path.join(mesh_out, "patients")):
    for f in files:
        if f.endswith(".points.json"):
            pts = json.load(open(os.path.join(root, f)))
            hidden += sum(1 for i, vis in zip(pts["in_image"], pts["visible"]) if i and not vis)
check(hidden > 0, "mesh mode marks some in-image points as occluded")
mesh_one = os.path.join(TMP, "mesh_one_thread")
run(MESH + ["--out", mesh_one], env={"OMP_NUM_THREADS": "1"})
same_tree(mesh_out, mesh_one, "mesh vessels on 1 thread against 2")

# Split by patient: each patient in exactly one split file.
seen = []
for s in ["train", "val", "test"]:
    seen += open(os.path.join(full, "splits", s + ".txt")).read().split()
check(sorted(seen) == [f"phantom-{n:04d}" for n in range(4)], f"splits {seen}")

# Killed and resumed (SIGKILL at several moments) equals uninterrupted.
for delay in [0.25, 0.6, 1.0]:
    out = os.path.join(TMP, f"killed_{delay}")
    proc = subprocess.Popen([DATASET, *COMMON, "--out", out])
    time.sleep(delay)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    run(COMMON + ["--out", out])
    same_tree(full, out, f"resume after kill at {delay} s")

# Shards (flag, Slurm and Kubernetes variables) merged equal one run.
for how in ["flag", "slurm", "k8s"]:
    out = os.path.join(TMP, f"shards_{how}")
    for i in range(3):
        if how == "flag":
            run(COMMON + ["--out", out, "--shard", f"{i}/3"])
        elif how == "slurm":
            run(COMMON + ["--out", out], env={"SLURM_ARRAY_TASK_ID": str(i + 1),
                                              "SLURM_ARRAY_TASK_COUNT": "3",
                                              "SLURM_ARRAY_TASK_MIN": "1"})
        else:
            run(COMMON + ["--out", out], env={"JOB_COMPLETION_INDEX": str(i),
                                              "GIMM_SHARD_COUNT": "3"})
    run(["merge", "--out", out])
    same_tree(full, out, f"3 shards ({how}) merged")
# --export reference, directly and after a sharded merge, gives the same reference tree.
exp = os.path.join(TMP, "export_full")
run(COMMON + ["--out", exp, "--export", "reference"])
check(len(os.listdir(os.path.join(exp, "reference", "images"))) == 4 * 27 * 2,
      "reference export: 2 images per pair")
for name in ["frame_export_old.json", "train_list.txt", "val_list.txt", "test_list.txt"]:
    check(os.path.exists(os.path.join(exp, "reference", name)), f"reference export lacks {name}")
exp_sh = os.path.join(TMP, "export_shards")
for i in range(2):
    run(COMMON + ["--out", exp_sh, "--shard", f"{i}/2"])
run(["merge", "--out", exp_sh, "--export", "reference"])
same_tree(os.path.join(exp, "reference"), os.path.join(exp_sh, "reference"),
          "reference export after merge")

out = os.path.join(TMP, "shards_missing")
run(COMMON + ["--out", out, "--shard", "0/2"])
proc = run(["merge", "--out", out], ok=False)
check(proc.returncode != 0 and "shard 1 of 2 is missing" in proc.stderr, "merge with a missing shard")
proc = run(COMMON + ["--out", out, "--shard", "2/2"], ok=False)
check(proc.returncode != 0 and "out of range" in proc.stderr, "bad --shard")

# A folder with bad patients: the good one is made, the bad ones are recorded.
folder = os.path.join(TMP, "imagecas")
os.makedirs(folder)
subprocess.run([os.path.join(BIN, "gimm-phantom"), "--seed", "1", "--out", folder], check=True,
               capture_output=True)
shutil.copy(os.path.join(folder, "1.img.nii.gz"), os.path.join(folder, "2.img.nii.gz"))  # no label
subprocess.run([os.path.join(BIN, "gimm-phantom"), "--seed", "3", "--out", os.path.join(TMP, "x")],
               check=True, capture_output=True)
import nibabel as nib  # noqa: E402
small = nib.load(os.path.join(TMP, "x", "3.label.nii.gz"))
nib.save(nib.Nifti1Image(np.asarray(small.dataobj)[:64], small.affine),
         os.path.join(folder, "3.label.nii.gz"))
shutil.copy(os.path.join(TMP, "x", "3.img.nii.gz"), os.path.join(folder, "3.img.nii.gz"))
out = os.path.join(TMP, "folder_out")
run(["--input", folder, "--out", out, "--rows", "96", "--cols", "96", "--pixel", "2.5", "--quiet"])
m = json.load(open(os.path.join(out, "manifest.json")))
status = {p["id"]: p for p in m["patients"]}
check(status.get("1", {}).get("status") == "ok", f"patient 1: {status.get('1')}")
check("missing" in status.get("2", {}).get("error", ""), f"patient 2: {status.get('2')}")
check("disagree" in status.get("3", {}).get("error", ""), f"patient 3: {status.get('3')}")
# A write that fails in the middle of a patient (views are written on a helper thread while the
# next one renders): that patient is recorded with an error naming the file, the others are
# made, nothing half-written is left, and a rerun once the obstacle is gone equals a full run.
out = os.path.join(TMP, "blocked_write")
blocker = os.path.join(out, "patients", "phantom-0002", "views", "LCA_03.mask.png")
os.makedirs(os.path.join(blocker, "in-the-way"))
run(COMMON + ["--out", out])
m = json.load(open(os.path.join(out, "manifest.json")))
status = {p["id"]: p for p in m["patients"]}
check(status.get("phantom-0002", {}).get("status") == "failed" and
      "LCA_03.mask.png" in status["phantom-0002"].get("error", ""),
      f"blocked patient: {status.get('phantom-0002')}")
check(all(status.get(f"phantom-{n:04d}", {}).get("status") == "ok" for n in (0, 1, 3)),
      f"the other patients go on: {status}")
leftovers = [f for f in tree_files(out) if ".tmp." in f]
check(not leftovers, f"half-written files left behind: {leftovers}")
shutil.rmtree(blocker)
run(COMMON + ["--out", out])
same_tree(full, out, "rerun after a blocked write")

ro = os.path.join(TMP, "read_only")
os.makedirs(ro)
os.chmod(ro, 0o500)
if os.access(ro, os.W_OK):  # running as root: permissions are not enforced
    ro = "/proc/gimm-cannot-write-here"
proc = run(COMMON + ["--out", ro], ok=False)
check(proc.returncode != 0 and "error" in proc.stderr, "unwritable output must fail up front")

h.finish("dataset_test")
