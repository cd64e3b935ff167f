#!/usr/bin/python3
"""Measured realism: the same image statistics on real angiogram frames and on gimm's DRRs.

    tools/realism/realism.py --real FILES... --synthetic FILES...
                             [--real-masks FILES...|auto] [--synthetic-masks FILES...|auto]
                             [--table OUT.md] [--json OUT.json] [--figure OUT.png]

Every image is read as grey and put in [0, 1] display units by its full scale (8-bit / 255,
16-bit / 65535); vessels are dark. Per image (docs/realism.md, "Measured realism"):

  field        share of the image inside the collimator (dark border detected per side)
  contrast     median over the centreline pixels of (mean of the background ring within 15 px)
               minus the pixel: the vessels' depth below their local background
  noise        sigma of the background's high-pass residual (MAD, corrected for the filter)
  cnr          contrast / noise
  nps_slope    log-log slope of the background's radially averaged noise power spectrum
  bg_lowpass   std / median of the background smoothed at 16 px (vessels left out)
  p1..p99      intensity percentiles inside the field
  width        median vessel width (px) from the distance transform on the centrelines
  branches     skeleton branches of at least --min-branch px

Vessels: a Frangi vesselness (Hessian of Gaussians over several scales) inside the detected
field, hysteresis thresholds, then each vessel cut at half its depth below the local
background (so that widths are comparable across images), or a mask PNG (> 0 = vessel) per
image: --real-masks / --synthetic-masks in the order of the images, or `auto` (gimm-dataset's
<view>.mask.png beside <view>.png). Masks are optional; the segmentation measures both kinds
of image the same way.

Needs numpy, scipy, PIL, matplotlib (Debian's python3). Exit status 2 on a usage error (a
file that is missing or not an image, masks that do not pair with the images).
"""
import argparse
import io
import json
import math
import os
import sys

import numpy as np
from PIL import Image, UnidentifiedImageError
from scipy import ndimage as ndi

SCALES = (1.0, 1.5, 2.0, 3.0, 4.0)       # Hessian scales (px)
BETA = 0.5                               # Frangi blob/line weight
EDGE = 0.5                               # step-edge suppression (gradient / curvature)
HIGH, LOW = 0.25, 0.08                   # hysteresis, relative to the 99.9th pct vesselness
MIN_AREA = 40                            # px: smaller vessel components are dropped
MIN_SNR = 2.5                            # a vessel's median depth, in noise sigmas, at least
HALF_DEPTH_WINDOW = 15                   # px: window of the local centre depth
CLOSING = 41                             # px: grey closing that removes vessels (background)
RING = (3.0, 8.0)                        # px from the mask: the background ring
RING_WINDOW = 31                         # px: the ring pixels a centreline pixel is compared with
NOISE_TILE = 32                          # px tiles for the noise sigma
NOISE_SMOOTH = 1.0                       # px Gaussian of the high-pass residual
NPS_PATCH = 64                           # px patches for the NPS
NPS_BAND = (0.08, 0.35)                  # cycles/px: the fitted "mid" frequencies
LOWPASS = 16.0                           # px Gaussian of the background structure
PERCENTILES = (1, 5, 50, 95, 99)
MARGIN = 8                               # px kept off the fully exposed part's edge

STAT_KEYS = ("field", "contrast", "noise", "cnr", "nps_slope", "bg_lowpass",
             "p1", "p5", "p50", "p95", "p99", "width", "branches")


class UsageError(Exception):
    pass


# --- reading -----------------------------------------------------------------------------------

def load_image(path):
    """Grey image in [0, 1] by its full scale (8 or 16 bit), and its bit depth."""
    if not os.path.isfile(path):
        raise UsageError(f"{path}: no such file")
    try:
        with Image.open(path) as im:
            im.load()
            mode = im.mode
            if mode in ("I;16", "I;16B", "I;16L", "I"):
                a = np.asarray(im, dtype=np.float64)
                bits = 16
                if mode == "I" and a.max(initial=0) > 65535:
                    raise UsageError(f"{path}: 32-bit integer image, expected 8 or 16 bit")
                return a / 65535.0, bits
            if mode == "F":
                raise UsageError(f"{path}: floating-point image, expected 8 or 16 bit")
            a = np.asarray(im.convert("L"), dtype=np.float64)
            return a / 255.0, 8
    except UnidentifiedImageError:
        raise UsageError(f"{path}: not an image PIL can read")
    except OSError as e:
        raise UsageError(f"{path}: cannot read ({e})")


