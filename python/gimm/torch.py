"""PyTorch data from gimm (optional: needs PyTorch). Training pairs rendered on the fly, as dicts
of tensors that torch.utils.data.DataLoader batches with `collate_pairs`:

    from torch.utils.data import DataLoader
    from gimm.torch import RenderedPairs, collate_pairs
    pairs = RenderedPairs(range(100), size=256, rows=512, cols=512, pixel_mm=0.3, seed=0)
    loader = DataLoader(pairs, batch_size=4, num_workers=2, collate_fn=collate_pairs)
    batch = next(iter(loader))   # batch["image_a"]: [4, 1, 256, 256], batch["points_a"]: 4 tensors

A patient is a phantom seed (gimm.make_phantom, as `gimm-dataset --phantom` makes them) or a
(ct_path, label_path) pair of volume files. Per visit, as gimm-dataset does for one patient
(view mode "shared"): the label is split into LCA and RCA; per system the centerlines are
extracted from the mask, a renderer is prepared with the system's lumen, one view per routine
view class is sampled (gimm.sample_view: the class's angle ranges with 5 deg jitter), rendered
and min-max scaled to 16 bits like the dataset's PNGs, resized so the longer side is `size`,
and every pair of the system's views is labelled (gimm.label_pair: the dataset's dense labels).
A visit's pairs come out in random order.

One sample (a dict):
    image_a, image_b   float32 [1, h, w] in [0, 1] (the network's input)
    mask_a, mask_b     bool [h0, w0] vessel masks at the detector's size
    class_a, class_b   int64 [] view classes (1..11)
    points_a, points_b float32 [N, 2] dense labels in network pixels, u_net = (u + 0.5) / s - 0.5
    points_a_full, points_b_full  float64 [N, 2] the same at the detector's pixels
    world_mm           float64 [N, 3]
    scale              float64 [2] detector pixels per network pixel (u, v)
    name               str "<patient>/<system>_<class a>-<class b>"
`collate_pairs` stacks what has one size per batch (images, classes, scale; masks when their
sizes agree) and keeps the rest (labels, names) as lists.

Determinism and workers: with the same `seed` and worker count the same samples come out in the
same order; each DataLoader worker draws from its own stream (seed, worker id), so workers
never repeat each other's views.
"""
import os

import numpy as np
import torch
import torch.nn.functional as F

from . import _gimm as gimm

__all__ = ["RenderedPairs", "collate_pairs", "render_patient", "resize_for_network"]


def resize_for_network(image, size):
    """[H, W] float32 numpy -> ([h, w] tensor with the longer side `size`, u scale, v scale):
    bilinear with pixel centres aligned (align_corners=False), as gimm-match resizes."""
    h, w = image.shape
    if size <= 0 or max(h, w) == size:
        return torch.from_numpy(image), 1.0, 1.0
    scale = size / max(h, w)
    rows, cols = max(1, round(h * scale)), max(1, round(w * scale))
    out = F.interpolate(torch.from_numpy(image)[None, None], size=(rows, cols), mode="bilinear",
                        align_corners=False)[0, 0]
    return out, w / cols, h / rows


def as_dataset_image(intensity):
    """Intensity -> what the dataset's 16-bit PNG reads back as: min-max scaled to 0..65535,
    rounded, / 65535 (render/drr.hpp to_uint16_min_max)."""
    lo, hi = float(intensity.min()), float(intensity.max())
    scale = 65535.0 / (hi - lo) if hi > lo else 0.0
    return (np.rint((intensity - lo) * scale) / 65535.0).astype(np.float32)


def patient_volumes(source):
    """(hu, label, geometry, name) of a phantom seed or a (ct_path, label_path) pair."""
    if isinstance(source, (int, np.integer)):
        p = gimm.make_phantom(seed=int(source))
        return p["hu"], p["label"], p["geometry"], f"phantom-seed-{int(source)}"
    ct, label = source
    hu, geometry = gimm.read_volume(ct, "float32")
    mask, mask_geometry = gimm.read_volume(label, "uint8")
    for key in ("spacing", "origin"):
        if not np.allclose(geometry[key], mask_geometry[key]):
            raise gimm.Error(f"gimm: {label}: {key} {mask_geometry[key]} differs from the CT's "
                             f"{geometry[key]} ({ct})")
    if hu.shape != mask.shape:
        raise gimm.Error(f"gimm: {label}: shape {mask.shape} differs from the CT's {hu.shape}")
    return hu, mask, geometry, os.path.basename(str(ct))


def sampled_angles(rng):
    """view_angles for render_patient: each class's angle ranges with 5 deg jitter."""
    return lambda system, view_class: gimm.sample_view(view_class, seed=int(rng.integers(1 << 62)))


