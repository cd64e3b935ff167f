#!/usr/bin/env python3
"""Trains the GIMM matcher on a gimm-dataset folder, on CPU or GPU, resumably.

    /usr/bin/python3 tools/train/train.py --dataset DATA --run RUN [--minutes 90] [--resume]

Writes into RUN: checkpoint.pt (every --checkpoint-minutes, and at the end), best.pt and
best.safetensors (the best validation Prec@3px with coverage >= 0.5, else the best coverage),
last.safetensors, log.jsonl (one JSON object per logged step and per validation) and config.json.
--resume continues a run exactly: same step, schedule, data order and random streams.

--device auto (the default) trains on the GPU when PyTorch sees one (CUDA), else on the CPU.
Several processes: launch with torchrun (torchrun --nproc_per_node=N train.py ...), or set
WORLD_SIZE, RANK, LOCAL_RANK, MASTER_ADDR and MASTER_PORT by hand for each process (Debian's
torch 1.13 torchrun fails on Python 3.11); docs/training.md has the commands. The model is
wrapped in DistributedDataParallel (NCCL on GPUs, rank r on GPU LOCAL_RANK; gloo on CPUs): each
rank takes every WORLD_SIZE-th pair of the epoch's order, gradients are averaged in backward,
and ranks decide to stop together.
"""
import argparse
import json
import math
import os
import random
import sys
import time

import numpy as np
import torch
import torch.distributed as dist
import torch.nn.functional as F

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gimm_data import load_pairs, network_image, resolve_images  # noqa: E402
from gimm_model import DEFAULT_CONFIG, NETWORK_INPUTS, GimmMatcher, config_metadata, fold_free_state_dict  # noqa: E402
from safetensors_io import save_file  # noqa: E402
from supervision import PairTruth, fine_losses, fine_targets, focal_loss  # noqa: E402


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--dataset", required=True, help="gimm-dataset folder")
    p.add_argument("--run", required=True, help="run folder (checkpoints, logs, weights)")
    p.add_argument("--resume", action="store_true", help="continue RUN/checkpoint.pt")
    p.add_argument("--init", default="",
                   help="start from the model of this checkpoint.pt (a fine-tune: new schedule, "
                        "new optimizer; the model options must be the checkpoint's)")
    p.add_argument("--minutes", type=float, default=90.0, help="wall-clock budget of this call")
    p.add_argument("--steps", type=int, default=20000, help="schedule length (cosine to 0)")
    p.add_argument("--stop-at", type=int, default=0,
                   help="stop this call at this step (0: at --steps); the schedule is unchanged")
    p.add_argument("--warmup", type=int, default=300)
    p.add_argument("--lr", type=float, default=2e-3)
    p.add_argument("--weight-decay", type=float, default=0.05)
    p.add_argument("--clip", type=float, default=1.0, help="gradient norm clipping")
    p.add_argument("--batch", type=int, default=4, help="pairs per step per rank")
    p.add_argument("--size", type=int, default=128, help="network input: longer side, pixels")
    p.add_argument("--images", default="auto", choices=["auto", "rendered", "formed"],
                   help="train on the renders (<view>.png) or the views as a C-arm forms them "
                        "(<view>.formed.png, gimm-dataset --formation); auto: formed where the "
                        "dataset has them (a clinical-style dataset), else rendered")
    p.add_argument("--input", default="intensity", choices=NETWORK_INPUTS,
                   help="what the network sees: the image, or its vesselness (needs the gimm "
                        "module; recorded in the weights, gimm-match does the same)")
    p.add_argument("--widths", type=int, nargs=3, default=[16, 32, 64])
    p.add_argument("--coarse-layers", nargs="+", default=["self", "cross"])
    p.add_argument("--fine-layers", nargs="+", default=["self", "cross"])
    p.add_argument("--no-film", action="store_true", help="the LoFTR-style ablation")
    p.add_argument("--no-anchor", action="store_true", help="A point at the cell centre (LoFTR)")
    p.add_argument("--max-fine", type=int, default=128, help="fine matches per pair, at most")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--threads", type=int, default=0, help="torch threads (0: cores / ranks)")
    p.add_argument("--device", default="auto", choices=["auto", "cpu", "cuda"],
                   help="auto: CUDA when PyTorch sees a GPU, else the CPU")
    p.add_argument("--log-every", type=int, default=20)
    p.add_argument("--checkpoint-minutes", type=float, default=5.0)
    p.add_argument("--val-minutes", type=float, default=15.0)
    p.add_argument("--val-pairs", type=int, default=150, help="validation pairs (0: all)")
    p.add_argument("--train-limit", type=int, default=0, help="use the first N train pairs")
    p.add_argument("--rendered", type=int, default=0,
                   help="train on N phantom patients rendered on the fly (rendered_pairs.py; "
                        "phantom seeds from 1e9, disjoint from gimm-dataset's) with fresh views "
                        "each visit, at the dataset's detector size; the dataset gives only the "
                        "validation pairs. Needs the gimm module on PYTHONPATH")
    p.add_argument("--val-threshold", type=float, default=0.05, help="coarse threshold at val")
    return p.parse_args(argv)


