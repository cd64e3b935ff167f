"""Reading a gimm-dataset folder for training: pairs by split, images, masks, dense labels.

The layout is gimm's (docs/dataset.md): splits/<split>.txt lists patient ids;
patients/<id>/pairs/<A>-<B>.json holds a pair's labels; patients/<id>/views/<name>.png is the
16-bit angiogram and <name>.mask.png its vessel mask. Dense label columns are looked up by name
in the pair's `dense_fields`, never by position.

Images go to the network as gimm-match feeds them (pipeline/matching.hpp): 16-bit PNG / 65535,
resized bilinearly with pixel centres aligned (PyTorch's align_corners=False) so that the longer
side is `size`; a point maps as u_net = (u + 0.5) / scale - 0.5.
"""
import json
import os

import numpy as np
import torch
import torch.nn.functional as F
from PIL import Image

DENSE_COLUMNS = ("u_a", "v_a", "u_b", "v_b", "x_mm", "y_mm", "z_mm")


class DatasetError(ValueError):
    pass


def read_split(root, split):
    path = os.path.join(root, "splits", f"{split}.txt")
    if not os.path.isfile(path):
        raise DatasetError(f"{root}: no splits/{split}.txt (is it a gimm-dataset folder?)")
    with open(path) as f:
        return [line.strip() for line in f if line.strip()]


def pair_files(root, patients):
    out = []
    for pid in patients:
        folder = os.path.join(root, "patients", pid, "pairs")
        if not os.path.isdir(folder):
            raise DatasetError(f"{root}: patient '{pid}' has no pairs/ folder")
        out += [os.path.join(folder, n) for n in sorted(os.listdir(folder)) if n.endswith(".json")]
    return out


def dense_columns(pair, path):
    fields = pair.get("dense_fields")
    if not isinstance(fields, list):
        raise DatasetError(f"{path}: no dense_fields list")
    missing = [c for c in DENSE_COLUMNS if c not in fields]
    if missing:
        raise DatasetError(f"{path}: dense_fields lacks {missing}")
    dense = np.asarray(pair["dense"], dtype=np.float64).reshape(-1, len(fields))
    return {c: dense[:, fields.index(c)] for c in DENSE_COLUMNS}


def read_png_unit(path):
    """A gimm 16-bit (or 8-bit) grey PNG as float32 in [0, 1]."""
    image = Image.open(path)
    array = np.asarray(image)
    if array.ndim != 2:
        raise DatasetError(f"{path}: expected a grey image, got shape {array.shape}")
    top = 65535.0 if array.dtype == np.uint16 or image.mode.startswith("I") else 255.0
    return (array.astype(np.float32) / top).astype(np.float32)


def resize_for_network(image, size):
    """[H, W] float -> [h, w] with the longer side `size`, and the image pixels per net pixel."""
    h, w = image.shape
    if size <= 0 or max(h, w) == size:
        return torch.from_numpy(image), 1.0, 1.0
    scale = size / max(h, w)
    rows, cols = max(1, round(h * scale)), max(1, round(w * scale))
    out = F.interpolate(torch.from_numpy(image)[None, None], size=(rows, cols), mode="bilinear",
                        align_corners=False)[0, 0]
    return out, w / cols, h / rows


def network_image(image, kind):
    """What the network sees of `image` ([h, w] tensor at network size): itself for
    'intensity'; for 'vesselness' gimm's own enhancement (include/gimm/match/network_input.hpp,
    through the gimm module, so that training and gimm-match compute the same thing)."""
    if kind == "intensity":
        return image
    import gimm  # needed for this input only
    return torch.from_numpy(gimm.network_image(image.float().numpy(), kind))