def load_mask(path, shape):
    if not os.path.isfile(path):
        raise UsageError(f"{path}: no such mask file")
    try:
        with Image.open(path) as im:
            m = np.asarray(im.convert("L") if im.mode not in ("I;16", "I") else im) > 0
    except (UnidentifiedImageError, OSError) as e:
        raise UsageError(f"{path}: not a mask PIL can read ({e})")
    if m.shape != shape:
        raise UsageError(f"{path}: mask is {m.shape[1]}x{m.shape[0]}, "
                         f"its image {shape[1]}x{shape[0]}")
    return m


def auto_mask_path(path):
    """gimm-dataset's mask beside its view: LCA_00.png -> LCA_00.mask.png."""
    root, ext = os.path.splitext(path)
    return root + ".mask" + ext


# --- the exposed field -------------------------------------------------------------------------

def side_border(profile, dark=0.8):
    """The collimator's dark band at the start of a profile: (edge, inner) depths in px, 0 and 0
    when the edge is no darker than `dark` times the plateau 32-96 px inside. `edge` is the
    half-rise point between the edge level and the plateau (the field's boundary), `inner` the
    90% rise point (where the penumbra ends; the analysis keeps inside it)."""
    n = len(profile)
    plateau = float(np.median(profile[min(32, n // 4):min(96, n // 2)]))
    edge = float(np.mean(profile[:2]))
    if plateau <= 0 or edge >= dark * plateau:
        return 0, 0
    out = []
    for frac in (0.5, 0.9):
        above = np.nonzero(profile[:n // 2] >= edge + frac * (plateau - edge))[0]
        out.append(int(above[0]) if len(above) else n // 2)
    return out[0], max(out)


def exposed_field(img):
    """Rectangles inside the collimator's dark border, (top, bottom, left, right) with exclusive
    ends: the field (half-rise edges) and the fully exposed part (90% rise). Per side, the
    median of each row (column) over the middle half of the other axis."""
    h, w = img.shape
    rows = np.median(img[:, w // 4:3 * w // 4], axis=1)
    cols = np.median(img[h // 4:3 * h // 4, :], axis=0)
    t, b, l, r = (side_border(p) for p in (rows, rows[::-1], cols, cols[::-1]))
    return ((t[0], h - b[0], l[0], w - r[0]), (t[1], h - b[1], l[1], w - r[1]))


def rect_mask(shape, rect, margin=0):
    top, bottom, left, right = rect
    m = np.zeros(shape, dtype=bool)
    m[top + margin:max(top + margin, bottom - margin),
      left + margin:max(left + margin, right - margin)] = True
    return m


# --- vessels -----------------------------------------------------------------------------------

def vesselness(img, inside, scales=SCALES, beta=BETA, edge=EDGE):
    """Frangi vesselness of dark tubes (the Hessian's large eigenvalue positive), max over the
    scales, scale-normalised (sigma^2); the structureness constant is half the largest Hessian
    norm inside the field over all scales. Times exp(-r^2 / 2 edge^2), r = sigma |gradient| /
    (sigma^2 lambda2): 0 on a line's centre, 1 beside a step edge (a rib's or the spine's
    border, which the Hessian alone takes for a line). Outside `inside` the image is filled
    with its median so that the collimator edge gives no response."""
    work = np.where(inside, img, np.median(img[inside]))
    lam1s, lam2s, grads = [], [], []
    for s in scales:
        grads.append(np.hypot(ndi.gaussian_filter(work, s, order=(1, 0)),
                              ndi.gaussian_filter(work, s, order=(0, 1))) * s)
        hrr = ndi.gaussian_filter(work, s, order=(2, 0)) * s * s
        hcc = ndi.gaussian_filter(work, s, order=(0, 2)) * s * s
        hrc = ndi.gaussian_filter(work, s, order=(1, 1)) * s * s
        mean = 0.5 * (hrr + hcc)
        root = np.sqrt(0.25 * (hrr - hcc) ** 2 + hrc ** 2)
        a, b = mean + root, mean - root
        swap = np.abs(a) < np.abs(b)
        lam1s.append(np.where(swap, a, b))   # smaller magnitude
        lam2s.append(np.where(swap, b, a))   # larger magnitude
    s_norm = [np.hypot(l1, l2) for l1, l2 in zip(lam1s, lam2s)]
    c = 0.5 * max(float(s[inside].max()) for s in s_norm)
    best = np.zeros_like(img)
    for l1, l2, sn, g in zip(lam1s, lam2s, s_norm, grads):
        rb = np.divide(l1, l2, out=np.zeros_like(l1), where=l2 != 0)
        r = np.divide(g, l2, out=np.full_like(g, np.inf), where=l2 > 0)
        v = (np.exp(-rb ** 2 / (2 * beta ** 2)) * (1 - np.exp(-sn ** 2 / (2 * c * c)))
             * np.exp(-r ** 2 / (2 * edge ** 2)))
        v[l2 <= 0] = 0
        best = np.maximum(best, v)
    best[~inside] = 0
    return best


def hysteresis(v, inside, high=HIGH, low=LOW, min_area=MIN_AREA):
    ref = float(np.percentile(v[inside], 99.9))
    if ref <= 0:
        return np.zeros_like(inside)
    lab, n = ndi.label(v >= low * ref, structure=np.ones((3, 3)))
    if n == 0:
        return np.zeros_like(inside)
    idx = np.arange(1, n + 1)
    has_high = ndi.maximum(v, lab, idx) >= high * ref
    area = ndi.sum(np.ones_like(v), lab, idx)
    keep = np.zeros(n + 1, dtype=bool)
    keep[1:] = has_high & (area >= min_area)
    return keep[lab]


def local_background(img, inside, size=CLOSING):
    """The image without its dark vessels: a grey closing (vessels narrower than `size` px are
    filled) of the lightly smoothed image, then smoothed."""
    work = np.where(inside, ndi.gaussian_filter(img, 1.0), np.median(img[inside]))
    return ndi.gaussian_filter(ndi.grey_closing(work, size=(size, size)), 4.0)


def segment(img, inside):
    """Vessel mask: Frangi + hysteresis finds them; detections whose median depth below the
    local background is under MIN_SNR noise sigmas (noise_sigma over the whole field) are
    dropped (on an image without vessels the relative thresholds would keep noise); each vessel
    is then cut at half its local depth (pixels near the detection, deeper than half the deepest
    depth within HALF_DEPTH_WINDOW px), so the width is the visible width (FWHM) whatever the
    Hessian scale."""
    core = hysteresis(vesselness(img, inside), inside)
    if not core.any():
        return core
    depth = local_background(img, inside) - ndi.gaussian_filter(img, 1.0)
    sigma, _ = noise_sigma(img, inside)
    lab, n = ndi.label(core, structure=np.ones((3, 3)))
    med = ndi.median(depth, lab, np.arange(1, n + 1))
    core = np.concatenate([[False], np.asarray(med) >= MIN_SNR * (sigma or 0.0)])[lab]
    if not core.any():
        return core
    centre = ndi.grey_dilation(np.where(core, depth, 0.0), size=HALF_DEPTH_WINDOW)
    near = ndi.binary_dilation(core, iterations=3)
    mask = near & inside & (depth > 0) & (depth >= 0.5 * centre)
    # keep the pieces that touch a detection; fill pinholes
    lab, n = ndi.label(mask, structure=np.ones((3, 3)))
    keep = np.zeros(n + 1, dtype=bool)
    keep[np.unique(lab[core & mask])] = True
    keep[0] = False
    mask = ndi.binary_fill_holes(keep[lab])
    lab, n = ndi.label(mask, structure=np.ones((3, 3)))
    if n:
        area = ndi.sum(np.ones(mask.shape), lab, np.arange(1, n + 1))
        mask = np.concatenate([[False], area >= MIN_AREA])[lab]
    return mask


# --- skeleton ----------------------------------------------------------------------------------

def _neighbours(s):
    """P2..P9 of Zhang-Suen (N, NE, E, SE, S, SW, W, NW) as arrays."""
    p = np.pad(s, 1)
    h, w = s.shape
    at = lambda dr, dc: p[1 + dr:1 + dr + h, 1 + dc:1 + dc + w]  # noqa: E731
    return [at(-1, 0), at(-1, 1), at(0, 1), at(1, 1), at(1, 0), at(1, -1), at(0, -1), at(-1, -1)]


def skeleton(mask):
    """Zhang-Suen thinning, then the staircase pixels (a 4-corner whose neighbours stay one
    8-connected piece without it) removed, so that a one-pixel line has two neighbours per
    pixel and only branch points have three or more."""
    s = mask.astype(np.uint8).copy()
    while True:
        changed = False
        for step in (0, 1):
            n = _neighbours(s)
            b = sum(x.astype(np.int32) for x in n)
            seq = n + [n[0]]
            a = sum(((seq[i] == 0) & (seq[i + 1] == 1)).astype(np.int32) for i in range(8))
            p2, p3, p4, p5, p6, p7, p8, p9 = n
            if step == 0:
                c = (p2 * p4 * p6 == 0) & (p4 * p6 * p8 == 0)
            else:
                c = (p2 * p4 * p8 == 0) & (p2 * p6 * p8 == 0)
            kill = (s == 1) & (b >= 2) & (b <= 6) & (a == 1) & c
            if kill.any():
                s[kill] = 0
                changed = True
        if not changed:
            break
    sk = s.astype(bool)
    n = _neighbours(sk)
    corner = (n[0] & n[2]) | (n[2] & n[4]) | (n[4] & n[6]) | (n[6] & n[0])
    offs = [(-1, 0), (-1, 1), (0, 1), (1, 1), (1, 0), (1, -1), (0, -1), (-1, -1)]
    h, w = sk.shape
    for r, c in zip(*np.nonzero(sk & corner)):
        nb = [(r + dr, c + dc) for dr, dc in offs
              if 0 <= r + dr < h and 0 <= c + dc < w and sk[r + dr, c + dc]]
        if len(nb) < 2:
            continue
        # one 8-connected piece among the neighbours?
        seen, todo = {nb[0]}, [nb[0]]
        while todo:
            pr, pc = todo.pop()
            for q in nb:
                if q not in seen and abs(q[0] - pr) <= 1 and abs(q[1] - pc) <= 1:
                    seen.add(q)
                    todo.append(q)
        if len(seen) == len(nb):
            sk[r, c] = False
    return sk


def branches(sk, min_length):
    """Lengths (px) of the skeleton's branches: the pieces left when the branch points (three
    or more neighbours) are taken out; those of at least min_length px."""
    n = sum(x.astype(np.int32) for x in _neighbours(sk))
    lab, count = ndi.label(sk & (n < 3), structure=np.ones((3, 3)))
    if count == 0:
        return []
    lengths = ndi.sum(np.ones(sk.shape), lab, np.arange(1, count + 1))
    return sorted(int(x) for x in lengths if x >= min_length)


# --- statistics --------------------------------------------------------------------------------

def _noise_gain(sigma):
    """Variance gain of (identity - Gaussian(sigma)) on white noise."""
    d = np.zeros((33, 33))
    d[16, 16] = 1.0
    k = d - ndi.gaussian_filter(d, sigma, mode="constant")
    return float((k ** 2).sum())


def _tiles(ok, size):
    """Top-left corners of the size x size tiles lying wholly in `ok`."""
    h, w = ok.shape
    out = []
    for r in range(0, h - size + 1, size):
        for c in range(0, w - size + 1, size):
            if ok[r:r + size, c:c + size].all():
                out.append((r, c))
    return out


def noise_sigma(img, background):
    """Median over the flattest half of the background tiles of 1.4826 * MAD of the high-pass
    residual img - G(NOISE_SMOOTH) * img, divided by the square root of that filter's noise
    gain (so white noise of sigma s gives s). None without a background tile."""
    resid = img - ndi.gaussian_filter(img, NOISE_SMOOTH)
    gain = math.sqrt(_noise_gain(NOISE_SMOOTH))
    smooth = ndi.gaussian_filter(img, 2.0)
    tiles = _tiles(background, NOISE_TILE)
    if not tiles:
        return None, 0
    flat, sig = [], []
    for r, c in tiles:
        t = resid[r:r + NOISE_TILE, c:c + NOISE_TILE]
        sig.append(1.4826 * float(np.median(np.abs(t - np.median(t)))) / gain)
        flat.append(float(smooth[r:r + NOISE_TILE, c:c + NOISE_TILE].std()))
    order = np.argsort(flat)
    keep = order[:max(1, (len(order) + 1) // 2)]
    return float(np.median(np.array(sig)[keep])), len(tiles)


def nps_slope(img, background, size=NPS_PATCH, band=NPS_BAND):
    """Slope of log NPS against log frequency over `band` (cycles/px): the NPS is the mean
    |FFT|^2 of the background patches (each with its best plane removed, Hann-windowed),
    averaged over rings of radial frequency. White noise gives 0; smooth structure a steep
    negative slope. None without a background patch."""
    tiles = _tiles(background, size)
    if not tiles:
        return None
    yy, xx = np.mgrid[0:size, 0:size].astype(np.float64)
    design = np.stack([np.ones(size * size), yy.ravel(), xx.ravel()], axis=1)
    win = np.outer(np.hanning(size), np.hanning(size))
    acc = np.zeros((size, size))
    for r, c in tiles:
        p = img[r:r + size, c:c + size].ravel()
        coef, *_ = np.linalg.lstsq(design, p, rcond=None)
        p = (p - design @ coef).reshape(size, size) * win
        acc += np.abs(np.fft.fft2(p)) ** 2
    acc /= len(tiles) * (win ** 2).sum()
    f = np.fft.fftfreq(size)
    fr = np.hypot(*np.meshgrid(f, f, indexing="ij"))
    edges = np.linspace(band[0], band[1], 12)
    fx, py = [], []
    for lo, hi in zip(edges[:-1], edges[1:]):
        sel = (fr >= lo) & (fr < hi)
        if sel.any() and acc[sel].mean() > 0:
            fx.append(math.log(fr[sel].mean()))
            py.append(math.log(acc[sel].mean()))
    if len(fx) < 3:
        return None
    return float(np.polyfit(fx, py, 1)[0])


def measure(img, mask=None, min_branch=15, bits=8):
    """All the statistics of one image (dict), plus the arrays the figure draws."""
    h, w = img.shape
    rect, full = exposed_field(img)
    field = rect_mask(img.shape, rect)
    inside = rect_mask(img.shape, full, MARGIN)
    if inside.sum() < 64 * 64:
        inside = field
    source = "given" if mask is not None else "segmented"
    if mask is None:
        mask = segment(img, inside)
    mask = mask & field
    sk = skeleton(mask) & inside
    out = {"size": [w, h], "bits": bits, "mask": source,
           "field": float(field.sum()) / (h * w),
           "field_rect": {"top": rect[0], "bottom": rect[1], "left": rect[2], "right": rect[3]},
           "vessel_fraction": float(mask[inside].mean())}
    dist_out = ndi.distance_transform_edt(~mask)
    ring = inside & ~mask & (dist_out > RING[0]) & (dist_out <= RING[1])
    # local: each centreline pixel against the ring pixels within RING_WINDOW px of it
    rw = ring.astype(np.float64)
    num = ndi.uniform_filter(img * rw, RING_WINDOW)
    den = ndi.uniform_filter(rw, RING_WINDOW)
    on = sk & (den > 0.02)
    if on.any():
        local_bg = num[on] / den[on]
        out["contrast"] = float(np.median(local_bg - img[on]))
        out["contrast_global"] = float(np.median(img[ring]) - np.median(img[on]))
    else:
        out["contrast"] = out["contrast_global"] = None
    background = inside & (dist_out > RING[0])
    sigma, ntiles = noise_sigma(img, background)
    out["noise"] = sigma
    out["noise_tiles"] = ntiles
    if out["contrast"] is not None and sigma:
        out["cnr"] = out["contrast"] / sigma
    else:
        out["cnr"] = None
    out["nps_slope"] = nps_slope(img, background)
    wgt = background.astype(np.float64)
    num = ndi.gaussian_filter(img * wgt, LOWPASS)
    den = ndi.gaussian_filter(wgt, LOWPASS)
    ok = background & (den > 0.2)
    if ok.any():
        low = num[ok] / den[ok]
        out["bg_lowpass"] = float(low.std() / np.median(img[ok]))
    else:
        out["bg_lowpass"] = None
    for p, v in zip(PERCENTILES, np.percentile(img[inside], PERCENTILES)):
        out[f"p{p}"] = float(v)
    if sk.any():
        d_in = ndi.distance_transform_edt(mask)
        out["width"] = float(np.median(2 * d_in[sk] - 1))
    else:
        out["width"] = None
    lengths = branches(sk, min_branch)
    out["branches"] = len(lengths)
    out["min_branch"] = min_branch
    return out, {"mask": mask, "skeleton": sk, "field": field}


# --- output ------------------------------------------------------------------------------------

FMT = {"field": "{:.2f}", "contrast": "{:.3f}", "noise": "{:.4f}", "cnr": "{:.1f}",
       "nps_slope": "{:.2f}", "bg_lowpass": "{:.3f}", "p1": "{:.2f}", "p5": "{:.2f}",
       "p50": "{:.2f}", "p95": "{:.2f}", "p99": "{:.2f}", "width": "{:.1f}",
       "branches": "{:d}"}
HEAD = {"field": "field", "contrast": "contrast", "noise": "noise σ", "cnr": "CNR",
        "nps_slope": "NPS slope", "bg_lowpass": "bg low-pass", "p1": "p1", "p5": "p5",
        "p50": "p50", "p95": "p95", "p99": "p99", "width": "width px",
        "branches": "branches"}


def fmt(key, v):
    if v is None:
        return "-"
    if key == "branches":
        return str(int(round(v)))
    return FMT[key].format(v)


def label_of(path):
    """A short name: the last two path parts (sample2/projection0/frame_20.jpg ->
    projection0/frame_20.jpg), or patient/view for gimm-dataset's views."""
    parts = os.path.normpath(path).split(os.sep)
    if len(parts) >= 3 and parts[-2] == "views":  # gimm-dataset: <patient>/views/<view>.png
        return parts[-3] + "/" + parts[-1]
    return "/".join(parts[-2:])


def summary(results, kind):
    rows = [r for r in results if r["kind"] == kind]
    out = {}
    for k in STAT_KEYS:
        vals = [r["stats"][k] for r in rows if r["stats"][k] is not None]
        out[k] = (float(np.median(vals)), float(min(vals)), float(max(vals))) if vals else None
    return out


def write_table(results, path, command):
    lines = ["<!-- written by tools/realism/realism.py -->", "",
             "| image | kind | " + " | ".join(HEAD[k] for k in STAT_KEYS) + " |",
             "| --- | --- | " + " | ".join("---:" for _ in STAT_KEYS) + " |"]
    for r in results:
        given = " (mask)" if r["stats"]["mask"] == "given" else ""
        lines.append(f"| {r['label']} | {r['kind']}{given} | "
                     + " | ".join(fmt(k, r["stats"][k]) for k in STAT_KEYS) + " |")
    kinds = [k for k in ("real", "synthetic") if any(r["kind"] == k for r in results)]
    sums = {k: summary(results, k) for k in kinds}
    lines += ["", "| statistic | " + " | ".join(f"{k}: median (min - max)" for k in kinds) + " |",
              "| --- | " + " | ".join("---" for _ in kinds) + " |"]
    for key in STAT_KEYS:
        cells = []
        for k in kinds:
            s = sums[k][key]
            cells.append("-" if s is None else
                         f"{fmt(key, s[0])} ({fmt(key, s[1])} - {fmt(key, s[2])})")
        lines.append(f"| {HEAD[key]} | " + " | ".join(cells) + " |")
    lines += ["", f"Command: `{command}`", ""]
    with open(path, "w") as f:
        f.write("\n".join(lines))


def write_figure(results, images, extras, path, overlay):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    kinds = [k for k in ("real", "synthetic") if any(r["kind"] == k for r in results)]
    ncols = max(sum(r["kind"] == k for r in results) for k in kinds)
    ncols = min(ncols, 4)
    rows_per = {k: -(-sum(r["kind"] == k for r in results) // ncols) for k in kinds}
    nrows = sum(rows_per.values())
    fig, axes = plt.subplots(nrows, ncols, figsize=(2.6 * ncols, 3.2 * nrows), squeeze=False)
    for ax in axes.ravel():
        ax.axis("off")
    row0 = 0
    for k in kinds:
        idx = [i for i, r in enumerate(results) if r["kind"] == k]
        for j, i in enumerate(idx):
            ax = axes[row0 + j // ncols, j % ncols]
            img = images[i]
            step = max(1, img.shape[0] // 256)
            show = img[::step, ::step]
            if overlay:
                rgb = np.repeat(show[..., None], 3, axis=2)
                sk = ndi.binary_dilation(extras[i]["skeleton"])[::step, ::step]
                rgb[sk] = (1.0, 0.35, 0.0)
                ax.imshow(rgb, interpolation="nearest")
            else:
                ax.imshow(show, cmap="gray", vmin=0, vmax=1, interpolation="nearest")
            s = results[i]["stats"]
            ax.set_title(f"{k}: {results[i]['label']}\n"
                         f"contrast {fmt('contrast', s['contrast'])}  σ {fmt('noise', s['noise'])}"
                         f"  CNR {fmt('cnr', s['cnr'])}\n"
                         f"NPS {fmt('nps_slope', s['nps_slope'])}"
                         f"  bg {fmt('bg_lowpass', s['bg_lowpass'])}"
                         f"  w {fmt('width', s['width'])}  br {fmt('branches', s['branches'])}",
                         fontsize=6.5)
        row0 += rows_per[k]
    fig.tight_layout(pad=0.6, h_pad=1.2)
    buf = io.BytesIO()
    fig.savefig(buf, dpi=110, format="png")
    plt.close(fig)
    buf.seek(0)
    im = Image.open(buf).convert("RGB")
    # a palette keeps a grey photo grid small in the docs
    im.quantize(colors=128, method=Image.Quantize.MEDIANCUT).save(path, optimize=True)


# --- command line ------------------------------------------------------------------------------

def parse(argv):
    ap = argparse.ArgumentParser(
        prog="realism.py", description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--real", nargs="+", default=[], metavar="FILE", help="real frames")
    ap.add_argument("--synthetic", nargs="+", default=[], metavar="FILE",
                    help="synthetic views (gimm DRRs)")
    ap.add_argument("--real-masks", nargs="+", metavar="MASK",
                    help="vessel masks of the real frames, in their order, or 'auto'")
    ap.add_argument("--synthetic-masks", nargs="+", metavar="MASK",
                    help="vessel masks of the synthetic views, in their order, or 'auto' "
                         "(<view>.mask.png beside <view>.png)")
    ap.add_argument("--min-branch", type=int, default=15,
                    help="shortest skeleton branch counted (px, default 15)")
    ap.add_argument("--table", help="Markdown table to write")
    ap.add_argument("--json", help="JSON to write")
    ap.add_argument("--figure", help="side-by-side PNG to write")
    ap.add_argument("--overlay", action="store_true",
                    help="draw the measured centrelines on the figure")
    args = ap.parse_args(argv)
    if not args.real and not args.synthetic:
        ap.error("give images: --real FILES... and/or --synthetic FILES...")
    if args.min_branch < 1:
        ap.error("--min-branch must be at least 1")
    for name in ("real", "synthetic"):
        masks = getattr(args, f"{name}_masks")
        files = getattr(args, name)
        if masks is None:
            continue
        if masks == ["auto"]:
            setattr(args, f"{name}_masks", [auto_mask_path(f) for f in files])
        elif len(masks) != len(files):
            ap.error(f"--{name}-masks: {len(masks)} masks for {len(files)} --{name} images")
    return args


def main(argv=None):
    args = parse(argv)
    todo = [("real", f, m) for f, m in zip(args.real, args.real_masks or [None] * len(args.real))]
    todo += [("synthetic", f, m) for f, m in
             zip(args.synthetic, args.synthetic_masks or [None] * len(args.synthetic))]
    try:
        loaded = []
        for kind, f, m in todo:  # every file checked before any work
            img, bits = load_image(f)
            loaded.append((img, bits, load_mask(m, img.shape) if m else None))
    except UsageError as e:
        print(f"realism.py: {e}", file=sys.stderr)
        return 2
    results, images, extras = [], [], []
    for (kind, f, m), (img, bits, mask) in zip(todo, loaded):
        stats, extra = measure(img, mask, args.min_branch, bits)
        results.append({"kind": kind, "file": os.path.abspath(f), "label": label_of(f),
                        "mask_file": os.path.abspath(m) if m else None, "stats": stats})
        images.append(img)
        extras.append(extra)
        s = stats
        print(f"{kind:9s} {label_of(f)}: " + ", ".join(
            f"{k} {fmt(k, s[k])}" for k in STAT_KEYS), flush=True)
    command = "tools/realism/realism.py " + " ".join(sys.argv[1:] if argv is None else argv)
    if args.json:
        kinds = sorted({r["kind"] for r in results})
        with open(args.json, "w") as f:
            json.dump({"format": "gimm-realism/1", "images": results,
                       "summary": {k: {key: (None if v is None else
                                             {"median": v[0], "min": v[1], "max": v[2]})
                                       for key, v in summary(results, k).items()}
                                   for k in kinds}},
                      f, indent=1)
            f.write("\n")
    if args.table:
        write_table(results, args.table, command)
    if args.figure:
        write_figure(results, images, extras, args.figure, args.overlay)
    return 0


if __name__ == "__main__":
    sys.exit(main())
