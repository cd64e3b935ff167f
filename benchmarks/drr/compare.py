#!/usr/bin/env python3
"""gimm-drr against plastimatch drr: geometry flags, orientation check, accuracy, Markdown tables.

  compare.py flags CAMERA.json          -> "nx ny nz ux uy uz": plastimatch --nrm and --vup
  compare.py report OUT_DIR             -> Markdown tables (reads the files side_by_side.sh wrote)
  compare.py chart OUT_DIR RUNS.txt     -> gnuplot data: time against error on the blob scene
                                           (RUNS.txt lines: tool step_mm time_ms image_file)

Geometry mapping (checked by `report`, never assumed): plastimatch places the source at
isocentre + SAD nrm and the detector centre at source - SID nrm, with --vup towards the top row.
gimm's camera.json gives the source ("center") and R, whose row 1 is the image's up direction;
so nrm = (center - isocenter) / SOD and vup = R[1]. plastimatch's columns then run along
vup x nrm (its .txt matrix: AP, nrm +y, vup +z -> columns towards -x, the patient's right),
gimm's along R[0] = nrm x vup (towards the patient's left): the opposite handedness, so
plastimatch's image is gimm's mirrored left-right (the view from the source rather than from
the detector side). `report` finds, and requires, that by trying all 8 flips/transposes.
Units: with -P none plastimatch integrates the voxel values as given (mm x value) and divides
by 10 ("mm to cm"); its output x 10 is the same optical depth as gimm's for mu in mm^-1.
"""
import json
import sys

import numpy as np

PM_SCALE = 10.0  # plastimatch drr divides the mm line integral by 10


def read_pfm(path):
    """PFM as stored: plastimatch writes its row 0 (the --vup side) first, ignoring the
    format's bottom-up convention; no flip here, orientation is matched explicitly."""
    with open(path, "rb") as f:
        assert f.readline().strip() == b"Pf"
        cols, rows = map(int, f.readline().split())
        scale = float(f.readline())
        data = np.frombuffer(f.read(), dtype="<f4" if scale < 0 else ">f4")
    return data.reshape(rows, cols).astype(np.float64)


def camera(path):
    c = json.load(open(path))
    return {k: np.array(c[k], dtype=float) for k in ("K", "R", "center", "isocenter")} | {
        "rows": c["image_size"]["rows"], "cols": c["image_size"]["cols"]}


def flags(camera_json):
    c = camera(camera_json)
    nrm = c["center"] - c["isocenter"]
    nrm /= np.linalg.norm(nrm)
    vup = c["R"][1]
    print(" ".join(f"{x:.12g}" for x in (*nrm, *vup)))


def rays(c):
    """Unit directions (rows, cols, 3) of gimm's rays through the pixel centres."""
    v, u = np.mgrid[0:c["rows"], 0:c["cols"]].astype(float)
    pix = np.stack([u, v, np.ones_like(u)], -1)
    d = pix @ (c["R"].T @ np.linalg.inv(c["K"])).T
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def truth_blobs(c, blobs):
    d = rays(c)
    out = np.zeros(d.shape[:2])
    for b in blobs:
        w = np.array(b["centre"]) - c["center"]
        t = d @ w
        d2 = w @ w - t * t
        out += b["peak"] * b["sigma"] * np.sqrt(2 * np.pi) * np.exp(-d2 / (2 * b["sigma"] ** 2))
    return out


def truth_cube(c, half=48.0):
    """Chord length (mm) through the box [-half, half]^3 (the cube volume, value 1)."""
    d = rays(c)
    with np.errstate(divide="ignore", invalid="ignore"):
        t0 = (-half - c["center"]) / d
        t1 = (half - c["center"]) / d
    t_in = np.nanmax(np.minimum(t0, t1), -1)
    t_out = np.nanmin(np.maximum(t0, t1), -1)
    return np.clip(t_out - t_in, 0, None)


ORIENT = {
    "as written": lambda a: a, "flipud": lambda a: a[::-1], "fliplr": lambda a: a[:, ::-1],
    "rot180": lambda a: a[::-1, ::-1], "transpose": lambda a: a.T,
    "transpose+flipud": lambda a: a.T[::-1], "transpose+fliplr": lambda a: a.T[:, ::-1],
    "transpose+rot180": lambda a: a.T[::-1, ::-1],
}


