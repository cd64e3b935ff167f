#!/usr/bin/python3
"""gimm from Python, start to end, on one page: a phantom patient, two clinical C-arm views of
its left coronary tree rendered, labelled with exact 3D-to-2D correspondences, matched by the
learned matcher and by the training-free geometric one, scored with the paper's protocol, and
drawn with matplotlib.

    PYTHONPATH=build/python examples/python/walkthrough.py [--out walkthrough.png] [--seed 7]
        [--view-a 40 20] [--view-b -30 20] [--size 128]

Prints one line per matcher (Prec@3px, 2D mean, coverage at K = 20, the same figures gimm-eval
gives) and writes the picture: the two views side by side, the 20 most confident matches of
each matcher joined by lines, green where the B point lies within 3 px of the true one.
Conventions: angles in degrees (primary: + = LAO, secondary: + = cranial), pixel centres at
integer coordinates, points (u, v) = (column, row), world points in mm (LPS).
"""
import argparse
import sys

try:
    import matplotlib
    import numpy as np
except ImportError as e:  # another Python than the one the packages were installed for
    sys.exit(f"walkthrough.py: {e.name} is missing for {sys.executable}: run it with the Python "
             "that has numpy and matplotlib (Debian's /usr/bin/python3 after "
             "scripts/install-deps.sh)")
matplotlib.use("Agg")  # files only: no display needed
import matplotlib.pyplot as plt  # noqa: E402

try:
    import gimm  # noqa: E402
except ImportError:
    sys.exit(f"walkthrough.py: the gimm module is not importable by {sys.executable}: set "
             "PYTHONPATH=build/python (the README's build) and use the Python it was built for")

TOP_K = 20


def parse_args(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default="walkthrough.png", help="the picture (PNG)")
    parser.add_argument("--seed", type=int, default=7, help="phantom patient seed")
    parser.add_argument("--view-a", type=float, nargs=2, default=(40.0, 20.0),
                        metavar=("PRIMARY", "SECONDARY"), help="view A angles, deg (LAO cranial)")
    parser.add_argument("--view-b", type=float, nargs=2, default=(-30.0, 20.0),
                        metavar=("PRIMARY", "SECONDARY"), help="view B angles, deg (RAO cranial)")
    parser.add_argument("--size", type=int, default=128,
                        help="detector pixels per side (the shipped weights run at 128)")
    args = parser.parse_args(argv)
    if args.size < 32:
        parser.error(f"--size must be at least 32 px, got {args.size}")
    return args


def b_errors(truth, points_a, points_b):
    """Per match, the distance (px) from its B point to the true partner of the label nearest
    its A point: the protocol's A->B error (docs/evaluation.md), for colouring only."""
    if len(points_a) == 0:
        return np.zeros(0)
    d = np.linalg.norm(points_a[:, None, :] - truth["points_a"][None, :, :], axis=2)
    return np.linalg.norm(points_b - truth["points_b"][d.argmin(axis=1)], axis=1)


def main(argv):
    args = parse_args(argv)
    # 1. A patient: CT in HU, a coronary label, and the phantom's own centerlines.
    patient = gimm.make_phantom(seed=args.seed)
    lca = gimm.split_coronary_systems(patient["label"], patient["geometry"])["lca"]
    isocenter = gimm.vessel_isocenter(lca, patient["geometry"])

    # 2. Prepare the renderer once (attenuation, padding), then render any number of views.
    renderer = gimm.Renderer(patient["hu"], lca, geometry=patient["geometry"])
    pixel_mm = 256.0 / args.size  # a 256 mm field of view whatever the size
    carms = [gimm.CArm(primary_deg=p, secondary_deg=s, rows=args.size, cols=args.size,
                       pixel_mm=pixel_mm, isocenter=isocenter)
             for p, s in (args.view_a, args.view_b)]
    views = [renderer.render(c) for c in carms]  # numpy views of gimm's buffers, no copy
    classes = [gimm.view_class_from_angles(c.primary_deg, c.secondary_deg, system="LCA")[0]
               for c in carms]

    # 3. Exact labels: the centerline points projected into both views, kept where visible.
    truth = gimm.label_pair(patient["centerlines"]["LCA"], carms[0], carms[1],
                            views[0]["vessel_mask"], views[1]["vessel_mask"])

    # 4. Two matchers: the learned one (shipped weights, gated by the exact F of the cameras)
    # and the geometric one (epipolar DP along the centerlines it segments from the images).
    images = [v["intensity"] for v in views]
    results = {
        "learned": gimm.Matcher().match(images[0], images[1], classes[0], classes[1], *carms),
        "geometric": gimm.match_geometric(images[0], images[1], *carms),
        "geometric, masks": gimm.match_geometric(images[0], images[1], *carms,
                                                 mask_a=views[0]["vessel_mask"],
                                                 mask_b=views[1]["vessel_mask"]),
    }

    # 5. Scores, as gimm-eval computes them.
    print(f"views: class {classes[0]} ({args.view_a[0]:g}, {args.view_a[1]:g}) and class "
          f"{classes[1]} ({args.view_b[0]:g}, {args.view_b[1]:g}); {len(truth['points_a'])} "
          "labels")
    for name, matches in results.items():
        pooled = gimm.evaluate(truth, matches, top_k=TOP_K)["pooled"]
        print(f"{name}: {len(matches['confidence'])} matches, Prec@3px {pooled['prec_3px']:.3f}, "
              f"2D mean {pooled['mean_px']:.2f} px, coverage {pooled['coverage']:.3f}")

    # 6. The picture: A and B side by side, each matcher's top-K joined A -> B.
    fig, axes = plt.subplots(1, len(results), figsize=(5 * len(results), 3))
    side_by_side = np.hstack(images)
    for ax, (name, matches) in zip(axes, results.items()):
        order = np.argsort(-matches["confidence"], kind="stable")[:TOP_K]
        a, b = matches["points_a"][order], matches["points_b"][order]
        good = b_errors(truth, a, b) <= 3.0
        ax.imshow(side_by_side, cmap="gray")
        for pa, pb, ok in zip(a, b, good):
            ax.plot([pa[0], pb[0] + args.size], [pa[1], pb[1]], "-", lw=0.8,
                    color="lime" if ok else "red")
        ax.set_title(f"{name}: {good.sum()} of {len(order)} within 3 px", fontsize=9)
        ax.axis("off")
    fig.tight_layout()
    fig.savefig(args.out, dpi=100)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv[1:]))
    except (gimm.Error, OSError) as e:
        print(f"error: walkthrough: {e}", file=sys.stderr)
        sys.exit(1)
