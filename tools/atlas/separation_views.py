#!/usr/bin/python3
"""The view list of the separation sweep (docs/stability.md): for each routine view class, its
centre pose paired with a pose the given number of degrees away, for every separation asked.

    tools/atlas/separation_views.py OUT.json [--separations 5,10,15,20,30,45,60,75,90]

The partner keeps the base's secondary angle and turns the primary angle (the C-arm's LAO/RAO
rotation) by the amount that puts the two viewing directions exactly SEP degrees apart: at
secondary s the directions of primaries p and p + dp are apart by acos(cos^2 s cos dp + sin^2 s),
so dp = acos((cos SEP - sin^2 s) / cos^2 s). It turns towards RAO from a LAO base and towards LAO
otherwise, so the partners stay within the C-arm's usual range. Writes a gimm-views/1 file for
gimm-dataset --views (docs/dataset.md); deterministic.
"""
import argparse
import json
import math

# The routine view classes' centre poses (include/gimm/labels/views.hpp): system, primary,
# secondary, in class-id order.
CLASS_CENTRES = [("RCA", 0, 22.5), ("RCA", 50, 0), ("RCA", 40, 17.5), ("RCA", -30, 7.5),
                 ("LCA", 0, 0), ("LCA", 0, 22.5), ("LCA", 0, -25), ("LCA", 45, 22.5),
                 ("LCA", 45, -27.5), ("LCA", -30, 22.5), ("LCA", -17.5, -20)]


def primary_turn(separation_deg, secondary_deg):
    """The primary-angle turn, degrees, that puts two views at one secondary angle
    `separation_deg` apart."""
    s, d = math.radians(secondary_deg), math.radians(separation_deg)
    c = (math.cos(d) - math.sin(s) ** 2) / math.cos(s) ** 2
    if c < -1:
        raise ValueError(f"{separation_deg} deg is out of reach at secondary {secondary_deg} deg")
    return math.degrees(math.acos(c))


def direction(primary_deg, secondary_deg):
    """The viewing direction of a pose (CArm::rotation's third row, up to sign)."""
    p, s = math.radians(primary_deg), math.radians(secondary_deg)
    v = (0.0, -math.cos(s), math.sin(s))  # Rx(-s) applied to the AP direction (0, -1, 0)
    return (math.cos(p) * v[0] - math.sin(p) * v[1], math.sin(p) * v[0] + math.cos(p) * v[1], v[2])


def angle_between(a, b):
    dot = sum(x * y for x, y in zip(direction(*a), direction(*b)))
    return math.degrees(math.acos(max(-1.0, min(1.0, dot))))


def sweep_pairs(separations):
    pairs = []
    for system, primary, secondary in CLASS_CENTRES:
        for sep in separations:
            turn = primary_turn(sep, secondary) * (-1 if primary > 0 else 1)
            partner = round(primary + turn, 6)
            # The closed form, checked against the directions themselves.
            assert abs(angle_between((primary, secondary), (partner, secondary)) - sep) < 1e-4
            pairs.append({"system": system, "a": {"primary": primary, "secondary": secondary},
                          "b": {"primary": partner, "secondary": secondary}})
    return pairs


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("out")
    p.add_argument("--separations", default="5,10,15,20,30,45,60,75,90",
                   help="degrees, comma-separated (default %(default)s)")
    args = p.parse_args()
    try:
        separations = [float(x) for x in args.separations.split(",")]
    except ValueError:
        p.error(f"--separations must be comma-separated numbers, got '{args.separations}'")
    if len(set(separations)) != len(separations):
        p.error(f"--separations lists a separation twice: '{args.separations}'")
    bad = [s for s in separations if not 1 <= s <= 120]
    if bad:
        p.error(f"--separations must lie in [1, 120] degrees, got {bad}")
    doc = {"format": "gimm-views/1",
           "note": "tools/atlas/separation_views.py --separations " + args.separations,
           "pairs": sweep_pairs(separations)}
    with open(args.out, "w") as f:
        json.dump(doc, f, indent=1)
    print(f"separation_views: {len(doc['pairs'])} pairs -> {args.out}")


if __name__ == "__main__":
    main()
