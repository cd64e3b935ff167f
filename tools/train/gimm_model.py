"""The GIMM matcher in PyTorch: the source of truth for include/gimm/nn/matcher.hpp.

A LoFTR-style coarse-to-fine matcher sized for a CPU (reference-notes.md, "The reference
matcher"):
  ResNet-FPN (coarse 1/8, fine 1/2) -> sine positional encoding -> FiLM view conditioning
  (1 + gamma) F + beta -> coarse linear-attention transformer -> dual-softmax matching
  (threshold, border removal, mutual nearest neighbours) -> 5x5 fine windows -> fine
  transformer -> expectation (soft-argmax).
Epipolar gating is geometry, not network: the C++ side applies it (geometry/gating.hpp).

Points are in the network input's pixels with pixel centres at integers: coarse cell (r, c) is
centred on pixel (8c, 8r) (stride-2 convolutions with odd kernels sample even positions), and a
fine offset of one fine pixel is 2 image pixels.

Every op is one the C++ engine implements; keep the two in step (the parity fixture checks it).
"""
import json
import math

import torch
import torch.nn as nn
import torch.nn.functional as F

FORMAT = "gimm-matcher/1"

DEFAULT_CONFIG = {
    "format": FORMAT,
    "widths": [24, 48, 96],           # ResNet stages at 1/2, 1/4, 1/8; fine dim = widths[0],
                                       # coarse dim = widths[2]
    "coarse_heads": 4,
    "coarse_layers": ["self", "cross", "self", "cross"],
    "fine_heads": 4,
    "fine_layers": ["self", "cross"],
    "film": True,                      # FiLM view conditioning on the coarse features
    "film_classes": 12,                # 0 = unknown, 1..11 = view classes
    "film_dim": 64,
    "temperature": 0.1,                # dual-softmax temperature
    "threshold": 0.2,                  # coarse confidence threshold
    "border": 1,                       # coarse cells dropped at each image border
    "window": 5,                       # fine window (odd)
    "anchor": True,                    # refine the A-side point inside its window too
    "input": "intensity",              # what the network sees: intensity | vesselness
}

# Keys a weights file written before they existed may lack, with the value that reproduces it.
BACKWARD_DEFAULTS = {"anchor": False, "input": "intensity"}
# Keys set after training (export.py --input-size, record_gate.py), read by the C++ engine.
OPTIONAL_KEYS = ("input_size", "gate")
# What the network sees of an image (include/gimm/match/network_input.hpp, gimm.network_image).
NETWORK_INPUTS = ("intensity", "vesselness")


def validate_config(cfg):
    for key, value in BACKWARD_DEFAULTS.items():
        cfg.setdefault(key, value)
    for key in DEFAULT_CONFIG:
        if key not in cfg:
            raise ValueError(f"matcher config: missing key '{key}'")
    for key in cfg:  # as the C++ reader (nn/matcher_file.hpp): an unknown key is refused
        if key not in DEFAULT_CONFIG and key not in OPTIONAL_KEYS:
            raise ValueError(f"matcher config: unknown key '{key}'")
    if cfg["format"] != FORMAT:
        raise ValueError(f"matcher config: format must be {FORMAT}, got {cfg['format']!r}")
    w = cfg["widths"]
    if len(w) != 3 or any(int(x) <= 0 for x in w):
        raise ValueError(f"matcher config: widths must be 3 positive ints, got {w}")
    for dim, heads, name in ((w[2], cfg["coarse_heads"], "coarse"), (w[0], cfg["fine_heads"], "fine")):
        if heads <= 0 or dim % heads:
            raise ValueError(f"matcher config: {name} dim {dim} not divisible by heads {heads}")
    if w[2] % 4:
        raise ValueError(f"matcher config: coarse dim {w[2]} must be a multiple of 4 (sine PE)")
    for layer in cfg["coarse_layers"] + cfg["fine_layers"]:
        if layer not in ("self", "cross"):
            raise ValueError(f"matcher config: layer kind must be self|cross, got {layer!r}")
    if cfg["input"] not in NETWORK_INPUTS:
        raise ValueError(f"matcher config: input must be one of {NETWORK_INPUTS}, "
                         f"got {cfg['input']!r}")
    if cfg["window"] < 1 or cfg["window"] % 2 == 0:
        raise ValueError(f"matcher config: window must be odd, got {cfg['window']}")
    return cfg


