"""train.py's on-the-fly source: gimm.torch.RenderedPairs (python/gimm/torch.py: pairs rendered
on the fly from phantom seeds or CT files, fresh views each visit, as gimm-dataset makes them)
with each sample dict turned into the attribute object train.py's batch code takes (the
attributes of gimm_data.PairSample), so train.py takes either source. Needs the gimm module.
"""
import numpy as np

import gimm.torch as gimm_torch


class RenderedPair:
    """One sample dict of gimm.torch with the attributes of gimm_data.PairSample (images in
    float16, as the precomputed pairs are held)."""

    def __init__(self, sample):
        self.path = sample["name"]
        self.image_a, self.image_b = sample["image_a"][0].half(), sample["image_b"][0].half()
        self.mask_a, self.mask_b = sample["mask_a"].numpy(), sample["mask_b"].numpy()
        self.class_a, self.class_b = int(sample["class_a"]), int(sample["class_b"])
        self.scale = tuple(float(s) for s in sample["scale"])
        self.a, self.b = sample["points_a"].numpy(), sample["points_b"].numpy()
        self.a_full = sample["points_a_full"].numpy()
        self.b_full = sample["points_b_full"].numpy()
        self.world = np.asarray(sample["world_mm"].numpy())


def render_patient(source, view_angles, size, rows=256, cols=256, pixel_mm=1.0):
    """gimm.torch.render_patient as RenderedPair objects."""
    return [RenderedPair(s) for s in gimm_torch.render_patient(source, view_angles, size, rows,
                                                                cols, pixel_mm)]


class RenderedPairs(gimm_torch.RenderedPairs):
    """gimm.torch.RenderedPairs as RenderedPair objects (the same stream, seed for seed)."""

    def __iter__(self):
        return map(RenderedPair, super().__iter__())
