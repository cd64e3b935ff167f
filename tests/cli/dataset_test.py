#!/usr/bin/env python3
"""gimm-dataset end to end: labels reproject, split by patient, a run killed at any moment
and restarted equals an uninterrupted run byte for byte (seconds go to --timings, outside), N
shards merged equal one run, bad patients are recorded while the rest goes on, ImageCAS
sub-folders, dropped label voxels, single-tree labels, stage timings, and a full disk (a failed
run, merge or export leaves nothing of its own, and a dataset already there unchanged).

Usage: dataset_test.py BIN_DIR TMP_DIR
"""
import filecmp
import glob
import json
import os
import shutil
import signal
import subprocess
import sys
import time

import numpy as np

from harness import Harness, read_png_gray

BIN, TMP = sys.argv[1], sys.argv[2]
DATASET = os.path.join(BIN, "gimm-dataset")
COMMON = ["--phantom", "4", "--style", "drr", "--seed", "7", "--rows", "128", "--cols", "128",
          "--pixel", "2.0", "--quiet"]
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
    """The same files, byte for byte (wall-clock seconds stay out of the dataset)."""
    fa, fb = tree_files(a), tree_files(b)
    if fa != fb:
        check(False, f"{what}: file lists differ: {sorted(set(fa) ^ set(fb))[:10]}")
        return
    diff = [f for f in fa if not filecmp.cmp(os.path.join(a, f), os.path.join(b, f), shallow=False)]
    check(not diff, f"{what}: {len(diff)} files differ, e.g. {diff[:5]}")


def check_pair_labels(pdir, what, files_per_view=4, views=11, pair_count=27):
    """Every dense label of a patient reprojects with its cameras and satisfies the exact F."""
    pairs = sorted(os.listdir(os.path.join(pdir, "pairs")))
    check(len(pairs) == pair_count, f"{what}: {pair_count} pairs per patient, got {len(pairs)}")
    check(len(os.listdir(os.path.join(pdir, "views"))) == views * files_per_view,
          f"{what}: {views} views x {files_per_view} files (png, mask, camera, points[, overlap])")
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
timings_file = os.path.join(TMP, "full-timings.jsonl")
run(COMMON + ["--out", full, "--timings", timings_file])

# Labels: every dense label reprojects with its cameras and satisfies the exact F.
manifest = json.load(open(os.path.join(full, "manifest.json")))
check(len(manifest["patients"]) == 4 and all(p["status"] == "ok" for p in manifest["patients"]),
      "four ok patients")
pdir = os.path.join(full, "patients", "phantom-0001")
pairs = check_pair_labels(pdir, "voxel vessels")
# Stage timings: one JSON line per patient in the --timings file; no file of the dataset holds
# seconds (it is byte-reproducible).
STAGES = ["read", "split", "centerlines", "attenuation", "mesh", "views", "pairs", "writes"]
timing_lines = {t["id"]: t for t in map(json.loads, open(timings_file))}
check(sorted(timing_lines) == sorted(p["id"] for p in manifest["patients"]),
      f"--timings: a line per patient, got {sorted(timing_lines)}")
for p in manifest["patients"]:
    t = timing_lines.get(p["id"], {"views": 0, "seconds": {"total": 0}})
    done = open(os.path.join(full, "patients", p["id"], "done.json")).read()
    check(t["views"] == 11 and t["seconds"]["total"] > 0 and
          all(s in t["seconds"] for s in STAGES) and "seconds" not in done and
          not os.path.exists(os.path.join(full, "patients", p["id"], "timings.json")),
          f"{p['id']}: timings {t}, done.json has seconds: {'seconds' in done}")
    check(p["label"]["components"] == 2 and p["label"]["dropped_voxels"] == 0 and
          all(sys["present"] for sys in p["systems"].values()), f"{p['id']}: record {p}")
check("seconds" not in open(os.path.join(full, "manifest.json")).read(), "timings in the manifest")
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
MESH = ["--phantom", "2", "--style", "drr", "--seed", "7", "--rows", "128", "--cols", "128", "--pixel", "2.0",
        "--quiet", "--vessels", "mesh"]
mesh_out = os.path.join(TMP, "mesh")
run(MESH + ["--out", mesh_out])
check_pair_labels(os.path.join(mesh_out, "patients", "phantom-0001"), "mesh vessels", 5)
hidden = overlapping = 0
for root, _, files in os.walk(os.path.join(mesh_out, "patients")):
    for f in files:
        if f.endswith(".points.json"):
            pts = json.load(open(os.path.join(root, f)))
            hidden += sum(1 for i, vis in zip(pts["in_image"], pts["visible"]) if i and not vis)
            overlapping += sum(1 for i, o in zip(pts["in_image"], pts["overlap"]) if i and o >= 2)