def conv_bn(cin, cout, kernel, stride):
    return nn.Sequential(nn.Conv2d(cin, cout, kernel, stride, kernel // 2, bias=False),
                         nn.BatchNorm2d(cout))


class BasicBlock(nn.Module):
    def __init__(self, cin, cout, stride):
        super().__init__()
        self.conv1 = conv_bn(cin, cout, 3, stride)
        self.conv2 = conv_bn(cout, cout, 3, 1)
        self.shortcut = conv_bn(cin, cout, 1, stride) if (stride != 1 or cin != cout) else None

    def forward(self, x):
        y = self.conv2(F.relu(self.conv1(x)))
        return F.relu((x if self.shortcut is None else self.shortcut(x)) + y)


def upsample2(x):
    return F.interpolate(x, scale_factor=2.0, mode="bilinear", align_corners=True)


class ResNetFPN(nn.Module):
    """Coarse features at 1/8 (widths[2] channels) and fine features at 1/2 (widths[0])."""

    def __init__(self, widths):
        super().__init__()
        w1, w2, w3 = widths
        self.stem = conv_bn(1, w1, 7, 2)
        self.layer1 = nn.Sequential(BasicBlock(w1, w1, 1), BasicBlock(w1, w1, 1))
        self.layer2 = nn.Sequential(BasicBlock(w1, w2, 2), BasicBlock(w2, w2, 1))
        self.layer3 = nn.Sequential(BasicBlock(w2, w3, 2), BasicBlock(w3, w3, 1))
        self.out3 = nn.Conv2d(w3, w3, 1, bias=False)
        self.out2 = nn.Conv2d(w2, w3, 1, bias=False)
        self.out2_refine = nn.Sequential(conv_bn(w3, w3, 3, 1), nn.ReLU(),
                                         nn.Conv2d(w3, w2, 3, 1, 1, bias=False))
        self.out1 = nn.Conv2d(w1, w2, 1, bias=False)
        self.out1_refine = nn.Sequential(conv_bn(w2, w2, 3, 1), nn.ReLU(),
                                         nn.Conv2d(w2, w1, 3, 1, 1, bias=False))

    def forward(self, x):
        x1 = self.layer1(F.relu(self.stem(x)))
        x2 = self.layer2(x1)
        x3 = self.layer3(x2)
        coarse = self.out3(x3)
        f2 = self.out2_refine(self.out2(x2) + upsample2(coarse))
        fine = self.out1_refine(self.out1(x1) + upsample2(f2))
        return coarse, fine


def sine_encoding(channels, height, width, device=None):
    """LoFTR's 2D sine encoding, [channels, height, width]; positions count from 1."""
    pe = torch.zeros(channels, height, width, device=device)
    y = torch.ones(height, width, device=device).cumsum(0)[None]
    x = torch.ones(height, width, device=device).cumsum(1)[None]
    div = torch.exp(torch.arange(0, channels // 2, 2, device=device).float()
                    * (-math.log(10000.0) / (channels // 2)))
    div = div[:, None, None]
    pe[0::4] = torch.sin(x * div)
    pe[1::4] = torch.cos(x * div)
    pe[2::4] = torch.sin(y * div)
    pe[3::4] = torch.cos(y * div)
    return pe


class LinearAttention(nn.Module):
    """Katharopoulos et al.: phi(x) = elu(x) + 1; queries [N, L, H, D], keys/values [N, S, H, D]."""

    eps = 1e-6

    def forward(self, q, k, v):
        q = F.elu(q) + 1
        k = F.elu(k) + 1
        s = v.shape[1]
        v = v / s
        kv = torch.einsum("nshd,nshv->nhdv", k, v)
        z = 1 / (torch.einsum("nlhd,nhd->nlh", q, k.sum(dim=1)) + self.eps)
        return torch.einsum("nlhd,nhdv,nlh->nlhv", q, kv, z) * s


class EncoderLayer(nn.Module):
    def __init__(self, dim, heads):
        super().__init__()
        self.heads, self.head_dim = heads, dim // heads
        self.q = nn.Linear(dim, dim, bias=False)
        self.k = nn.Linear(dim, dim, bias=False)
        self.v = nn.Linear(dim, dim, bias=False)
        self.attention = LinearAttention()
        self.merge = nn.Linear(dim, dim, bias=False)
        self.mlp = nn.Sequential(nn.Linear(2 * dim, 2 * dim, bias=False), nn.ReLU(),
                                 nn.Linear(2 * dim, dim, bias=False))
        self.norm1 = nn.LayerNorm(dim)
        self.norm2 = nn.LayerNorm(dim)

    def forward(self, x, source):
        n = x.shape[0]
        q = self.q(x).view(n, x.shape[1], self.heads, self.head_dim)
        k = self.k(source).view(n, source.shape[1], self.heads, self.head_dim)
        v = self.v(source).view(n, source.shape[1], self.heads, self.head_dim)
        message = self.attention(q, k, v).reshape(n, x.shape[1], self.heads * self.head_dim)
        message = self.norm1(self.merge(message))
        message = self.norm2(self.mlp(torch.cat([x, message], dim=2)))
        return x + message


class Transformer(nn.Module):
    def __init__(self, dim, heads, kinds):
        super().__init__()
        self.kinds = list(kinds)
        self.layers = nn.ModuleList([EncoderLayer(dim, heads) for _ in self.kinds])

    def forward(self, f0, f1):
        for kind, layer in zip(self.kinds, self.layers):
            if kind == "self":
                f0, f1 = layer(f0, f0), layer(f1, f1)
            else:  # cross: image 0 first, then image 1 against the updated image 0 (LoFTR)
                f0 = layer(f0, f1)
                f1 = layer(f1, f0)
        return f0, f1


class FiLM(nn.Module):
    """embedding(classes, d) -> Linear(d, d) -> ReLU -> Linear(d, 2C) gives (gamma, beta)."""

    def __init__(self, classes, dim, channels):
        super().__init__()
        self.embedding = nn.Embedding(classes, dim)
        self.mlp = nn.Sequential(nn.Linear(dim, dim), nn.ReLU(), nn.Linear(dim, 2 * channels))

    def forward(self, feat, view_class):
        gamma, beta = self.mlp(self.embedding(view_class)).chunk(2, dim=-1)
        return (1 + gamma)[:, :, None, None] * feat + beta[:, :, None, None]


def border_mask(h, w, border, device=None):
    keep = torch.zeros(h, w, dtype=torch.bool, device=device)
    keep[border:h - border, border:w - border] = True
    return keep.reshape(-1)


def extract_windows(fine, batch, rows, cols, window, stride):
    """fine [N, C, Hf, Wf]; windows of image `batch` centred on fine pixels (stride*r, stride*c),
    zero padded. Returns [M, window*window, C], window pixels in row-major order."""
    half = window // 2
    padded = F.pad(fine, (half, half, half, half))
    offsets = torch.arange(window, device=fine.device)
    ry = (rows * stride)[:, None] + offsets[None, :]          # [M, W] rows in padded coords
    cx = (cols * stride)[:, None] + offsets[None, :]          # [M, W]
    win = padded[batch[:, None, None], :, ry[:, :, None], cx[:, None, :]]  # [M, W, W, C]
    return win.reshape(rows.shape[0], window * window, fine.shape[1])


def window_grid(window, device=None):
    """Normalised window offsets in [-1, 1], row-major: (gx, gy), each [window*window]."""
    grid = torch.linspace(-1.0, 1.0, window, device=device)
    gy, gx = torch.meshgrid(grid, grid, indexing="ij")
    return gx.reshape(-1), gy.reshape(-1)


def expectation(heat, gx, gy):
    """Soft-argmax of heat [M, R] over the window grid: (ex, ey, std), normalised units."""
    ex = (heat * gx).sum(1)
    ey = (heat * gy).sum(1)
    var = (heat * gx * gx).sum(1) - ex ** 2 + (heat * gy * gy).sum(1) - ey ** 2
    return ex, ey, torch.sqrt(torch.clamp(var, min=1e-10))


class GimmMatcher(nn.Module):
    def __init__(self, cfg):
        super().__init__()
        self.cfg = validate_config(dict(cfg))
        w1, _, w3 = self.cfg["widths"]
        self.backbone = ResNetFPN(self.cfg["widths"])
        self.film = FiLM(self.cfg["film_classes"], self.cfg["film_dim"], w3) if self.cfg["film"] else None
        self.coarse = Transformer(w3, self.cfg["coarse_heads"], self.cfg["coarse_layers"])
        self.down_proj = nn.Linear(w3, w1)
        self.merge_feat = nn.Linear(2 * w1, w1)
        self.fine = Transformer(w1, self.cfg["fine_heads"], self.cfg["fine_layers"])
        # The A-side anchor: a score per A-window pixel; its soft-argmax is the A point (on the
        # vessel, not the cell centre) and its weighted feature queries B's window.
        self.anchor = nn.Linear(w1, 1) if self.cfg["anchor"] else None

    def coarse_stage(self, image0, image1, class0, class1):
        """image0, image1 [B, 1, H, W]; classes [B] long. Returns the coarse tokens f0, f1
        [B, L, C], the dual-softmax matrix [B, L, L], the fine maps [2B, Cf, H/2, W/2] (image0's
        first) and the coarse grid (hc, wc)."""
        h, w = image0.shape[-2:]
        assert image1.shape[-2:] == (h, w) and h % 8 == 0 and w % 8 == 0
        b = image0.shape[0]
        coarse, fine = self.backbone(torch.cat([image0, image1], 0))
        c = coarse.shape[1]
        hc, wc = h // 8, w // 8
        coarse = coarse + sine_encoding(c, hc, wc, coarse.device)[None]
        if self.film is not None:
            coarse = self.film(coarse, torch.cat([class0, class1]))
        tokens = coarse.flatten(2).transpose(1, 2)                 # [2B, L, C]
        f0, f1 = self.coarse(tokens[:b], tokens[b:])
        sim = (f0 / c ** 0.5) @ (f1 / c ** 0.5).transpose(1, 2) / self.cfg["temperature"]
        conf = F.softmax(sim, 1) * F.softmax(sim, 2)                # [B, L0, L1]
        return f0, f1, conf, fine, (hc, wc)

    def coarse_matches(self, conf, hc, wc):
        """Thresholded mutual nearest neighbours away from the border: (b, i, j) ids."""
        keep = border_mask(hc, wc, self.cfg["border"], conf.device)
        mask = (conf > self.cfg["threshold"]) & keep[None, :, None] & keep[None, None, :]
        mask = (mask & (conf == conf.max(dim=2, keepdim=True)[0])
                & (conf == conf.max(dim=1, keepdim=True)[0]))
        return torch.nonzero(mask, as_tuple=True)

    def fine_stage(self, f0, f1, fine, b_ids, i_ids, j_ids, wc):
        """Fine points of coarse matches (b, i, j), in input pixels: points0, points1 [M, 2],
        and the normalised A and B expectations and B's std for the losses."""
        cfg = self.cfg
        win, cf = cfg["window"], fine.shape[1]
        nb = f0.shape[0]
        w0 = extract_windows(fine, b_ids, i_ids // wc, i_ids % wc, win, 4)
        w1_ = extract_windows(fine, b_ids + nb, j_ids // wc, j_ids % wc, win, 4)
        cwin = self.down_proj(torch.cat([f0[b_ids, i_ids], f1[b_ids, j_ids]], 0))  # [2M, Cf]
        merged = self.merge_feat(torch.cat([torch.cat([w0, w1_], 0),
                                            cwin[:, None, :].expand(-1, win * win, -1)], -1))
        m = i_ids.shape[0]
        g0, g1 = self.fine(merged[:m], merged[m:])
        gx, gy = window_grid(win, fine.device)
        if self.anchor is not None:
            heat0 = F.softmax(self.anchor(g0).squeeze(-1), dim=1)
            ex0, ey0, _ = expectation(heat0, gx, gy)
            center = torch.einsum("mr,mrc->mc", heat0, g0)
        else:
            ex0 = ey0 = torch.zeros(m, device=fine.device)
            center = g0[:, (win * win) // 2, :]
        heat = F.softmax(torch.einsum("mc,mrc->mr", center, g1) / cf ** 0.5, dim=1)
        ex, ey, std = expectation(heat, gx, gy)
        reach = (win // 2) * 2  # input pixels from the cell centre to the window's edge
        pts0 = torch.stack([(i_ids % wc) * 8 + ex0 * reach, (i_ids // wc) * 8 + ey0 * reach], 1)
        pts1 = torch.stack([(j_ids % wc) * 8 + ex * reach, (j_ids // wc) * 8 + ey * reach], 1)
        return {"points0": pts0.float(), "points1": pts1.float(), "std": std,
                "offset0": torch.stack([ex0, ey0], 1), "offset1": torch.stack([ex, ey], 1)}

    def forward(self, image0, image1, class0=0, class1=0):
        """image0, image1: [1, 1, H, W] in [0, 1], H and W multiples of 8. Returns a dict."""
        def as_classes(c):
            return c.reshape(1).long().to(image0.device) if isinstance(c, torch.Tensor) \
                else torch.tensor([c], device=image0.device)
        f0, f1, conf, fine, (hc, wc) = self.coarse_stage(image0, image1, as_classes(class0),
                                                         as_classes(class1))
        b_ids, i_ids, j_ids = self.coarse_matches(conf, hc, wc)
        out = self.fine_stage(f0, f1, fine, b_ids, i_ids, j_ids, wc)
        out.update({"conf": conf[0], "i_ids": i_ids, "j_ids": j_ids, "mconf": conf[b_ids, i_ids, j_ids],
                    "coarse0": f0[0], "coarse1": f1[0]})
        return out


def fold_free_state_dict(model):
    """Tensors to save: every parameter and BN buffer (the C++ loader folds BN into convs)."""
    return {k: v.detach().cpu().float().contiguous() for k, v in model.state_dict().items()
            if not k.endswith("num_batches_tracked")}


def config_metadata(cfg):
    return {"gimm_config": json.dumps(cfg, sort_keys=True)}