def blas_in_use():
    """The BLAS library this process has mapped (OpenBLAS trains 1.4-2x faster than the
    reference BLAS on this machine)."""
    torch.ones(64, 64) @ torch.ones(64, 64)
    try:
        with open("/proc/self/maps") as f:
            libs = {line.split()[-1] for line in f if "blas" in line.lower() and ".so" in line}
        return ", ".join(sorted(libs)) or "none mapped (MKL or built-in)"
    except OSError:
        return "unknown"


# ---- distributed -------------------------------------------------------------------------

def pick_device(choice):
    if choice == "cuda" and not torch.cuda.is_available():
        raise SystemExit("train: --device cuda: PyTorch sees no CUDA GPU (torch.cuda.is_available()"
                         " is False)")
    return "cuda" if choice == "cuda" or (choice == "auto" and torch.cuda.is_available()) \
        else "cpu"


def init_ranks(kind):
    """(rank, world, device): one process per GPU (LOCAL_RANK's) with NCCL, or CPUs with gloo."""
    world = int(os.environ.get("WORLD_SIZE", "1"))
    device = torch.device("cpu")
    if kind == "cuda":
        device = torch.device("cuda", int(os.environ.get("LOCAL_RANK", "0")))
        torch.cuda.set_device(device)
    if world > 1:
        dist.init_process_group("nccl" if kind == "cuda" else "gloo")
        return dist.get_rank(), world, device
    return 0, 1, device


def agree(wanted, world, device):
    """True on every rank when any rank wants it. Every decision that leads to a collective
    (stopping, checkpointing) goes through here: decided on each rank's own clock, one rank
    would checkpoint (all_gather) while the other stopped, and the one left spun forever."""
    if world == 1:
        return wanted
    flag = torch.tensor([1.0 if wanted else 0.0], device=device)
    dist.all_reduce(flag, op=dist.ReduceOp.MAX)
    return bool(flag.item())


class TrainStep(torch.nn.Module):
    """One training step's loss as a module's forward, so DistributedDataParallel (which hooks
    forward) can wrap it: the step calls the model's stages, not its inference forward."""

    def __init__(self, model, max_fine):
        super().__init__()
        self.model, self.max_fine = model, max_fine

    def forward(self, batch):
        return train_step(self.model, batch, self.max_fine)


# ---- data --------------------------------------------------------------------------------

