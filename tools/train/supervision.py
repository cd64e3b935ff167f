"""Ground truth for the matcher from gimm's dense labels, and the losses.

Coarse ground truth (LoFTR builds it from depth and pose; here the labels carry both): each
label falls in the 1/8 cell of A whose centre (8c, 8r) is nearest its A point, and its B point
in a cell of B. Per A cell the label nearest the cell centre speaks for it; per B cell only the
A cell whose label lands nearest B's cell centre is kept (mutual), so each row and column of
the matrix has at most one positive.

Fine ground truth, with the A-side anchor (gimm_model.GimmMatcher.anchor): the A point of a
match is predicted inside A's window, so its target is the label of that A cell nearest the
prediction (chosen without gradient), and the B target is that label's B point. Matches whose
B target falls outside B's window carry no fine loss (LoFTR's rule).
"""
import numpy as np
import torch


def cell_of(points, hc, wc):
    """[N, 2] network pixels -> cell ids (row-major), -1 off the grid."""
    c = np.rint(points[:, 0] / 8.0).astype(np.int64)
    r = np.rint(points[:, 1] / 8.0).astype(np.int64)
    ok = (c >= 0) & (c < wc) & (r >= 0) & (r < hc) & np.isfinite(points).all(1)
    return np.where(ok, r * wc + c, -1)


def centre_of(cells, wc):
    return np.stack([(cells % wc) * 8.0, (cells // wc) * 8.0], 1)


class PairTruth:
    """Per pair: coarse positives (i, j) and the labels of each A cell (CSR)."""

    def __init__(self, a, b, hc, wc):
        ia, jb = cell_of(a, hc, wc), cell_of(b, hc, wc)
        ok = (ia >= 0) & (jb >= 0)
        a, b, ia, jb = a[ok], b[ok], ia[ok], jb[ok]
        self.a, self.b = a, b
        order = np.argsort(ia, kind="stable")
        self.order = order
        self.starts = np.searchsorted(ia[order], np.arange(hc * wc + 1))
        # Coarse positives: the label nearest each A cell centre, then one per B cell.
        da = np.linalg.norm(a - centre_of(ia, wc), axis=1)
        best = {}
        for n in np.lexsort((da, ia)):
            best.setdefault(int(ia[n]), n)
        rows = np.array(sorted(best), dtype=np.int64)
        picks = np.array([best[i] for i in rows], dtype=np.int64)
        cols = jb[picks] if len(picks) else np.zeros(0, np.int64)
        db = np.linalg.norm(b[picks] - centre_of(cols, wc), axis=1) if len(picks) else np.zeros(0)
        keep = {}
        for n in np.lexsort((db, cols)):
            keep.setdefault(int(cols[n]), n)
        sel = np.array(sorted(keep.values()), dtype=np.int64)
        self.i = rows[sel] if len(sel) else np.zeros(0, np.int64)
        self.j = cols[sel] if len(sel) else np.zeros(0, np.int64)

    def labels_in(self, cell):
        return self.order[self.starts[cell]:self.starts[cell + 1]]


def focal_loss(conf, positive, alpha=0.25, gamma=2.0):
    """LoFTR's focal loss over the whole dual-softmax matrix: positives and negatives averaged
    separately (each term weighted 1)."""
    conf = conf.clamp(1e-6, 1 - 1e-6)
    pos, neg = conf[positive], conf[~positive]
    loss_pos = (-alpha * (1 - pos) ** gamma * pos.log()).mean() if pos.numel() else conf.sum() * 0
    loss_neg = (-(1 - alpha) * neg ** gamma * (1 - neg).log()).mean()
    return loss_pos, loss_neg


def fine_targets(truths, b_ids, i_ids, j_ids, points0, wc, reach):
    """Targets of fine matches: A target (nearest label of A's cell to the predicted A point),
    B target offset (normalised, B window), and which matches carry each loss."""
    m = len(i_ids)
    a_target = torch.zeros(m, 2)
    b_offset = torch.zeros(m, 2)
    has_a = torch.zeros(m, dtype=torch.bool)
    has_b = torch.zeros(m, dtype=torch.bool)
    pred = points0.detach().cpu().numpy()
    for n in range(m):
        t = truths[int(b_ids[n])]
        idx = t.labels_in(int(i_ids[n]))
        if len(idx) == 0:
            continue
        k = idx[np.argmin(np.linalg.norm(t.a[idx] - pred[n], axis=1))]
        a_target[n] = torch.from_numpy(t.a[k])
        has_a[n] = True
        j = int(j_ids[n])
        off = (t.b[k] - np.array([(j % wc) * 8.0, (j // wc) * 8.0])) / reach
        if np.abs(off).max() <= 1.0:
            b_offset[n] = torch.from_numpy(off.astype(np.float32))
            has_b[n] = True
    device = points0.device  # built on the CPU (numpy labels), used where the points are
    return a_target.to(device), has_a.to(device), b_offset.to(device), has_b.to(device)


def fine_losses(out, a_target, has_a, b_offset, has_b, reach):
    """A: squared distance of the A point to its target (in window units); B: LoFTR's
    std-weighted L2 on the expectation."""
    zero = out["points1"].sum() * 0
    loss_a = (((out["points0"][has_a] - a_target[has_a]) / reach) ** 2).sum(1).mean() \
        if has_a.any() else zero
    if has_b.any():
        inv_std = 1.0 / out["std"][has_b].detach().clamp(min=1e-6)
        weight = inv_std / inv_std.mean()
        loss_b = (weight * ((out["offset1"][has_b] - b_offset[has_b]) ** 2).sum(1)).mean()
    else:
        loss_b = zero
    return loss_a, loss_b