in_image = sum(sum(json.load(open(os.path.join(r, f)))["in_image"])
               for r, _, fs in os.walk(os.path.join(mesh_out, "patients"))
               for f in fs if f.endswith(".points.json"))
check(0 < hidden < in_image / 4 and 0 < overlapping < in_image / 4,
      f"mesh mode: {hidden} occluded and {overlapping} overlapping of {in_image} in-image points")
# The overlap map: passages per pixel, > 0 exactly on the vessel mask.
view = os.path.join(mesh_out, "patients", "phantom-0001", "views", "LCA_00")
overlap_map, mask = read_png_gray(view + ".overlap.png"), read_png_gray(view + ".mask.png")
check(overlap_map.shape == (128, 128) and ((overlap_map > 0) == (mask > 0)).all() and
      overlap_map.max() >= 2, f"overlap map: max {overlap_map.max()}, on mask exactly")

mesh_one = os.path.join(TMP, "mesh_one_thread")
run(MESH + ["--out", mesh_one], env={"OMP_NUM_THREADS": "1"})
same_tree(mesh_out, mesh_one, "mesh vessels on 1 thread against 2")

# The released code's protocol: per-pair views (54 renders per patient) and orthographic
# cameras; labels reproject and satisfy F (affine) there too.
ortho = os.path.join(TMP, "per_pair_orthographic")
run(["--phantom", "1", "--style", "drr", "--seed", "7", "--rows", "96", "--cols", "96", "--pixel",
     "2.5", "--quiet", "--view-mode", "per_pair", "--model", "orthographic", "--out", ortho])
opdir = os.path.join(ortho, "patients", "phantom-0000")
check_pair_labels(opdir, "per-pair orthographic", views=54)
cam = json.load(open(os.path.join(opdir, "views", "LCA_00.camera.json")))
check(np.allclose(np.array(cam["P"])[2, :3], 0), f"orthographic P has an affine last row: {cam['P']}")

# Views placed on purpose (--views): a 5-degree pair, a pose two pairs share (rendered once)
# and one RCA pair. Labels reproject and satisfy F; each view keeps its angles, gets its
# system's nearest class; the manifest records the list; the bad cases are refused.
VIEW_LIST = {"format": "gimm-views/1", "pairs": [
    {"system": "LCA", "a": {"primary": 30, "secondary": 0}, "b": {"primary": 35, "secondary": 0}},
    {"system": "LCA", "a": {"primary": 30, "secondary": 0}, "b": {"primary": -30, "secondary": 20}},
    {"system": "RCA", "a": {"primary": 45, "secondary": 0}, "b": {"primary": -30, "secondary": 5}}]}
views_json = os.path.join(TMP, "views.json")
with open(views_json, "w") as f:
    json.dump(VIEW_LIST, f)
LISTED = ["--phantom", "1", "--style", "drr", "--seed", "7", "--rows", "96", "--cols", "96", "--pixel", "2.5",
          "--quiet", "--views", views_json]
listed = os.path.join(TMP, "listed")
run(LISTED + ["--out", listed])
ldir = os.path.join(listed, "patients", "phantom-0000")
check_pair_labels(ldir, "listed views", views=5, pair_count=3)
cams = {v: json.load(open(os.path.join(ldir, "views", v + ".camera.json")))
        for v in ["LCA_00", "LCA_01", "LCA_02", "RCA_00", "RCA_01"]}
check([(c["primary_deg"], c["secondary_deg"]) for c in cams.values()] ==
      [(30, 0), (35, 0), (-30, 20), (45, 0), (-30, 5)], "listed views keep their angles")
check([c["view_class"] for c in cams.values()] == [8, 8, 10, 2, 4],
      f"listed views' classes {[c['view_class'] for c in cams.values()]}")
axis = [np.array(cams[v]["R"])[2] for v in ["LCA_00", "LCA_01"]]
check(abs(np.degrees(np.arccos(np.clip(axis[0] @ axis[1], -1, 1))) - 5) < 1e-6,
      "the listed LCA pair is 5 degrees apart")
lab = json.load(open(os.path.join(ldir, "pairs", "LCA_00-02.json")))
check((lab["view_a"], lab["view_b"]) == ("LCA_00", "LCA_02"), "pairs name their listed views")
lparams = json.load(open(os.path.join(listed, "manifest.json")))["parameters"]
check(lparams["view_mode"] == "listed" and lparams["views"] == VIEW_LIST,
      f"manifest records the list: {lparams.get('view_mode')}, {lparams.get('views')}")
for extra, text in [(["--export", "reference"], "--views"),
                    (["--view-mode", "per_pair"], "excludes"),
                    (["--views", os.path.join(TMP, "no_such_views.json")], "no_such_views.json")]:
    out = os.path.join(TMP, "listed_refused")
    args = LISTED + extra if extra[0] != "--views" else LISTED[:-1] + [extra[1]]
    proc = run(args + ["--out", out], ok=False)
    check(text in proc.stderr and not os.path.exists(out),
          f"{extra}: refused naming '{text}', nothing written: {proc.stderr.strip()[-200:]}")