def augment(image, gen):
    """X-ray photometric augmentation (no geometry: the cameras and view class must hold):
    gamma, contrast and brightness, blur, Poisson-like and Gaussian noise."""
    x = image.float()
    x = x.clamp(0, 1) ** math.exp(gen.uniform(-0.35, 0.35))
    mean = x.mean()
    x = (x - mean) * gen.uniform(0.8, 1.25) + mean + gen.uniform(-0.05, 0.05)
    if gen.random() < 0.3:
        sigma = gen.uniform(0.3, 0.9)
        r = torch.arange(-2, 3, dtype=torch.float32)
        k = torch.exp(-r ** 2 / (2 * sigma ** 2))
        k = (k / k.sum())
        x = F.conv2d(x[None, None], k.view(1, 1, 1, 5), padding=(0, 2))
        x = F.conv2d(x, k.view(1, 1, 5, 1), padding=(2, 0))[0, 0]
    g = torch.Generator().manual_seed(gen.randrange(1 << 31))
    x = x + gen.uniform(0, 0.03) * x.clamp(min=0).sqrt() * torch.randn(x.shape, generator=g)
    x = x + gen.uniform(0, 0.01) * torch.randn(x.shape, generator=g)
    return x.clamp(0, 1)


def pad8(image):
    h, w = image.shape
    return F.pad(image, (0, (-w) % 8, 0, (-h) % 8))


def make_batch(samples, truths, gen, train=True, device="cpu", kind="intensity"):
    """Augmented on the CPU (the generator's stream does not depend on the device), turned into
    the network's input kind, then moved."""
    prep = (lambda x: network_image(augment(x, gen), kind)) if train else \
        (lambda x: network_image(x.float(), kind))
    a = torch.stack([pad8(prep(s.image_a)) for s in samples])[:, None]
    b = torch.stack([pad8(prep(s.image_b)) for s in samples])[:, None]
    ca = torch.tensor([s.class_a for s in samples])
    cb = torch.tensor([s.class_b for s in samples])
    return a.to(device), b.to(device), ca.to(device), cb.to(device), \
        [truths[id(s)] for s in samples]


RENDERED_SEED_BASE = 10 ** 9  # gimm-dataset's phantoms: seed * 1000003 + index, far below


def rendered_stream(args, rank, step):
    """train.py's pairs rendered on the fly at the dataset's detector (its manifest)."""
    from rendered_pairs import RenderedPairs  # needs the gimm module
    with open(os.path.join(args.dataset, "manifest.json")) as f:
        carm = json.load(f)["parameters"]["carm"]
    seeds = [RENDERED_SEED_BASE + k for k in range(args.rendered)]
    return iter(RenderedPairs(seeds, size=args.size, rows=carm["image_size"]["rows"],
                              cols=carm["image_size"]["cols"], pixel_mm=carm["pixel_mm"],
                              seed=[args.seed, rank, step]))


def epoch_order(n, seed, epoch):
    return np.random.default_rng([seed, epoch]).permutation(n)


# ---- steps -------------------------------------------------------------------------------

