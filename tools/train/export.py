#!/usr/bin/env python3
"""Writes matcher weights (safetensors, config in __metadata__) and, optionally, ONNX models.

    /usr/bin/python3 tools/train/export.py --out W.safetensors [--seed S] [--from W.safetensors]
                                           [--onnx PREFIX --sizes 256 512] [--threshold T]
                                           [--input-size N]

Without --from, the weights are PyTorch's default initialisation from --seed, with FiLM's last
layer scaled by 0.1 (untrained FiLM otherwise adds one large offset to every token). That is
what the benchmarks run until trained weights exist. --onnx writes PREFIX_<size>.onnx per input
size (the sine encoding is traced for one size); inputs image0, image1 [1, 1, S, S] float32 and
classes [2] int64; outputs points0, points1 [M, 2], mconf [M].
"""
import argparse
import json
import os
import sys

import torch

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gimm_model import DEFAULT_CONFIG, GimmMatcher, config_metadata, fold_free_state_dict  # noqa: E402
from safetensors_io import load_file, save_file  # noqa: E402


def load_model(path):
    """GimmMatcher from a gimm safetensors file."""
    tensors, meta = load_file(path)
    if "gimm_config" not in meta:
        raise ValueError(f"{path}: no gimm_config in __metadata__")
    model = GimmMatcher(json.loads(meta["gimm_config"])).eval()
    state = {k: torch.from_numpy(v.copy()) for k, v in tensors.items()}
    missing, unexpected = model.load_state_dict(state, strict=False)
    missing = [k for k in missing if not k.endswith("num_batches_tracked")]
    if missing or unexpected:
        raise ValueError(f"{path}: missing tensors {missing}, unexpected {unexpected}")
    return model


class OnnxWrapper(torch.nn.Module):
    def __init__(self, model):
        super().__init__()
        self.model = model

    def forward(self, image0, image1, classes):
        out = self.model(image0, image1, classes[0], classes[1])
        return out["points0"], out["points1"], out["mconf"]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", help="weights to write (safetensors)")
    parser.add_argument("--from", dest="source", help="start from these weights")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--threshold", type=float, help="override the coarse threshold")
    parser.add_argument("--input-size", type=int,
                        help="record the input size the weights were trained at (gimm-match's "
                             "default --input-size)")
    parser.add_argument("--onnx", help="ONNX output prefix")
    parser.add_argument("--sizes", type=int, nargs="+", default=[256, 512])
    args = parser.parse_args()
    if args.source:
        model = load_model(args.source)
    else:
        torch.manual_seed(args.seed)
        model = GimmMatcher(DEFAULT_CONFIG).eval()
        with torch.no_grad():
            model.film.mlp[2].weight.mul_(0.1)
            model.film.mlp[2].bias.mul_(0.1)
    if args.threshold is not None:
        model.cfg["threshold"] = args.threshold
    if args.input_size is not None:
        model.cfg["input_size"] = args.input_size
    if args.out:
        save_file(args.out, fold_free_state_dict(model), config_metadata(model.cfg))
        params = sum(p.numel() for p in model.parameters())
        print(f"export: {args.out} ({params} parameters, widths {model.cfg['widths']})")
    if args.onnx:
        for size in args.sizes:
            path = f"{args.onnx}_{size}.onnx"
            image = torch.rand(1, 1, size, size)
            torch.onnx.export(OnnxWrapper(model), (image, image.flip(3), torch.tensor([1, 2])), path,
                              input_names=["image0", "image1", "classes"],
                              output_names=["points0", "points1", "mconf"],
                              dynamic_axes={"points0": {0: "m"}, "points1": {0: "m"}, "mconf": {0: "m"}},
                              opset_version=16)
            print(f"export: {path}")


if __name__ == "__main__":
    main()