bad_list = dict(VIEW_LIST, pairs=[dict(VIEW_LIST["pairs"][0], b={"primary": 30.5, "secondary": 0})])
with open(views_json, "w") as f:
    json.dump(bad_list, f)
proc = run(LISTED + ["--out", os.path.join(TMP, "listed_refused")], ok=False)
check("views.json" in proc.stderr and "pairs[0]" in proc.stderr and "0.5 degrees apart" in proc.stderr
      and not os.path.exists(os.path.join(TMP, "listed_refused")),
      f"a too-close pair refused naming the file and pair, nothing written: "
      f"{proc.stderr.strip()[-200:]}")
# A list that names one system: the other gets centerlines but no views, recorded as present.
one_system = dict(VIEW_LIST, pairs=VIEW_LIST["pairs"][:1])
with open(views_json, "w") as f:
    json.dump(one_system, f)
lca_only = os.path.join(TMP, "listed_lca_only")
run(LISTED + ["--out", lca_only])
record = json.load(open(os.path.join(lca_only, "manifest.json")))["patients"][0]
rca = record["systems"]["RCA"]
check(record["status"] == "ok" and rca["present"] and rca["views"] == 0 and rca["pairs"] == 0
      and rca["centerline_mm"] > 0 and record["systems"]["LCA"]["pairs"] == 1,
      f"one-system list: {record['systems']}")
check(sorted(os.listdir(os.path.join(lca_only, "patients", "phantom-0000", "pairs"))) ==
      ["LCA_00-01.json"], "one-system list: only its pair is written")
# Resumed with another list: refused like any other change of parameters, nothing changed.
with open(views_json, "w") as f:
    json.dump(VIEW_LIST, f)
before = tree_files(lca_only)
proc = run(LISTED + ["--out", lca_only], ok=False)
check("other parameters" in proc.stderr and tree_files(lca_only) == before,
      f"resumed with another view list: {proc.stderr.strip()[-200:]}")

# Split by patient: each patient in exactly one split file.
seen = []
for s in ["train", "val", "test"]:
    seen += open(os.path.join(full, "splits", s + ".txt")).read().split()
check(sorted(seen) == [f"phantom-{n:04d}" for n in range(4)], f"splits {seen}")

# Killed and resumed (SIGKILL at several moments) equals uninterrupted. The moments are events,
# not times, so that each kill lands while the run is still going on this machine's speed.
def views_written(out, patient):
    """The patient's view files so far: in its staging folder (patients/<id>.tmp.<host>.<pid>/)
    while it is made, in patients/<id>/ once complete."""
    count = 0
    for d in glob.glob(os.path.join(out, "patients", patient + "*", "views")):
        try:
            count = max(count, len(os.listdir(d)))
        except FileNotFoundError:  # renamed into place meanwhile
            pass
    return count


kill_moments = {
    "at start": lambda out: True,
    "mid first patient": lambda out: views_written(out, "phantom-0000") >= 6,
    "after first patient": lambda out: os.path.exists(
        os.path.join(out, "patients", "phantom-0000", "done.json")),
    "mid third patient": lambda out: views_written(out, "phantom-0002") >= 10,
}
for moment, reached in kill_moments.items():
    out = os.path.join(TMP, "killed_" + moment.replace(" ", "_"))
    proc = subprocess.Popen([DATASET, *COMMON, "--out", out])
    while not reached(out) and proc.poll() is None:
        time.sleep(0.002)
    check(proc.poll() is None, f"kill {moment}: the run ended before the kill")
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    run(COMMON + ["--out", out])
    same_tree(full, out, f"resume after a kill {moment}")

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

# A shard cleans only its own patients' temporaries and staging folders: another shard may be
# writing its files into the same folder right now.
out = os.path.join(TMP, "shards_busy")
busy = os.path.join(out, "patients", "phantom-0001", "views", "LCA_00.png.tmp.otherhost.77")
staging = os.path.join(out, "patients", "phantom-0001.tmp.otherhost.78")
os.makedirs(os.path.dirname(busy))
os.makedirs(os.path.join(staging, "views"))
open(busy, "w").write("being written by shard 1")
open(os.path.join(staging, "views", "LCA_00.png"), "w").write("being made by shard 1")
run(COMMON + ["--out", out, "--shard", "0/2"])
check(os.path.exists(busy) and os.path.exists(staging),
      "shard 0 removed a temporary file or staging folder of shard 1's patient")
run(COMMON + ["--out", out, "--shard", "1/2"])
check(not os.path.exists(busy) and not os.path.exists(staging),
      "shard 1 left its own stale temporary or staging folder behind")
