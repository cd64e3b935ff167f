#!/usr/bin/env python3
"""Regenerates the PyTorch <-> C++ parity fixture of the matcher (tests/data/nn/).

    /usr/bin/python3 tools/train/make_parity_fixture.py [--out tests/data/nn]
    /usr/bin/python3 tools/train/make_parity_fixture.py --shipped weights/W.safetensors \
        DATASET/patients/phantom-0000/pairs/LCA_00-03.json

Writes parity_weights.safetensors (a small model with random weights, random batch-norm
statistics and random layer norms, config in __metadata__) and parity_expected.safetensors
(the two input images and what PyTorch computes: the dual-softmax matrix, the coarse matches,
their fine points). tests/nn/matcher_parity_test.cpp checks the C++ engine against it.
The images are 64 x 96 (not square, so a swapped axis fails) and the threshold is set between
the mutual-nearest confidences, so it removes some of them.
"""
import argparse
import json
import os
import sys

import numpy as np
import torch

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gimm_model import DEFAULT_CONFIG, GimmMatcher, config_metadata, fold_free_state_dict  # noqa: E402
from safetensors_io import save_file  # noqa: E402

CLASSES = (3, 7)


def randomise(model, gen):
    with torch.no_grad():
        for name, module in model.named_modules():
            if isinstance(module, (torch.nn.BatchNorm2d, torch.nn.LayerNorm)):
                module.weight.copy_(torch.rand(module.weight.shape, generator=gen) + 0.5)
                module.bias.copy_(torch.randn(module.bias.shape, generator=gen) * 0.1)
            if isinstance(module, torch.nn.BatchNorm2d):
                module.running_mean.copy_(torch.randn(module.running_mean.shape, generator=gen) * 0.1)
                module.running_var.copy_(torch.rand(module.running_var.shape, generator=gen) + 0.5)
            if isinstance(module, torch.nn.Embedding):
                module.weight.copy_(torch.randn(module.weight.shape, generator=gen))
        # An untrained FiLM adds one large beta to every token, so one cell wins every row and
        # mutual matching keeps a single pair; a tenth of it still tests the conditioning.
        model.film.mlp[2].weight.mul_(0.1)
        model.film.mlp[2].bias.mul_(0.1)


def smooth_image(gen, h, w):
    noise = torch.rand(1, 1, h // 4, w // 4, generator=gen)
    return torch.nn.functional.interpolate(noise, size=(h, w), mode="bilinear", align_corners=False)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=os.path.join(os.path.dirname(__file__), "..", "..", "tests", "data", "nn"))
    parser.add_argument("--shipped", nargs=2, metavar=("WEIGHTS", "PAIR_JSON"),
                        help="write only shipped_expected: WEIGHTS run on a dataset pair file")
    args = parser.parse_args()
    if args.shipped:
        write_shipped_fixture(args.out, *args.shipped)
        return
    write_fixture(args.out, "parity", anchor=False)
    write_fixture(args.out, "parity_anchor", anchor=True)


def write_fixture(folder, prefix, anchor):
    """prefix_weights / prefix_expected; anchor: the A-side refinement (gimm_model.py)."""
    gen = torch.Generator().manual_seed(20261123)
    torch.manual_seed(20261123)
    cfg = dict(DEFAULT_CONFIG, widths=[8, 16, 32], coarse_heads=4, fine_heads=2, threshold=0.0,
               anchor=anchor)
    model = GimmMatcher(cfg).eval()
    randomise(model, gen)

    h, w = 64, 96
    image0 = smooth_image(gen, h, w)
    image1 = torch.roll(image0, shifts=(8, 16), dims=(2, 3)) + 0.02 * torch.rand(1, 1, h, w, generator=gen)
    with torch.no_grad():
        probe = model(image0, image1, *CLASSES)
        confs = probe["mconf"].sort().values
        if len(confs) < 8:
            raise SystemExit(f"parity fixture: only {len(confs)} mutual matches; change the seed")
        # A threshold half way between two neighbouring confidences near the lower quarter.
        k = len(confs) // 4
        model.cfg["threshold"] = float((confs[k - 1] + confs[k]) / 2)
        out = model(image0, image1, *CLASSES)

    os.makedirs(folder, exist_ok=True)
    # Without the anchor, the config is written as before the key existed: the loader's
    # backward default is tested by the same file.
    written = {k: v for k, v in model.cfg.items() if k != "anchor" or anchor}
    save_file(os.path.join(folder, f"{prefix}_weights.safetensors"), fold_free_state_dict(model),
              config_metadata(written))
    expected = {
        "image0": image0[0, 0], "image1": image1[0, 0], "confidence": out["conf"],
        "i_ids": out["i_ids"].float(), "j_ids": out["j_ids"].float(), "mconf": out["mconf"],
        "points0": out["points0"], "points1": out["points1"],
    }
    save_file(os.path.join(folder, f"{prefix}_expected.safetensors"),
              {k: v.detach().float().contiguous().numpy() for k, v in expected.items()},
              {"class0": str(CLASSES[0]), "class1": str(CLASSES[1]),
               "matches": str(len(out["i_ids"])), "probe_matches": str(len(confs))})
    print(f"parity fixture: {len(out['i_ids'])} of {len(confs)} mutual matches kept "
          f"(threshold {model.cfg['threshold']:.6f}); {prefix}_* written to {os.path.normpath(folder)}")


def write_shipped_fixture(folder, weights, pair_file):
    """shipped_expected: what PyTorch computes with the shipped weights on one real view pair
    (a phantom pair at the weights' input size), for the C++ engine to reproduce."""
    from export import load_model
    from gimm_data import PairSample
    model = load_model(weights)
    sample = PairSample(pair_file, model.cfg.get("input_size", 0), {})
    image0 = sample.image_a.float()[None, None]
    image1 = sample.image_b.float()[None, None]
    with torch.no_grad():
        out = model(image0, image1, sample.class_a, sample.class_b)
    expected = {
        "image0": image0[0, 0], "image1": image1[0, 0], "confidence": out["conf"],
        "i_ids": out["i_ids"].float(), "j_ids": out["j_ids"].float(), "mconf": out["mconf"],
        "points0": out["points0"], "points1": out["points1"],
    }
    save_file(os.path.join(folder, "shipped_expected.safetensors"),
              {k: v.detach().float().contiguous().numpy() for k, v in expected.items()},
              {"class0": str(sample.class_a), "class1": str(sample.class_b),
               "matches": str(len(out["i_ids"])), "pair": os.path.basename(pair_file)})
    print(f"parity fixture: shipped weights, {len(out['i_ids'])} matches on "
          f"{os.path.basename(pair_file)}; shipped_expected written to {os.path.normpath(folder)}")


if __name__ == "__main__":
    main()