class PairSample:
    """One view pair at network resolution: images, masks, classes and dense labels."""

    def __init__(self, path, size, view_cache, images="rendered"):
        with open(path) as f:
            pair = json.load(f)
        cols = dense_columns(pair, path)
        views = os.path.join(os.path.dirname(os.path.dirname(path)), "views")
        self.path = path
        self.class_a, self.class_b = int(pair["view_class_a"]), int(pair["view_class_b"])
        suffix = IMAGE_SUFFIXES[images]
        self.image_a, self.mask_a, su, sv = self._view(views, pair["view_a"], size, view_cache,
                                                       suffix)
        self.image_b, self.mask_b, _, _ = self._view(views, pair["view_b"], size, view_cache,
                                                     suffix)
        self.scale = (su, sv)  # image pixels per network pixel
        net = lambda u, s: (u + 0.5) / s - 0.5  # noqa: E731
        self.a = np.stack([net(cols["u_a"], su), net(cols["v_a"], sv)], 1).astype(np.float32)
        self.b = np.stack([net(cols["u_b"], su), net(cols["v_b"], sv)], 1).astype(np.float32)
        self.a_full = np.stack([cols["u_a"], cols["v_a"]], 1)  # image pixels, for validation
        self.b_full = np.stack([cols["u_b"], cols["v_b"]], 1)
        self.world = np.stack([cols["x_mm"], cols["y_mm"], cols["z_mm"]], 1)

    @staticmethod
    def _view(views, name, size, cache, suffix=".png"):
        key = (views, name)
        if key not in cache:
            path = os.path.join(views, name + suffix)
            if not os.path.isfile(path):
                raise DatasetError(f"{path}: no such image (formed images need gimm-dataset "
                                   "--formation)" if suffix != ".png" else f"{path}: no such image")
            image = read_png_unit(path)
            mask = np.asarray(Image.open(os.path.join(views, name + ".mask.png"))) > 0
            net, su, sv = resize_for_network(image, size)
            cache[key] = (net.half(), mask, su, sv)  # half: 1000s of views stay in memory
        return cache[key]


# Which image of a view the network sees: the render (<view>.png) or the view as a C-arm forms
# it (<view>.formed.png: iodine, scatter, noise, blur, processing, shutters; --formation).
IMAGE_SUFFIXES = {"rendered": ".png", "formed": ".formed.png"}


def dataset_images(root):
    """The images every view of the dataset at `root` has ("drr", and "formed" and "field" where
    a formation stage ran): a gimm-dataset/2 manifest lists them, a /1 manifest's parameters
    hold a "formation" record (include/gimm/dataset/reader.hpp, dataset_images_of)."""
    path = os.path.join(root, "manifest.json")
    try:
        with open(path) as f:
            manifest = json.load(f)
    except (OSError, ValueError) as e:
        raise DatasetError(f"{path}: cannot read the manifest ({e})") from e
    if manifest.get("format") == "gimm-dataset/1":
        return ["drr", "formed", "field"] if "formation" in manifest.get("parameters", {}) else ["drr"]
    if manifest.get("format") != "gimm-dataset/2" or not isinstance(manifest.get("images"), list):
        raise DatasetError(f"{path}: format {manifest.get('format')!r} with images "
                           f"{manifest.get('images')!r} is no gimm-dataset/1 or /2 manifest")
    return manifest["images"]


def resolve_images(root, images):
    """'auto' -> 'formed' where the dataset has formed views, else 'rendered'."""
    if images != "auto":
        return images
    return "formed" if "formed" in dataset_images(root) else "rendered"


def load_pairs(root, split, size, limit=None, progress=True, images="rendered"):
    images = resolve_images(root, images)
    if images not in IMAGE_SUFFIXES:
        raise DatasetError(f"images must be one of {sorted(IMAGE_SUFFIXES)}, got {images!r}")
    files = pair_files(root, read_split(root, split))
    if limit:
        files = files[:limit]
    cache, out = {}, []
    for n, path in enumerate(files):
        out.append(PairSample(path, size, cache, images))
        if progress and (n + 1) % 500 == 0:
            print(f"data: {split} {n + 1}/{len(files)} pairs", flush=True)
    return out