run(["merge", "--out", out])
same_tree(full, out, "2 shards with a stale temporary, merged")

# Resuming into a folder made with other parameters is refused and changes nothing.
out = os.path.join(TMP, "other_parameters")
shutil.copytree(full, out)
proc = run([a if a != "128" else "96" for a in COMMON] + ["--out", out], ok=False)
check(proc.returncode != 0 and "other parameters" in proc.stderr and "/parameters/carm/" in proc.stderr,
      f"resume with other parameters: {proc.stderr[-300:]}")
same_tree(full, out, "a refused resume")

# --export with --shard is refused before any work.
out = os.path.join(TMP, "shard_export")
proc = run(COMMON + ["--out", out, "--shard", "0/2", "--export", "reference"], ok=False)
check(proc.returncode == 2 and "--export with --shard 0/2" in proc.stderr and
      not os.path.exists(os.path.join(out, "patients")), f"--export with --shard: {proc.stderr}")

# Flags that would set nothing are refused, before any work.
for flag in (["--primary", "30"], ["--secondary", "-10"], ["--isocenter", "0", "0", "0"]):
    out = os.path.join(TMP, "noop_flag")
    proc = run(COMMON + ["--out", out] + flag, ok=False)
    check(proc.returncode != 0 and f"{flag[0]} sets nothing" in proc.stderr and
          not os.path.exists(out), f"{flag[0]}: {proc.stderr}")

# --vessels tubes are a phantom's: with --input, a usage error naming the flag, before any work.
out = os.path.join(TMP, "tubes_input")
proc = run(["--input", TMP, "--vessels", "tubes", "--out", out], ok=False)
check(proc.returncode == 2 and "--vessels" in proc.stderr and "phantom" in proc.stderr and
      not os.path.exists(out), f"--vessels tubes with --input: {proc.returncode} {proc.stderr}")

# The lumen is a phantom's too; with phantoms the stenoses drawn are recorded per patient.
for flag in (["--stenoses", "1"], ["--lumen-irregularity", "0.05"], ["--tortuosity", "1"]):
    out = os.path.join(TMP, "lumen_input")
    proc = run(["--input", TMP, *flag, "--out", out], ok=False)
    check(proc.returncode == 2 and flag[0] in proc.stderr and "phantom" in proc.stderr and
          not os.path.exists(out), f"{flag[0]} with --input: {proc.returncode} {proc.stderr}")
out = os.path.join(TMP, "lumen")
run(["--phantom", "1", "--style", "drr", "--tree", "rich", "--rows", "64", "--cols", "64",
     "--pixel", "3.0", "--stenoses", "2", "--lumen-irregularity", "0.05", "--tortuosity", "1.5",
     "--quiet", "--out", out])
with open(os.path.join(out, "patients", "phantom-0000", "centerlines.json")) as f:
    record = json.load(f)
lumen = record.get("phantom_lumen", {})
check(record.get("phantom_tortuosity") == {"sigma_mm": 1.5, "correlation_mm": 4.0},
      f"--tortuosity 1.5: centerlines.json records {record.get('phantom_tortuosity')}")
proc = run(["--phantom", "1", "--tortuosity", "6", "--out", os.path.join(TMP, "tortuous")], ok=False)
check(proc.returncode == 2 and "--tortuosity" in proc.stderr and
      not os.path.exists(os.path.join(TMP, "tortuous")),
      f"--tortuosity 6: {proc.returncode} {proc.stderr}")
check(len(lumen.get("stenoses", [])) == 2 and lumen.get("irregularity") == 0.05 and
      all(0.3 <= s["severity"] <= 0.8 for s in lumen["stenoses"]),
      f"--stenoses 2: centerlines.json records {lumen}")

# --timings inside --out would put wall-clock seconds into the dataset: a usage error.
out = os.path.join(TMP, "timings_inside")
proc = run(COMMON + ["--out", out, "--timings", os.path.join(out, "t.jsonl")], ok=False)
check(proc.returncode == 2 and "--timings" in proc.stderr and not os.path.exists(out),
      f"--timings inside --out: {proc.returncode} {proc.stderr}")

# The progress line: patients done, rate and ETA; after a full resume the rate counts no one.
LOUD = [a for a in COMMON if a != "--quiet"]
proc = run(LOUD[:1] + ["1"] + LOUD[2:] + ["--out", os.path.join(TMP, "progress")])
check("1/1 patients (0 resumed, 0 failed)" in proc.stderr and "patients/s, ETA 0 s" in proc.stderr,
      f"progress line: {proc.stderr!r}")
check("11 views made in" in proc.stdout and "s per view" in proc.stdout, f"summary: {proc.stdout!r}")
# The per-patient line and the summary name every stage.
patient_line = [ln for ln in proc.stderr.replace("\r", "\n").splitlines()
                if ln.startswith("gimm-dataset: patient phantom-0000: ")]
