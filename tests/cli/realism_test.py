"""tools/realism/realism.py on hand-made images whose answers are known: a dark line of known
depth and width on a flat background with Gaussian noise of known sigma (contrast and sigma
within 10%, width within 1 px, segmented and with the mask given), a cross (4 branches), a
collimator border (the field fraction), white noise (a flat NPS), the usage errors (exit 2,
naming the file); and, when ../shared/data/clinical-xa is there, one real frame within broad
bounds (skipped without it: a fresh clone has no ../shared).

Run by ctest (realism); alone: realism_test.py TMP_DIR
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
TOOL = os.path.join(ROOT, "tools", "realism", "realism.py")
sys.path.insert(0, os.path.dirname(TOOL))
import realism  # noqa: E402

from harness import Harness  # noqa: E402

TMP = sys.argv[1]
shutil.rmtree(TMP, ignore_errors=True)
os.makedirs(TMP)
h = Harness(None)  # no binaries: the tool is Python
check = h.check


def near(got, want, rel):
    return got is not None and abs(got - want) <= rel * abs(want)


def save16(path, img):
    Image.fromarray(np.clip(np.round(img * 65535), 0, 65535).astype(np.uint16)).save(path)


def run(*args):
    return subprocess.run([sys.executable, TOOL, *args], capture_output=True, text=True)


rng = np.random.default_rng(43)
BG, DEPTH, WIDTH, SIGMA = 0.6, 0.2, 5, 0.02

# --- a dark line: contrast, noise, CNR, width ---------------------------------------------------
line = np.full((256, 256), BG)
line_mask = np.zeros(line.shape, dtype=bool)
line_mask[20:236, 126:126 + WIDTH] = True
line[line_mask] -= DEPTH
noisy = line + rng.normal(0, SIGMA, line.shape)
for how, mask in (("segmented", None), ("mask given", line_mask)):
    s, extra = realism.measure(noisy, mask)
    check(near(s["contrast"], DEPTH, 0.10), f"line, {how}: contrast {s['contrast']} ~ {DEPTH}")
    check(near(s["noise"], SIGMA, 0.10), f"line, {how}: noise {s['noise']} ~ {SIGMA}")
    check(near(s["cnr"], DEPTH / SIGMA, 0.2), f"line, {how}: CNR {s['cnr']} ~ {DEPTH / SIGMA}")
    check(s["width"] is not None and abs(s["width"] - WIDTH) <= 1,
          f"line, {how}: width {s['width']} ~ {WIDTH} px")
    check(s["branches"] == 1, f"line, {how}: {s['branches']} branches, expected 1")
    check(s["field"] == 1.0, f"line, {how}: field {s['field']}, expected 1 (no border)")
    check(near(s["p50"], BG, 0.05), f"line, {how}: median {s['p50']} ~ {BG}")
# the segmentation finds the line and little else
seg = realism.measure(noisy)[1]["mask"]
iou = (seg & line_mask).sum() / (seg | line_mask).sum()
check(iou > 0.8, f"line: segmentation IoU with the true line {iou:.2f} > 0.8")

# A wider, shallower line: the answers follow (a tool that ignored its input would not).
wide = np.full((256, 256), BG)
wide[20:236, 120:131] -= 0.1
wide += rng.normal(0, 0.01, wide.shape)
s, _ = realism.measure(wide)
check(near(s["contrast"], 0.1, 0.10), f"wide line: contrast {s['contrast']} ~ 0.1")
check(near(s["noise"], 0.01, 0.10), f"wide line: noise {s['noise']} ~ 0.01")
check(s["width"] is not None and abs(s["width"] - 11) <= 1, f"wide line: width {s['width']} ~ 11")

# --- a cross: four branches --------------------------------------------------------------------
cross = np.full((256, 256), BG)
cross[40:216, 126:131] -= DEPTH
cross[126:131, 40:216] -= DEPTH
cross += rng.normal(0, SIGMA, cross.shape)
s, _ = realism.measure(cross)
check(s["branches"] == 4, f"cross: {s['branches']} branches, expected 4")
s, _ = realism.measure(cross, min_branch=100)
check(s["branches"] == 0, f"cross, --min-branch 100: {s['branches']} branches, expected 0")

# --- a collimator border: the field ------------------------------------------------------------
coll = noisy.copy()
coll[:, :32] = 0.1     # left shutter, 32 px
coll[-16:, :] = 0.1    # bottom shutter, 16 px
coll += rng.normal(0, 0.005, coll.shape)
s, _ = realism.measure(coll)
want = (256 - 32) * (256 - 16) / 256 ** 2
check(abs(s["field"] - want) < 0.01, f"collimator: field {s['field']:.3f} ~ {want:.3f}")
check(s["field_rect"]["left"] == 32 and s["field_rect"]["bottom"] == 240,
      f"collimator: field rectangle {s['field_rect']}")
check(near(s["contrast"], DEPTH, 0.10), f"collimator: contrast {s['contrast']} ~ {DEPTH} "
      "(the border is no vessel)")

# --- white noise: a flat NPS; a smooth background: a steep one ----------------------------------
white = BG + rng.normal(0, SIGMA, (256, 256))
s, extra = realism.measure(white)
check(extra["mask"].mean() < 0.01,
      f"white noise: {extra['mask'].mean():.3f} of it taken for vessels")
check(s["nps_slope"] is not None and abs(s["nps_slope"]) < 0.3,
      f"white noise: NPS slope {s['nps_slope']} ~ 0")
check(near(s["noise"], SIGMA, 0.10), f"white noise: noise {s['noise']} ~ {SIGMA}")
yy, xx = np.mgrid[0:256, 0:256]
blobs = BG + 0.05 * np.sin(xx / 30.0) * np.cos(yy / 40.0)
s, _ = realism.measure(blobs + rng.normal(0, 0.001, blobs.shape))
check(s["bg_lowpass"] is not None and s["bg_lowpass"] > 0.02,
      f"smooth structure: background low-pass {s['bg_lowpass']} > 0.02")
s, _ = realism.measure(white)
check(s["bg_lowpass"] is not None and s["bg_lowpass"] < 0.005,
      f"white noise: background low-pass {s['bg_lowpass']} < 0.005")
# a power-law field, NPS ~ f^-3: the estimator finds the slope (measure() would take its
# valleys for vessels and leave no background patch, so the estimator alone)
f = np.hypot(*np.meshgrid(np.fft.fftfreq(256), np.fft.fftfreq(256), indexing="ij"))
amp = np.where(f > 0, np.maximum(f, 1e-3) ** -1.5, 0.0)
field = np.real(np.fft.ifft2(amp * np.fft.fft2(rng.normal(0, 1, (256, 256)))))
field = BG + 0.02 * field / field.std()
slope = realism.nps_slope(field, np.ones(field.shape, dtype=bool))
check(slope is not None and abs(slope + 3) < 0.5, f"power-law field: NPS slope {slope} ~ -3")

# --- the command line: 8- and 16-bit files, masks, outputs ---------------------------------------
p16 = os.path.join(TMP, "line16.png")
save16(p16, noisy)
p8 = os.path.join(TMP, "line8.png")
Image.fromarray(np.clip(np.round(noisy * 255), 0, 255).astype(np.uint8)).save(p8)
pm = os.path.join(TMP, "line16.mask.png")
Image.fromarray(line_mask.astype(np.uint8) * 255).save(pm)
out_json, out_md, out_png = (os.path.join(TMP, n) for n in ("r.json", "r.md", "r.png"))
done = run("--real", p8, "--synthetic", p16, "--synthetic-masks", "auto",
           "--json", out_json, "--table", out_md, "--figure", out_png)
check(done.returncode == 0, f"CLI: exit {done.returncode} {done.stderr.strip()}")
if done.returncode == 0:
    res = json.load(open(out_json))
    real, syn = res["images"]
    check(real["stats"]["bits"] == 8 and syn["stats"]["bits"] == 16, "CLI: bit depths 8 and 16")
    check(syn["stats"]["mask"] == "given" and real["stats"]["mask"] == "segmented",
          "CLI: the synthetic mask found beside its view (auto)")
    for r in (real, syn):
        check(near(r["stats"]["contrast"], DEPTH, 0.10),
              f"CLI {r['kind']}: contrast {r['stats']['contrast']} ~ {DEPTH}")
    check("| statistic |" in open(out_md).read(), "CLI: the table has its summary")
    check(os.path.getsize(out_png) > 1000, "CLI: a figure was written")

# --- usage errors: exit 2, the file named ---------------------------------------------------------
missing = os.path.join(TMP, "no_such_frame.jpg")
done = run("--real", missing)
check(done.returncode == 2 and "no_such_frame.jpg" in done.stderr,
      f"missing file: exit {done.returncode}, message {done.stderr.strip()!r}")
junk = os.path.join(TMP, "junk.png")
open(junk, "w").write("not an image")
done = run("--synthetic", junk)
check(done.returncode == 2 and "junk.png" in done.stderr,
      f"unreadable file: exit {done.returncode}, message {done.stderr.strip()!r}")
done = run("--synthetic", p16, p8, "--synthetic-masks", pm)
check(done.returncode == 2 and "masks" in done.stderr,
      f"masks that do not pair: exit {done.returncode}")
done = run()
check(done.returncode == 2, f"no images: exit {done.returncode}")
small_mask = os.path.join(TMP, "small_mask.png")
Image.fromarray(np.zeros((10, 10), dtype=np.uint8)).save(small_mask)
done = run("--synthetic", p16, "--synthetic-masks", small_mask)
check(done.returncode == 2 and "small_mask.png" in done.stderr,
      f"a mask of another size: exit {done.returncode}")

# --- a real frame, when the shared data is there ---------------------------------------------
frame = os.path.join(ROOT, "..", "shared", "data", "clinical-xa", "sample2", "projection0",
                     "frame_20.jpg")
if os.path.isfile(frame):
    img, bits = realism.load_image(frame)
    s, _ = realism.measure(img)
    check(bits == 8, "real frame: 8 bit")
    check(0.05 < (s["contrast"] or 0) < 0.4, f"real frame: contrast {s['contrast']}")
    check(0.002 < (s["noise"] or 0) < 0.05, f"real frame: noise {s['noise']}")
    check(0.85 < s["field"] < 1.0, f"real frame: field {s['field']} (a collimator border)")
    check(s["branches"] >= 5, f"real frame: {s['branches']} branches")
    check(4 <= (s["width"] or 0) <= 20, f"real frame: width {s['width']} px")
else:
    print(f"skipped: the real-frame check ({frame} absent)")

h.finish("realism")