def pair_sample(name, a, b, labels):
    """One sample dict (the module docstring) from two rendered views and their labels."""
    (image_a, mask_a, class_a, su, sv), (image_b, mask_b, class_b, _, _) = a, b
    net = lambda u, s: (u + 0.5) / s - 0.5  # noqa: E731  detector -> network pixels
    pa, pb = labels["points_a"], labels["points_b"]
    return {"image_a": image_a[None], "image_b": image_b[None],
            "mask_a": torch.from_numpy(mask_a), "mask_b": torch.from_numpy(mask_b),
            "class_a": torch.tensor(class_a, dtype=torch.int64),
            "class_b": torch.tensor(class_b, dtype=torch.int64),
            "points_a": torch.from_numpy(np.stack([net(pa[:, 0], su), net(pa[:, 1], sv)], 1)
                                         .astype(np.float32)),
            "points_b": torch.from_numpy(np.stack([net(pb[:, 0], su), net(pb[:, 1], sv)], 1)
                                         .astype(np.float32)),
            "points_a_full": torch.from_numpy(np.asarray(pa, dtype=np.float64)),
            "points_b_full": torch.from_numpy(np.asarray(pb, dtype=np.float64)),
            "world_mm": torch.from_numpy(np.asarray(labels["world_mm"], dtype=np.float64)),
            "scale": torch.tensor([su, sv], dtype=torch.float64),
            "name": name}


def render_patient(source, view_angles, size, rows=256, cols=256, pixel_mm=1.0):
    """Every pair of one patient's views, both systems, as sample dicts. view_angles(system,
    view_class) -> (primary_deg, secondary_deg): sampled_angles(rng), or given angles."""
    hu, label, geometry, name = patient_volumes(source)
    systems = gimm.split_coronary_systems(label, geometry, allow_single=True)
    classes = {s: [v["id"] for v in gimm.routine_views() if v["system"] == s]
               for s in ("LCA", "RCA")}
    samples = []
    for system in ("LCA", "RCA"):
        mask = systems[system.lower()]
        if not mask.any():
            continue
        centerlines = gimm.extract_centerlines(mask, geometry, system=system)
        renderer = gimm.Renderer(hu, mask, geometry=geometry)
        isocenter = gimm.vessel_isocenter(mask, geometry)
        carms, views = [], []
        for view_class in classes[system]:
            primary, secondary = view_angles(system, view_class)
            carm = gimm.CArm(primary_deg=primary, secondary_deg=secondary, rows=rows, cols=cols,
                             pixel_mm=pixel_mm, isocenter=isocenter)
            out = renderer.render(carm)
            image, su, sv = resize_for_network(as_dataset_image(out["intensity"]), size)
            carms.append(carm)
            views.append((image, out["vessel_mask"] > 0, view_class, su, sv))
        for i in range(len(views)):
            for j in range(i + 1, len(views)):
                labels = gimm.label_pair(centerlines, carms[i], carms[j], views[i][1],
                                         views[j][1], sparse_count=0)
                samples.append(pair_sample(f"{name}/{system}_{classes[system][i]}-"
                                           f"{classes[system][j]}", views[i], views[j], labels))
    return samples


class RenderedPairs(torch.utils.data.IterableDataset):
    """An endless stream of sample dicts rendered on the fly (see the module's docstring).

    sources: phantom seeds and/or (ct_path, label_path) pairs; size: the network's input side;
    rows, cols, pixel_mm: the detector (gimm-dataset's --rows/--cols/--pixel); seed: the stream
    (an int or a sequence of ints).
    """

    def __init__(self, sources, size=128, rows=256, cols=256, pixel_mm=1.0, seed=0):
        super().__init__()
        sources = list(sources)
        if len(sources) == 0:
            raise ValueError("RenderedPairs: no sources (phantom seeds or (ct, label) paths)")
        if size < 8 or rows < 8 or cols < 8 or not pixel_mm > 0:
            raise ValueError(f"RenderedPairs: bad size {size}, detector {cols} x {rows} or "
                             f"pixel {pixel_mm} mm")
        self.sources, self.size, self.seed = sources, size, seed
        self.rows, self.cols, self.pixel_mm = rows, cols, pixel_mm

    def __iter__(self):
        info = torch.utils.data.get_worker_info()
        worker = info.id if info else 0
        rng = np.random.default_rng([*np.atleast_1d(self.seed).tolist(), worker])
        while True:
            source = self.sources[int(rng.integers(len(self.sources)))]
            samples = render_patient(source, sampled_angles(rng), self.size, self.rows,
                                     self.cols, self.pixel_mm)
            for k in rng.permutation(len(samples)):
                yield samples[k]


STACKED = ("image_a", "image_b", "class_a", "class_b", "scale")


def collate_pairs(samples):
    """DataLoader's collate_fn for sample dicts: images [B, 1, h, w], classes [B], scale [B, 2]
    stacked; masks stacked when every mask of the batch has one size, else lists; the labels
    (points_*, world_mm: one length per pair) and names as lists."""
    if not samples:
        raise ValueError("collate_pairs: an empty batch")
    batch = {}
    for key in samples[0]:
        values = [s[key] for s in samples]
        same_shape = all(isinstance(v, torch.Tensor) and v.shape == values[0].shape
                         for v in values)
        if key in STACKED or (key.startswith("mask_") and same_shape):
            batch[key] = torch.stack(values)
        else:
            batch[key] = values
    return batch