def train_step(model, batch, max_fine):
    image0, image1, c0, c1, truths = batch
    f0, f1, conf, fine, (hc, wc) = model.coarse_stage(image0, image1, c0, c1)
    positive = torch.zeros_like(conf, dtype=torch.bool)
    gt_b, gt_i, gt_j = [], [], []
    for n, t in enumerate(truths):
        positive[n, t.i, t.j] = True
        gt_b.append(np.full(len(t.i), n))
        gt_i.append(t.i)
        gt_j.append(t.j)
    loss_pos, loss_neg = focal_loss(conf, positive)
    # Fine matches: the ground-truth coarse matches, padded with predicted ones (LoFTR), at most
    # max_fine per pair.
    with torch.no_grad():
        pb, pi, pj = (x.cpu() for x in model.coarse_matches(conf, hc, wc))
        is_positive = positive.cpu()
    b_ids, i_ids, j_ids = [], [], []
    for n in range(len(truths)):
        gi, gj = gt_i[n], gt_j[n]
        sel = pb == n
        extra = [(int(i), int(j)) for i, j in zip(pi[sel], pj[sel]) if not is_positive[n, i, j]]
        pairs = list(zip(gi.tolist(), gj.tolist())) + extra
        pairs = pairs[:max_fine]
        b_ids += [n] * len(pairs)
        i_ids += [p[0] for p in pairs]
        j_ids += [p[1] for p in pairs]
    b_ids, i_ids, j_ids = (torch.tensor(x, dtype=torch.long) for x in (b_ids, i_ids, j_ids))
    reach = (model.cfg["window"] // 2) * 2
    if len(i_ids):
        on = [x.to(conf.device) for x in (b_ids, i_ids, j_ids)]
        out = model.fine_stage(f0, f1, fine, *on, wc)
        targets = fine_targets(truths, b_ids, i_ids, j_ids, out["points0"], wc, reach)
        loss_a, loss_b = fine_losses(out, *targets, reach)
        if model.anchor is None:
            loss_a = loss_a * 0
    else:  # no match at all: keep every parameter in the graph so all ranks reduce alike
        loss_a = loss_b = sum(p.sum() for p in model.parameters()) * 0
    loss = loss_pos + loss_neg + loss_a + loss_b
    return loss, {"pos": loss_pos.item(), "neg": loss_neg.item(), "fine_a": loss_a.item(),
                  "fine_b": loss_b.item(), "gt": int(sum(len(t.i) for t in truths))}


def lr_at(step, args):
    if step < args.warmup:
        return args.lr * (step + 1) / args.warmup
    t = min(1.0, (step - args.warmup) / max(1, args.steps - args.warmup))
    return args.lr * (0.02 + 0.98 * 0.5 * (1 + math.cos(math.pi * t)))


# ---- validation (the protocol of include/gimm/metrics/protocol.hpp, K = 20) ---------------

def score_direction(src, dst, src_labels, dst_labels, src_mask):
    u, v = int(np.floor(src[0] + 0.5)) if src[0] >= 0 else -int(np.floor(-src[0] + 0.5)), \
        int(np.floor(src[1] + 0.5)) if src[1] >= 0 else -int(np.floor(-src[1] + 0.5))
    h, w = src_mask.shape
    if not (np.isfinite(src).all() and 0 <= u < w and 0 <= v < h and src_mask[v, u]):
        return None
    j = int(np.argmin(((src_labels - src) ** 2).sum(1)))
    return float(np.linalg.norm(dst - dst_labels[j]))


@torch.no_grad()
def validate(model, pairs, threshold, k=20):
    model.eval()
    saved = model.cfg["threshold"]
    model.cfg["threshold"] = threshold
    errors, slots, seconds = [], 0, 0.0
    device = next(model.parameters()).device
    for s in pairs:
        kind = model.cfg["input"]
        a = pad8(network_image(s.image_a.float(), kind))[None, None].to(device)
        b = pad8(network_image(s.image_b.float(), kind))[None, None].to(device)
        t0 = time.perf_counter()
        out = model(a, b, s.class_a, s.class_b)
        seconds += time.perf_counter() - t0
        out = {key: out[key].cpu() for key in ("mconf", "points0", "points1")}
        order = torch.argsort(-out["mconf"], stable=True)[:k]
        su, sv = s.scale
        back = lambda p: np.stack([(p[:, 0] + 0.5) * su - 0.5, (p[:, 1] + 0.5) * sv - 0.5], 1)  # noqa
        pa, pb = back(out["points0"][order].numpy()), back(out["points1"][order].numpy())
        slots += 2 * k
        for m in range(len(order)):
            for src, dst, sl, dl, mask in ((pa[m], pb[m], s.a_full, s.b_full, s.mask_a),
                                           (pb[m], pa[m], s.b_full, s.a_full, s.mask_b)):
                e = score_direction(src, dst, sl, dl, mask)
                if e is not None:
                    errors.append(e)
    model.cfg["threshold"] = saved
    model.train()
    e = np.array(errors)
    return {"pairs": len(pairs), "coverage": len(e) / max(1, slots),
            "prec_1px": float((e <= 1).mean()) if len(e) else float("nan"),
            "prec_3px": float((e <= 3).mean()) if len(e) else float("nan"),
            "prec_5px": float((e <= 5).mean()) if len(e) else float("nan"),
            "mean_px": float(e.mean()) if len(e) else float("nan"),
            "seconds_per_pair": seconds / max(1, len(pairs))}


def val_key(v):
    """Best = highest Prec@3px among runs with coverage >= 0.5; below that, highest coverage."""
    p = v["prec_3px"] if v["prec_3px"] == v["prec_3px"] else 0.0
    return (1, p) if v["coverage"] >= 0.5 else (0, v["coverage"])


# ---- main --------------------------------------------------------------------------------

def save_weights(model, path, threshold, input_size):
    """The weights gimm-match loads, with the coarse threshold and the input size they were
    trained at (gimm-match resizes to it by default)."""
    cfg = dict(model.cfg, threshold=threshold, input_size=input_size)
    tmp = path + ".tmp"
    save_file(tmp, fold_free_state_dict(model), config_metadata(cfg))
    os.replace(tmp, path)


def save_checkpoint(path, state):
    tmp = path + ".tmp"
    torch.save(state, tmp)
    os.replace(tmp, path)


def truncate_log(path, step):
    """Drops the log entries of steps after `step`: a run stopped between checkpoints wrote them,
    and the resumed run writes those steps again."""
    if not os.path.isfile(path):
        return
    with open(path) as f:
        lines = f.readlines()
    def entry_step(entry):  # a logged step, or a validation's
        return entry.get("step", entry.get("val", {}).get("step", 0))

    keep = [ln for ln in lines if ln.strip() and entry_step(json.loads(ln)) <= step]
    if len(keep) != len(lines):
        tmp = path + ".tmp"
        with open(tmp, "w") as f:
            f.writelines(keep)
        os.replace(tmp, path)
        print(f"train: dropped {len(lines) - len(keep)} log entries after step {step}", flush=True)


MODEL_OPTIONS = ("widths", "coarse_layers", "fine_layers", "no_film", "no_anchor")


def load_init(model, args):
    """Loads the model of --init into `model`; returns the CPU seconds that model cost, so that a
    fine-tune reports the whole training time."""
    if not os.path.isfile(args.init):
        raise SystemExit(f"train: --init: {args.init} does not exist")
    try:
        state = torch.load(args.init, map_location="cpu")
        saved = state["args"]
        weights = state["model"]
    except Exception as e:  # torch raises several types for a file that is not a checkpoint
        raise SystemExit(f"train: --init: {args.init} is not a train.py checkpoint ({e})")
    for name in MODEL_OPTIONS:
        if saved.get(name) != getattr(args, name):
            raise SystemExit(f"train: --init: {args.init} has {name}={saved.get(name)!r}, this "
                             f"run {name}={getattr(args, name)!r}")
    model.load_state_dict(weights)
    return state.get("cpu_seconds", 0.0)


def main(argv=None):
    args = parse_args(argv)
    rank, world, device = init_ranks(pick_device(args.device))
    torch.set_num_threads(args.threads or max(1, (os.cpu_count() or 1) // world))
    os.makedirs(args.run, exist_ok=True)
    ckpt_path = os.path.join(args.run, "checkpoint.pt")
    state = None
    if args.resume:
        if not os.path.isfile(ckpt_path):
            raise SystemExit(f"train: --resume: {ckpt_path} does not exist")
        state = torch.load(ckpt_path, map_location="cpu")
        # Where the data and run live may change (a regenerated, byte-identical dataset); what
        # was trained on and how may not.
        keep = {"minutes", "resume", "val_minutes", "checkpoint_minutes", "threads", "stop_at",
                "dataset", "run", "device"}
        saved = state["args"]
        args = argparse.Namespace(**{**saved, **{k: getattr(args, k) for k in keep}})
    if args.images == "auto" and not args.rendered:  # saved as what it resolved to
        args.images = resolve_images(args.dataset, args.images)
    if rank == 0:
        where = f"GPU {torch.cuda.get_device_name(device)}" if device.type == "cuda" else \
            f"CPU, BLAS {blas_in_use()}; {torch.get_num_threads()} threads"
        print(f"train: {where} x {world} ranks", flush=True)
    cfg = dict(DEFAULT_CONFIG, widths=args.widths, coarse_layers=args.coarse_layers,
               fine_layers=args.fine_layers, film=not args.no_film, anchor=not args.no_anchor,
               coarse_heads=4, fine_heads=2 if args.widths[0] % 4 else 4,
               input=getattr(args, "input", "intensity"))  # runs saved before --input
    torch.manual_seed(args.seed)
    model = GimmMatcher(cfg)
    if model.film is not None and state is None:
        with torch.no_grad():  # an untrained FiLM adds one large offset to every token
            model.film.mlp[2].weight.mul_(0.1)
            model.film.mlp[2].bias.mul_(0.1)
    model.to(device)
    opt = torch.optim.AdamW(model.parameters(), lr=args.lr, weight_decay=args.weight_decay)
    t_load = time.time()
    # The stream restarts from (seed, rank, step) on --resume: deterministic, not a replay.
    stream = rendered_stream(args, rank, state["step"] if state else 0) if args.rendered else None
    train = [next(stream)] if stream else \
        load_pairs(args.dataset, "train", args.size, args.train_limit or None, rank == 0,
                   args.images)
    val = load_pairs(args.dataset, "val", args.size, args.val_pairs or None, rank == 0,
                     args.images) \
        if rank == 0 else []
    hc, wc = (train[0].image_a.shape[0] + 7) // 8, (train[0].image_a.shape[1] + 7) // 8
    truths = {id(s): PairTruth(s.a, s.b, hc, wc) for s in train}
    if rank == 0:
        params = sum(p.numel() for p in model.parameters())
        source = f"{args.rendered} phantoms rendered on the fly" if stream else \
            f"{len(train)} train pairs"
        print(f"train: {source}, {len(val)} val pairs at {args.size} px, loaded in "
              f"{time.time() - t_load:.0f} s; {params} parameters; config {json.dumps(cfg)}",
              flush=True)
        with open(os.path.join(args.run, "config.json"), "w") as f:
            json.dump({"args": vars(args), "model": cfg}, f, indent=1)
    step, epoch, pos, best, cpu0 = 0, 0, 0, None, 0.0
    gen = random.Random(args.seed * 1000 + rank)
    if state is not None:
        model.load_state_dict(state["model"])
        opt.load_state_dict(state["optimizer"])
        step, epoch, pos, best = state["step"], state["epoch"], state["pos"], state["best"]
        gen.setstate(state["gen"][rank])
        torch.set_rng_state(state["torch_rng"])
        cpu0 = state.get("cpu_seconds", 0.0)
    elif args.init:
        cpu0 = load_init(model, args)
    model.train()
    # DDP averages the gradients in backward (and starts every rank from rank 0's weights).
    step_module = TrainStep(model, args.max_fine)
    if world > 1:
        step_module = torch.nn.parallel.DistributedDataParallel(
            step_module, device_ids=[device.index] if device.type == "cuda" else None)
    start = time.time()
    cpu_start = time.process_time()
    last_ckpt = last_val = start
    log_path = os.path.join(args.run, "log.jsonl")
    if rank == 0 and state is not None:
        truncate_log(log_path, step)
    log = open(log_path, "a") if rank == 0 else None
    per_step = args.batch * world
    order = epoch_order(len(train), args.seed, epoch)
    seen_window, t_window = 0, time.time()

    def checkpoint():
        gens = [None] * world
        if world > 1:
            dist.all_gather_object(gens, gen.getstate())
        else:
            gens = [gen.getstate()]
        if rank == 0:
            save_checkpoint(ckpt_path, {
                "model": model.state_dict(), "optimizer": opt.state_dict(), "step": step,
                "epoch": epoch, "pos": pos, "best": best, "gen": gens, "args": vars(args),
                "torch_rng": torch.get_rng_state(),
                "cpu_seconds": cpu0 + (time.process_time() - cpu_start) * world})
            save_weights(model, os.path.join(args.run, "last.safetensors"), args.val_threshold,
                         args.size)

    while True:
        out_of_time = (time.time() - start > args.minutes * 60 or step >= args.steps
                       or (args.stop_at and step >= args.stop_at))
        if agree(out_of_time, world, device):
            break
        if stream:
            samples = [next(stream) for _ in range(args.batch)]
            truths = {id(s): PairTruth(s.a, s.b, hc, wc) for s in samples}
        else:
            if pos + per_step > len(order):
                epoch, pos = epoch + 1, 0
                order = epoch_order(len(train), args.seed, epoch)
            samples = [train[i] for i in order[pos + rank:pos + per_step:world]]
            pos += per_step
        batch = make_batch(samples, truths, gen, device=device, kind=cfg["input"])
        for g in opt.param_groups:
            g["lr"] = lr_at(step, args)
        loss, terms = step_module(batch)
        opt.zero_grad(set_to_none=False)
        loss.backward()
        norm = torch.nn.utils.clip_grad_norm_(model.parameters(), args.clip)
        opt.step()
        step += 1
        seen_window += per_step
        if rank == 0 and step % args.log_every == 0:
            rate = seen_window / max(1e-9, time.time() - t_window)
            left = (min(args.steps - step, (args.minutes * 60 - (time.time() - start)) * rate
                        / per_step)) / max(1e-9, rate / per_step)
            print(f"step {step}/{args.steps} epoch {epoch} pairs {step * per_step} loss "
                  f"{loss.item():.4f} (pos {terms['pos']:.4f} neg {terms['neg']:.5f} fine_a "
                  f"{terms['fine_a']:.4f} fine_b {terms['fine_b']:.4f}) gt {terms['gt']} lr "
                  f"{lr_at(step, args):.2e} |g| {norm:.2f} {rate:.2f} pairs/s ETA {left / 60:.1f} min",
                  flush=True)
            log.write(json.dumps({"step": step, "epoch": epoch, "pairs": step * per_step,
                                  "loss": loss.item(), **terms, "lr": lr_at(step, args),
                                  "grad_norm": float(norm), "pairs_per_s": rate,
                                  "time_s": time.time() - start}) + "\n")
            log.flush()
            seen_window, t_window = 0, time.time()
        if agree(time.time() - last_ckpt > args.checkpoint_minutes * 60, world, device):
            checkpoint()
            last_ckpt = time.time()
        if rank == 0 and val and time.time() - last_val > args.val_minutes * 60:
            best = run_validation(model, val, args, step, log, best)
            last_val = time.time()
    if rank == 0 and val:
        best = run_validation(model, val, args, step, log, best)
    checkpoint()
    if rank == 0:
        cpu = cpu0 + (time.process_time() - cpu_start) * world
        print(f"train: stopped at step {step} ({step * per_step} pairs) after "
              f"{(time.time() - start) / 60:.1f} min; CPU time so far {cpu / 3600:.2f} h", flush=True)
    if world > 1:
        dist.destroy_process_group()
        # PyTorch 1.13's gloo teardown can deadlock at interpreter exit: the DDP reducer's
        # destructor joins a gloo worker thread that waits for the GIL the destructor holds (seen
        # as a rank spinning after its run had ended). Everything is written: leave now.
        if log:
            log.close()
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(0)


def run_validation(model, val, args, step, log, best):
    v = validate(model, val, args.val_threshold)
    v["step"] = step
    improved = best is None or val_key(v) > val_key(best)
    print(f"val step {step}: Prec@3px {v['prec_3px']:.3f} coverage {v['coverage']:.3f} "
          f"2D mean {v['mean_px']:.2f} px ({v['pairs']} pairs, {v['seconds_per_pair']:.3f} s/pair)"
          f"{' (best)' if improved else ''}", flush=True)
    log.write(json.dumps({"val": v}) + "\n")
    log.flush()
    if improved:
        save_weights(model, os.path.join(args.run, "best.safetensors"), args.val_threshold,
                     args.size)
        return v
    return best


if __name__ == "__main__":
    main()