check(len(patient_line) == 1 and all(f" {s} " in patient_line[0] for s in STAGES) and
      "(11 views, " in patient_line[0], f"per-patient line: {proc.stderr!r}")
check("time by stage" in proc.stdout and all(f" {s} " in proc.stdout for s in STAGES),
      f"stage summary: {proc.stdout!r}")
out = os.path.join(TMP, "progress_resumed")
shutil.copytree(full, out)
proc = run(LOUD + ["--out", out])
check("4/4 patients (4 resumed, 0 failed), 0.000 patients/s, ETA ?" in proc.stderr and
      "views made in" not in proc.stdout, f"progress line after a resume: {proc.stderr!r}")

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
# Patient 5: a NaN in the CT; patient 6: a label without any vessel.
img = nib.load(os.path.join(folder, "1.img.nii.gz"))
hu = np.asarray(img.dataobj).astype(np.float32)
hu[10, 20, 5] = np.nan
nib.save(nib.Nifti1Image(hu, img.affine), os.path.join(folder, "5.img.nii.gz"))
shutil.copy(os.path.join(folder, "1.label.nii.gz"), os.path.join(folder, "5.label.nii.gz"))
shutil.copy(os.path.join(folder, "1.img.nii.gz"), os.path.join(folder, "6.img.nii.gz"))
lab1 = nib.load(os.path.join(folder, "1.label.nii.gz"))
nib.save(nib.Nifti1Image(np.zeros(lab1.shape, np.uint8), lab1.affine),
         os.path.join(folder, "6.label.nii.gz"))
# Patient 4: the label's j axis points the other way (same origin, sizes and spacing).
lab4 = nib.load(os.path.join(folder, "1.label.nii.gz"))
flipped = lab4.affine.copy()
flipped[:3, 1] *= -1
nib.save(nib.Nifti1Image(np.asarray(lab4.dataobj), flipped), os.path.join(folder, "4.label.nii.gz"))
shutil.copy(os.path.join(folder, "1.img.nii.gz"), os.path.join(folder, "4.img.nii.gz"))
# Patient 7: a third tree in the label (a 6^3 block in a corner, 216 voxels, over 5% of this
# phantom's label): made from the two largest, the rest recorded and warned about. Patient 8:
# one tree only.
lab7 = np.asarray(lab1.dataobj).copy()
check(0.05 < 216 / (lab7.sum() + 216) < 0.25 and lab7[1:7, 1:7, 1:7].sum() == 0,
      f"phantom label: {lab7.sum()} voxels")
lab7[1:7, 1:7, 1:7] = 1
nib.save(nib.Nifti1Image(lab7, lab1.affine), os.path.join(folder, "7.label.nii.gz"))
shutil.copy(os.path.join(folder, "1.img.nii.gz"), os.path.join(folder, "7.img.nii.gz"))


def one_component(label):
    """The 26-connected component of the label's first voxel (breadth-first)."""
    todo = [tuple(np.argwhere(label)[0])]
    seen = set(todo)
    while todo:
        i, j, k = todo.pop()
        for d in np.ndindex(3, 3, 3):
            n = (i + d[0] - 1, j + d[1] - 1, k + d[2] - 1)
            if n not in seen and all(0 <= n[a] < label.shape[a] for a in range(3)) and label[n]:
                seen.add(n)
                todo.append(n)
    out = np.zeros_like(label)
    out[tuple(np.array(sorted(seen)).T)] = 1
    return out


lab8 = one_component(np.asarray(lab1.dataobj))
check(0 < lab8.sum() < lab1.get_fdata().sum(), f"one tree of the phantom: {lab8.sum()} voxels")
nib.save(nib.Nifti1Image(lab8, lab1.affine), os.path.join(folder, "8.label.nii.gz"))
shutil.copy(os.path.join(folder, "1.img.nii.gz"), os.path.join(folder, "8.img.nii.gz"))
out = os.path.join(TMP, "folder_out")
folder_run = run(["--input", folder, "--out", out, "--rows", "96", "--cols", "96", "--pixel", "2.5",
                  "--quiet"])
m = json.load(open(os.path.join(out, "manifest.json")))
status = {p["id"]: p for p in m["patients"]}
check(status.get("1", {}).get("status") == "ok", f"patient 1: {status.get('1')}")
check("missing" in status.get("2", {}).get("error", ""), f"patient 2: {status.get('2')}")
check("dimensions" in status.get("3", {}).get("error", ""), f"patient 3: {status.get('3')}")
check("direction of axis 1" in status.get("4", {}).get("error", ""), f"patient 4: {status.get('4')}")
check("not finite" in status.get("5", {}).get("error", ""), f"patient 5: {status.get('5')}")
check("patient 6 label: empty coronary mask" in status.get("6", {}).get("error", ""),
      f"patient 6: {status.get('6')}")
