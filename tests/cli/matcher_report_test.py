"""benchmarks/matcher/report.py's agreement of two engines' matches: the same matches in another
order and with rounding noise agree (they did not: sorted by the A point, two matches whose A x
differed by 1e-6 swapped places and looked 200 px apart); a moved match or another count does
not. Run by ctest (matcher_report)."""
import os
import random
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..",
                                "benchmarks", "matcher"))
from report import paired_difference  # noqa: E402

rng = random.Random(3)
# A column of refined A points: x equal up to rounding, y a cell (8 px) apart.
ours = [(100.0 + rng.uniform(-1e-6, 1e-6), 8.0 * k, 300.0 - 8 * k, 40.0 + k) for k in range(50)]
theirs = [(x + rng.uniform(-1e-4, 1e-4), y, u, v) for x, y, u, v in ours]
rng.shuffle(theirs)
same, diff = paired_difference(ours, theirs)
assert same and diff < 2e-4, (same, diff)
moved = list(theirs)
moved[7] = (moved[7][0], moved[7][1], moved[7][2] + 30, moved[7][3])
same, diff = paired_difference(ours, moved)
assert not same or diff >= 29, (same, diff)  # either way, not "the same"
collapsed = list(theirs)
collapsed[3] = collapsed[4]  # two of ours now map to one of theirs
assert not paired_difference(ours, collapsed)[0]
assert paired_difference(ours, theirs[:-1]) == (False, float("inf"))
assert paired_difference([], []) == (True, 0.0)
print("matcher_report_test: engines' matches are paired one to one in any order")