def best_orientation(pm, ref):
    scores = {k: np.abs(f(pm) - ref).mean() for k, f in ORIENT.items()}
    name = min(scores, key=scores.get)
    runner_up = sorted(scores.values())[1]
    return name, scores[name], runner_up


def errors(img, truth):
    m = truth > 0.01 * truth.max()
    e = img[m] - truth[m]
    return np.abs(e).mean(), e.mean(), (np.abs(e) / truth[m]).mean(), np.abs(e).max()


def hyperfine_times(path):
    d = json.load(open(path))
    return {r["command"]: (r["mean"], r["stddev"], r["median"], r["min"]) for r in d["results"]}


def report(out):
    tools = [("gimm siddon", "g_siddon", False), ("gimm trilinear 0.75 mm", "g_tri075", False),
             ("gimm trilinear 0.5625 mm", "g_tri05625", False),
             ("plastimatch exact", "pm_exact", True), ("plastimatch uniform", "pm_uniform", True)]

    def load(scene, stem, is_pm, orient="fliplr"):
        if is_pm:
            return ORIENT[orient](read_pfm(f"{out}/{scene}_{stem}0000.pfm") * PM_SCALE)
        return np.load(f"{out}/{scene}_{stem}.npy").astype(np.float64)

    def loaded(scene, some_tools):
        """(label, image) of every tool whose output for `scene` exists."""
        for label, stem, is_pm in some_tools:
            try:
                yield label, load(scene, stem, is_pm)
            except FileNotFoundError:
                continue

    print("### Orientation (plastimatch image against gimm siddon, same geometry)\n")
    print("| scene, view | best of 8 flips/transposes | mean abs diff | next best |")
    print("| --- | --- | --- | --- |")
    for scene in ("thorax_ap", "thorax_lao", "blobs_lao"):
        g = load(scene, "g_siddon", False)
        pm = read_pfm(f"{out}/{scene}_pm_exact0000.pfm") * PM_SCALE
        name, best, second = best_orientation(pm, g)
        assert name == "fliplr", f"{scene}: plastimatch orientation {name}, expected fliplr"
        print(f"| {scene} | {name} | {best:.2e} | {second:.2e} |")
        # and no sub-pixel/one-pixel shift hides in it
        shifts = {(dr, dc): np.abs(np.roll(ORIENT[name](pm), (dr, dc), (0, 1)) - g).mean()
                  for dr in (-1, 0, 1) for dc in (-1, 0, 1)}
        assert min(shifts, key=shifts.get) == (0, 0), f"{scene}: best shift {min(shifts, key=shifts.get)}"

    g0 = load("thorax_ap", "g_siddon", False)
    g1 = load("thorax_flipped_ap", "g_siddon", False)
    p1 = load("thorax_flipped_ap", "pm_exact", True)
    print(f"\nDirection cosines (thorax stored reversed in i, j with direction -1 on x, y; same "
          f"object): gimm siddon max abs change {np.abs(g1 - g0).max():.2e}; plastimatch exact "
          f"mean abs change {np.abs(p1 - load('thorax_ap', 'pm_exact', True)).mean():.3f} "
          f"(mean optical depth {g0.mean():.3f}), {int((p1 > 0).sum())} of {p1.size} pixels "
          f"non-zero")

    print("\n### Agreement on the thorax volume (optical depth, pixels above 1% of the peak)\n")
    print("| view | tool | mean abs diff to gimm siddon | mean rel. diff | max abs diff |")
    print("| --- | --- | --- | --- | --- |")
    for scene in ("thorax_ap", "thorax_lao"):
        g = load(scene, "g_siddon", False)
        for label, img in loaded(scene, tools[1:]):
            a, _, r, mx = errors(img, g)
            print(f"| {scene} | {label} | {a:.2e} | {r:.2e} | {mx:.2e} |")

    c = camera(f"{out}/blobs_lao_g_siddon.camera.json")
    truth = {"blobs_lao": truth_blobs(c, json.load(open(f"{out}/blobs.json"))),
             "cube_lao": truth_cube(camera(f"{out}/cube_lao_g_siddon.camera.json"))}
    print("\n### Accuracy against analytic line integrals (LAO 30 / cranial 20)\n")
    print("| volume | tool | mean abs error | mean signed error | mean rel. error | max abs error |")
    print("| --- | --- | --- | --- | --- | --- |")
    for scene, t in truth.items():
        for label, img in loaded(scene, tools):
            a, s, r, mx = errors(img, t)
            print(f"| {scene} | {label} | {a:.3e} | {s:+.3e} | {r:.3e} | {mx:.3e} |")

    times = hyperfine_times(f"{out}/times.json")
    print("\n### Whole process (hyperfine, thorax 256^3 float .nii -> 512^2, AP)\n")
    print("| command | mean (s) | stddev | median | min |")
    print("| --- | --- | --- | --- | --- |")
    key = {}
    for cmd, (mean, sd, med, mn) in times.items():
        short = next(stem for _, stem, _ in tools if f"/thorax_ap_{stem}" in cmd)
        key[short] = mean
        print(f"| `{short}` | {mean:.3f} | {sd:.3f} | {med:.3f} | {mn:.3f} |")
    print("\n" + open(f"{out}/load.txt").read().strip().replace("\n", "; "))
    print("\nIn-process times (ms, median of 3 runs; plastimatch reports rendering + writing only):\n")
    print("| tool | load | render | write | render + write |")
    print("| --- | --- | --- | --- | --- |")
    parts = {}
    for line in open(f"{out}/breakdown.txt"):
        stem, text = line.split(": ", 1)
        if text.startswith("Total time"):
            parts.setdefault(stem, []).append((None, float(text.split()[2]) * 1000, None))
        else:
            ms = [float(text.split(f"{k} ")[1].split(" ms")[0]) for k in ("load", "render", "write")]
            parts.setdefault(stem, []).append(tuple(ms))
    for stem, runs in parts.items():
        med = lambda i: np.median([r[i] for r in runs]) if runs[0][i] is not None else None
        fmt = lambda x: "-" if x is None else f"{x:.0f}"
        load, render, write = med(0), med(1), med(2)
        total = render + (write or 0)
        print(f"| `{stem}` | {fmt(load)} | {fmt(render) if write is not None else '-'} | "
              f"{fmt(write)} | {total:.0f} |")
    print(f"\nratios of means: plastimatch exact / gimm siddon = "
          f"{key['pm_exact'] / key['g_siddon']:.2f}; plastimatch uniform / gimm trilinear "
          f"0.75 mm = {key['pm_uniform'] / key['g_tri075']:.2f}; plastimatch uniform / gimm "
          f"trilinear 0.5625 mm = {key['pm_uniform'] / key['g_tri05625']:.2f}")
    mins = {short: times[cmd][3] for cmd in times
            for short in [next(stem for _, stem, _ in tools if f"/thorax_ap_{stem}" in cmd)]}
    print(f"ratios of minima: {mins['pm_exact'] / mins['g_siddon']:.2f}; "
          f"{mins['pm_uniform'] / mins['g_tri075']:.2f}; {mins['pm_uniform'] / mins['g_tri05625']:.2f}")


def chart(out, runs_txt):
    """One line per run: tool step_mm time_ms mean_rel_error mean_abs_error (blob scene, LAO)."""
    c = camera(f"{out}/blobs_lao_g_siddon.camera.json")
    truth = truth_blobs(c, json.load(open(f"{out}/blobs.json")))
    for line in open(runs_txt):
        tool, step, ms, path = line.split()
        img = (ORIENT["fliplr"](read_pfm(path) * PM_SCALE) if path.endswith(".pfm")
               else np.load(path).astype(np.float64))
        a, _, r, _ = errors(img, truth)
        print(f"{tool} {step} {ms} {r:.6g} {a:.6g}")


if __name__ == "__main__":
    {"flags": flags, "report": report, "chart": chart}[sys.argv[1]](*sys.argv[2:])