n7 = int(lab7.sum())
check(f"warning: patient 7: {100 * 216 / n7:.1f}% of the label's voxels (216 of {n7}, in 1 of its "
      "3 components)" in folder_run.stderr, f"patient 7 warning: {folder_run.stderr}")
check(status.get("7", {}).get("status") == "ok" and
      status["7"]["label"] == {"voxels": n7, "components": 3, "dropped_components": 1,
                               "dropped_voxels": 216, "dropped_fraction": 216 / n7},
      f"patient 7 (a third tree in its label): {status.get('7')}")
check(json.load(open(os.path.join(out, "patients", "7", "done.json")))["label"] ==
      status["7"]["label"], "patient 7: done.json records the dropped voxels")
check("patient 1" not in folder_run.stderr, f"a clean label warns: {folder_run.stderr}")
# The manifest records the library's words (its option), the log the CLI's (the flag beside it).
check("SplitOptions::allow_single" in status.get("8", {}).get("error", ""),
      f"patient 8: {status.get('8')}")
check("error: gimm-dataset: patient 8 failed:" in folder_run.stderr and
      "SplitOptions::allow_single (--allow-single-system)" in folder_run.stderr,
      f"patient 8's error line lacks the flag: {folder_run.stderr}")

# --allow-single-system: the single tree is made (the system it is assigned to), the other is
# recorded as absent; the threshold of the dropped-voxel warning is a flag.
single = os.path.join(TMP, "single_in")
os.makedirs(single)
for f in ["7.img.nii.gz", "7.label.nii.gz", "8.img.nii.gz", "8.label.nii.gz"]:
    shutil.copy(os.path.join(folder, f), single)
out = os.path.join(TMP, "single_out")
proc = run(["--input", single, "--out", out, "--rows", "96", "--cols", "96", "--pixel", "2.5",
            "--quiet", "--allow-single-system", "--warn-dropped", "0.25"])
check("warning" not in proc.stderr, f"--warn-dropped 0.25, patient 7 at 18.5%: {proc.stderr}")
m = json.load(open(os.path.join(out, "manifest.json")))
status = {p["id"]: p for p in m["patients"]}
rec = status.get("8", {})
present = [name for name, sys in rec.get("systems", {}).items() if sys["present"]]
check(rec.get("status") == "ok" and len(present) == 1 and m["parameters"]["allow_single_system"],
      f"patient 8 with --allow-single-system: {rec}")
if rec.get("status") == "ok" and len(present) == 1:
    absent = "RCA" if present[0] == "LCA" else "LCA"
    check(rec["systems"][absent] == {"present": False, "voxels": 0, "views": 0, "pairs": 0,
                                     "centerline_mm": 0.0, "dense_labels": 0},
          f"patient 8 absent system: {rec['systems'][absent]}")
    p8 = os.path.join(out, "patients", "8")
    prefixes = {f[:3] for d in ["views", "pairs"] for f in os.listdir(os.path.join(p8, d))}
    n_views = len([f for f in os.listdir(os.path.join(p8, "views")) if f.endswith(".camera.json")])
    check(prefixes == {present[0]} and n_views == rec["systems"][present[0]]["views"] > 0,
          f"patient 8 files: {prefixes}, {n_views} views")
check(status.get("7", {}).get("status") == "ok", f"patient 7 with --allow-single-system: {status.get('7')}")

# ImageCAS as distributed: patients in sub-folders (and NIfTI with or without gzip) give the
# same patients, with one split over all of them, as the same files in one folder.
nested, flat = os.path.join(TMP, "nested_in"), os.path.join(TMP, "flat_in")
for d in ["1-200", "201-400/more"]:
    os.makedirs(os.path.join(nested, d))
os.makedirs(flat)
for src, dst in [("1.img.nii.gz", "1-200/1.img.nii.gz"), ("1.label.nii.gz", "1-200/1.label.nii.gz"),
                 ("7.img.nii.gz", "201-400/7.img.nii.gz"), ("7.label.nii.gz", "201-400/7.label.nii.gz")]:
    shutil.copy(os.path.join(folder, src), os.path.join(nested, dst))
nib.save(nib.load(os.path.join(folder, "1.img.nii.gz")), os.path.join(nested, "201-400/more/9.img.nii"))
nib.save(nib.load(os.path.join(folder, "1.label.nii.gz")), os.path.join(nested, "201-400/more/9.label.nii"))
for d, _, files in os.walk(nested):
    for f in files:
        shutil.copy(os.path.join(d, f), flat)
