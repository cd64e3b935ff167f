#!/usr/bin/python3
"""Pairs per second of the two training data sources against the training step itself, on
this machine: which one the training recipe should use.

    PYTHONPATH=build/python tools/train/data_throughput.py DATASET [--pairs 200] [--steps 10]
        [--size 128] [--threads 2]

1. precomputed, read: gimm_data.load_pairs over DATASET's train split (JSON labels, 16-bit PNGs,
   resize), what train.py does once at start;
2. precomputed, batch: train.make_batch from the preloaded pairs (augmentation, padding);
3. on the fly: rendered_pairs.RenderedPairs over phantom seeds (phantom, split, centerlines,
   renderer, 11 views rendered at DATASET's detector size, 27 pairs labelled per patient);
4. training step: forward, backward and AdamW of train.py's default model at --size, batch 4.
Prints one line per stage; run nothing else beside it (the figures are ratios of one run).
"""
import argparse
import itertools
import json
import os
import random
import sys
import time

import torch

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gimm_data import load_pairs  # noqa: E402
from rendered_pairs import RenderedPairs  # noqa: E402
import train as T  # noqa: E402


def rate(label, pairs, seconds, note=""):
    print(f"{label:<28} {pairs / seconds:8.1f} pairs/s  ({pairs} pairs in {seconds:.2f} s){note}",
          flush=True)
    return pairs / seconds


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("dataset")
    p.add_argument("--pairs", type=int, default=200)
    p.add_argument("--steps", type=int, default=10)
    p.add_argument("--size", type=int, default=128)
    p.add_argument("--threads", type=int, default=2)
    args = p.parse_args(argv)
    if args.pairs < 8 or args.steps < 2:
        p.error(f"--pairs must be >= 8 and --steps >= 2, got {args.pairs} and {args.steps}")
    torch.set_num_threads(args.threads)
    with open(os.path.join(args.dataset, "manifest.json")) as f:
        manifest = json.load(f)
    carm = manifest["parameters"]["carm"]  # gimm-dataset/1 (docs/dataset.md)
    rows, cols = int(carm["image_size"]["rows"]), int(carm["image_size"]["cols"])
    pixel = float(carm["pixel_mm"])
    print(f"data_throughput: {args.dataset} ({cols} x {rows} px of {pixel} mm), network "
          f"{args.size} px, {torch.get_num_threads()} torch threads", flush=True)

    t = time.time()
    pairs = load_pairs(args.dataset, "train", args.size, args.pairs, progress=False)
    rate("precomputed, read", len(pairs), time.time() - t)

    gen = random.Random(0)
    hc, wc = (pairs[0].image_a.shape[0] + 7) // 8, (pairs[0].image_a.shape[1] + 7) // 8
    truths = {id(s): T.PairTruth(s.a, s.b, hc, wc) for s in pairs}
    t = time.time()
    for k in range(0, len(pairs) - 3, 4):
        T.make_batch(pairs[k:k + 4], truths, gen)
    rate("precomputed, batch", len(pairs) // 4 * 4, time.time() - t)

    stream = RenderedPairs(list(range(1000, 1100)), size=args.size, rows=rows, cols=cols,
                           pixel_mm=pixel, seed=0)
    t = time.time()
    rendered = list(itertools.islice(iter(stream), args.pairs))
    rate("on the fly (render+label)", len(rendered), time.time() - t)

    cfg = dict(T.DEFAULT_CONFIG, widths=[16, 32, 64], coarse_layers=["self", "cross"],
               fine_layers=["self", "cross"], film=True, anchor=True, coarse_heads=4,
               fine_heads=4)
    model = T.GimmMatcher(cfg)
    opt = torch.optim.AdamW(model.parameters(), lr=1e-4)
    model.train()
    batches = [T.make_batch(pairs[k:k + 4], truths, gen) for k in range(0, 4 * args.steps, 4)
               if k + 4 <= len(pairs)]
    steps = 0
    t = None
    for n, batch in enumerate(itertools.islice(itertools.cycle(batches), args.steps + 1)):
        if n == 1:  # the first step allocates: not timed
            t = time.time()
        loss, _ = T.train_step(model, batch, 128)
        opt.zero_grad()
        loss.backward()
        opt.step()
        steps += n >= 1
    rate("training step (batch 4)", 4 * steps, time.time() - t, f"; BLAS {T.blas_in_use()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
