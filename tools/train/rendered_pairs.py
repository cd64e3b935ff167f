"""Training pairs rendered on the fly with the gimm Python module: an IterableDataset beside the
precomputed-dataset loader (gimm_data.load_pairs), with fresh random views every time a patient
comes round.

A patient is a phantom seed (gimm.make_phantom, as `gimm-dataset --phantom` makes them) or a
(CT, label) pair of volume files. Per visit, as gimm-dataset does for one patient
(pipeline/dataset.hpp, view mode "shared"): the label is split into LCA and RCA; per system its
centerlines are extracted from the mask, a renderer is prepared with the system's lumen, one
view per routine view class is sampled (gimm.sample_view: the class's angle ranges with 5 deg
jitter), rendered and min-max scaled to 16 bits like the dataset's PNGs, and every pair of the
system's views is labelled (gimm.label_pair, the same dense labels as the dataset's pair files).
The pairs come out in random order, as `gimm_data.PairSample`-like objects, so train.py's batch
and ground-truth code takes either source.

Determinism: with the same `seed` (and worker count) the same pairs come out in the same order;
each DataLoader worker draws from its own stream. Cost per pair at 256 px on this machine:
`tools/train/data_throughput.py` and docs/training.md.
"""
import os

import numpy as np
import torch

import gimm
from gimm_data import resize_for_network


class RenderedPair:
    """One pair, with the attributes of gimm_data.PairSample."""

    def __init__(self, name, views, i, j, labels, size):
        self.path = name
        (self.image_a, self.mask_a, self.class_a, su, sv) = views[i]
        (self.image_b, self.mask_b, self.class_b, _, _) = views[j]
        self.scale = (su, sv)
        net = lambda u, s: (u + 0.5) / s - 0.5  # noqa: E731  image -> network pixels
        pa, pb = labels["points_a"], labels["points_b"]
        self.a = np.stack([net(pa[:, 0], su), net(pa[:, 1], sv)], 1).astype(np.float32)
        self.b = np.stack([net(pb[:, 0], su), net(pb[:, 1], sv)], 1).astype(np.float32)
        self.a_full, self.b_full, self.world = pa, pb, labels["world_mm"]


def as_dataset_image(intensity):
    """Intensity -> what gimm_data.read_png_unit gives for the dataset's 16-bit PNG: min-max
    scaled to 0..65535, rounded, / 65535 (render/drr.hpp to_uint16_min_max)."""
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


def render_patient(source, view_angles, size, rows=256, cols=256, pixel_mm=1.0):
    """Every pair of one patient's views, both systems, as RenderedPair. view_angles(system,
    view_class) -> (primary_deg, secondary_deg): sampled_angles(rng), or given angles."""
    hu, label, geometry, name = patient_volumes(source)
    systems = gimm.split_coronary_systems(label, geometry, allow_single=True)
    classes = {s: [v["id"] for v in gimm.routine_views() if v["system"] == s]
               for s in ("LCA", "RCA")}
    pairs = []
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
            views.append((image.half(), out["vessel_mask"] > 0, view_class, su, sv))
        for i in range(len(views)):
            for j in range(i + 1, len(views)):
                labels = gimm.label_pair(centerlines, carms[i], carms[j], views[i][1],
                                         views[j][1], sparse_count=0)
                pairs.append(RenderedPair(f"{name}/{system}_{classes[system][i]}-"
                                          f"{classes[system][j]}", views, i, j, labels, size))
    return pairs


class RenderedPairs(torch.utils.data.IterableDataset):
    """An endless stream of pairs rendered on the fly (see the module's docstring).

    sources: phantom seeds and/or (ct_path, label_path) pairs; size: the network's input side;
    rows, cols, pixel_mm: the detector (gimm-dataset's --rows/--cols/--pixel); seed: the stream
    (an int or a sequence of ints).
    Use with DataLoader(..., batch_size=None, collate_fn=None) or iterate directly.
    """

    def __init__(self, sources, size=128, rows=256, cols=256, pixel_mm=1.0, seed=0):
        super().__init__()
        if len(sources) == 0:
            raise ValueError("RenderedPairs: no sources (phantom seeds or (ct, label) paths)")
        if size < 8 or rows < 8 or cols < 8 or not pixel_mm > 0:
            raise ValueError(f"RenderedPairs: bad size {size}, detector {cols} x {rows} or "
                             f"pixel {pixel_mm} mm")
        self.sources, self.size, self.seed = list(sources), size, seed
        self.rows, self.cols, self.pixel_mm = rows, cols, pixel_mm

    def __iter__(self):
        info = torch.utils.data.get_worker_info()
        worker = info.id if info else 0
        rng = np.random.default_rng([*np.atleast_1d(self.seed).tolist(), worker])
        while True:
            source = self.sources[int(rng.integers(len(self.sources)))]
            pairs = render_patient(source, sampled_angles(rng), self.size, self.rows, self.cols,
                                   self.pixel_mm)
            for k in rng.permutation(len(pairs)):
                yield pairs[k]