FOLDER = ["--rows", "96", "--cols", "96", "--pixel", "2.5", "--quiet"]
run(["--input", nested, "--out", os.path.join(TMP, "nested_out")] + FOLDER)
run(["--input", flat, "--out", os.path.join(TMP, "flat_out")] + FOLDER)
m = json.load(open(os.path.join(TMP, "nested_out", "manifest.json")))
check(sorted(p["id"] for p in m["patients"]) == ["1", "7", "9"] and
      all(p["status"] == "ok" for p in m["patients"]), f"nested folder: {m['patients']}")
check(sorted(p["split"] for p in m["patients"]) == ["test", "train", "val"],
      f"one split over every sub-folder: {[(p['id'], p['split']) for p in m['patients']]}")
for sub in ["patients", "splits"]:
    same_tree(os.path.join(TMP, "flat_out", sub), os.path.join(TMP, "nested_out", sub),
              f"nested input against flat input: {sub}")
# The same id in two sub-folders is refused before any work, naming both files.
shutil.copy(os.path.join(folder, "1.img.nii.gz"), os.path.join(nested, "201-400/more/1.img.nii.gz"))
out = os.path.join(TMP, "duplicate_out")
proc = run(["--input", nested, "--out", out] + FOLDER, ok=False)
check("patient id '1'" in proc.stderr and os.path.join(nested, "1-200", "1.img.nii.gz") in proc.stderr
      and os.path.join(nested, "201-400", "more", "1.img.nii.gz") in proc.stderr and
      not os.path.exists(out), f"duplicate id: {proc.stderr}")
# No patient at all: the folder and the patterns looked for.
empty = os.path.join(TMP, "no_patients")
os.makedirs(os.path.join(empty, "sub"))
shutil.copy(os.path.join(folder, "1.label.nii.gz"), os.path.join(empty, "sub", "1.nii.gz"))
proc = run(["--input", empty, "--out", os.path.join(TMP, "no_patients_out")] + FOLDER, ok=False)
check(f"'{empty}'" in proc.stderr and "<id>.img.nii.gz with <id>.label.nii.gz" in proc.stderr and
      "<id>.img.nii with <id>.label.nii" in proc.stderr, f"no patients: {proc.stderr}")

# --export reference with an id the reference layout cannot name: refused before any work.
bad_ids = os.path.join(TMP, "bad_ids")
os.makedirs(bad_ids)
for f in ["img", "label"]:
    shutil.copy(os.path.join(folder, f"1.{f}.nii.gz"), os.path.join(bad_ids, f"1.{f}.nii.gz"))
    shutil.copy(os.path.join(folder, f"1.{f}.nii.gz"), os.path.join(bad_ids, f"case_2.{f}.nii.gz"))
out = os.path.join(TMP, "bad_ids_out")
proc = run(["--input", bad_ids, "--out", out, "--export", "reference"] + FOLDER, ok=False)
check(proc.returncode == 2 and "--export reference" in proc.stderr and
      "patient id 'case_2'" in proc.stderr and "at '_'" in proc.stderr and
      not os.path.exists(os.path.join(out, "patients")), f"--export with a bad id: {proc.stderr}")
# An unfinished patient folder written in place (by a killed run of an older gimm), even with a
# folder in the way of one of its files: the patient is made in its staging folder and replaces
# it whole. (A write that fails while a patient is made: the full-disk checks below.)
out = os.path.join(TMP, "unfinished_in_place")
blocker = os.path.join(out, "patients", "phantom-0002", "views", "LCA_03.mask.png")
os.makedirs(os.path.join(blocker, "in-the-way"))
open(os.path.join(out, "patients", "phantom-0002", "views", "LCA_00.png"), "w").write("half")
run(COMMON + ["--out", out])
same_tree(full, out, "a run over an unfinished patient folder")

# A full disk (simulated: every file limited to N bytes, harness.run_on_full_disk): the run fails
# naming the file and the reason, and leaves nothing of its own: no output folder, partial
# patient, temporary or split list on a fresh target, and a dataset already there unchanged. The
# limits come from the full run's file sizes, so that many files are written before the failure.
disk = os.path.join(TMP, "full_disk")
os.makedirs(disk)
open(os.path.join(disk, "unrelated.txt"), "w").write("not gimm's")


def sizes(pattern):
    return [os.path.getsize(p) for p in glob.glob(os.path.join(full, "patients", pattern))]


# Every RCA view file fits, an LCA view does not (written on the helper thread while the next
# view renders); every view fits, an LCA pair does not (written after the views).
view_limit = max(sizes("phantom-0000/views/RCA_*")) + 1
pair_limit = max(sizes("*/views/*")) + 1
check(max(sizes("phantom-0000/views/LCA_*")) >= view_limit and
      max(sizes("phantom-0000/pairs/LCA_*")) >= pair_limit and view_limit < pair_limit,
      f"full disk: the limits {view_limit}, {pair_limit} stop no write of phantom-0000")
# A fresh target: no folder appears.
h.run_on_full_disk("gimm-dataset", *COMMON, "--out", os.path.join(disk, "new"), limit=view_limit,
                   watch=disk)
# A killed run's folder (three finished patients, no manifest or splits yet): the fourth patient
# fails; nothing of it appears. A rerun with room finishes it as if nothing had happened.
partial = os.path.join(disk, "partial")
shutil.copytree(full, partial)
for leftover in ["patients/phantom-0003", "splits", "manifest.json"]:
    path = os.path.join(partial, leftover)
    shutil.rmtree(path) if os.path.isdir(path) else os.remove(path)
h.run_on_full_disk("gimm-dataset", *COMMON, "--out", partial, limit=pair_limit, watch=disk)
run(COMMON + ["--out", partial])
same_tree(full, partial, "a run resumed after a full disk")
# --export reference on a finished dataset: the export fails part way; no reference folder, and
# the manifest and splits as they were.
finished = os.path.join(disk, "finished")
shutil.copytree(full, finished)
# Marked, so that a run that rewrote them before failing (bytes equal to the originals) is seen.
for marked in ["manifest.json", "splits/train.txt"]:
    with open(os.path.join(finished, marked), "a") as f:
        f.write("\n")
h.run_on_full_disk("gimm-dataset", *COMMON, "--out", finished, "--export", "reference",
                   limit=pair_limit, watch=disk)
# merge --export: the shard manifests stay, no manifest.json or splits appear, and nothing of the
# export.
sharded = os.path.join(disk, "sharded")
for i in range(2):
    run(COMMON + ["--out", sharded, "--shard", f"{i}/2"])
h.run_on_full_disk("gimm-dataset", "merge", "--out", sharded, "--export", "reference",
                   limit=pair_limit, watch=disk)
run(["merge", "--out", sharded])
same_tree(full, sharded, "shards merged after a failed merge")

# Styles: the default (clinical) forms the views of the chest phantom's rich tree through its
# tubes at 0.3 mm; drr is the bare DRR of the crop phantom; a flag of its own wins over either.
styled = {}
for name, extra in [("clinical", []), ("drr", ["--style", "drr"]),
                    ("clinical_no_formation", ["--no-formation", "--pixel", "0.5"])]:
    styled[name] = os.path.join(TMP, "style_" + name)
    run(["--phantom", "1", "--seed", "7", "--rows", "64", "--cols", "64", "--quiet",
         "--view-mode", "per_pair", "--out", styled[name]] + extra)
for name, images, size, tree, pixel in [
        ("clinical", ["drr", "formed", "field"], "chest", "rich", 0.3),
        ("drr", ["drr"], "small", None, 0.5),
        ("clinical_no_formation", ["drr"], "chest", "rich", 0.5)]:
    with open(os.path.join(styled[name], "manifest.json")) as f:
        m = json.load(f)
    check(m["format"] == "gimm-dataset/2" and m["images"] == images,
          f"style {name}: format {m['format']}, images {m.get('images')} (want {images})")
    check(m["input"]["phantom_size"] == size and m["input"].get("phantom_tree") == tree,
          f"style {name}: input {m['input']}")
    check(("formation" in m["parameters"]) == ("formed" in images),
          f"style {name}: a formation record exactly with formed images")
    check(abs(m["parameters"]["carm"]["pixel_mm"] - pixel) < 1e-12,
          f"style {name}: pixel {m['parameters']['carm']['pixel_mm']} (want {pixel})")
    views = glob.glob(os.path.join(styled[name], "patients", "phantom-0000", "views", "*"))
    formed = [v for v in views if v.endswith(".formed.png")]
    check(bool(formed) == ("formed" in images), f"style {name}: {len(formed)} formed views")
    vessels = m["parameters"]["vessel_mode"]
    check(vessels == ("voxel" if name == "drr" else "tubes"), f"style {name}: vessels {vessels}")
# The rich tree in the clinical style: its tubes' axes are the labelled centerlines, side
# branches included (drr's are the label's skeleton, named by it).
names = [b["name"] for b in json.load(open(os.path.join(
    styled["clinical"], "patients", "phantom-0000", "centerlines.json")))["branches"]]
check(len(names) >= 18 and {"S1", "S2", "S3", "CB", "RV1", "RV2"} <= set(names),
      f"clinical style: the rich tree's branches, got {names}")

ro = os.path.join(TMP, "read_only")
os.makedirs(ro)
os.chmod(ro, 0o500)
if os.access(ro, os.W_OK):  # running as root: permissions are not enforced
    ro = "/proc/gimm-cannot-write-here"
proc = run(COMMON + ["--out", ro], ok=False)
check(proc.returncode != 0 and "error" in proc.stderr, "unwritable output must fail up front")

h.finish("dataset_test")
