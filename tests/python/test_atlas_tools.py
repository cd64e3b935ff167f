"""tools/atlas/f_from_matches.py: its error measure and its controlled sweep on a synthetic pair
whose answers are known (exact correspondences of two C-arm views)."""
import json
import os
import sys
import unittest

import numpy as np

import gimm

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "tools", "atlas"))
import f_from_matches  # noqa: E402


def synthetic_pair(n=400, seed=0):
    """F and n exact correspondences of LAO 30 / cranial 20 and RAO 30 / caudal 20."""
    a = gimm.CArm(primary_deg=30, secondary_deg=20, rows=256, cols=256, pixel_mm=1.0).camera()
    b = gimm.CArm(primary_deg=-30, secondary_deg=-20, rows=256, cols=256, pixel_mm=1.0).camera()
    points = np.random.default_rng(seed).uniform(-40, 40, size=(n, 3))
    return gimm.fundamental_from_cameras(a, b), a.project(points)[0], b.project(points)[0]


class FFromMatches(unittest.TestCase):
    def test_error_is_zero_for_the_true_f_and_infinite_without_one(self):
        F, a, b = synthetic_pair()
        self.assertLess(f_from_matches.f_error(F, a, b), 1e-6)
        self.assertEqual(f_from_matches.f_error(None, a, b), float("inf"))
        # A wrong F (another pair's) is off by pixels, not by nothing.
        other = gimm.fundamental_from_cameras(gimm.CArm(rows=256, cols=256, pixel_mm=1.0),
                                              gimm.CArm(primary_deg=60, rows=256, cols=256,
                                                        pixel_mm=1.0))
        self.assertGreater(f_from_matches.f_error(other, a, b), 3.0)

    def test_controlled_sweep_follows_count_and_outliers(self):
        pair = synthetic_pair()
        rng = np.random.default_rng(1)
        table = f_from_matches.controlled([pair] * 3, rng, (256, 256))
        # Fewer than 32 matches: the reference rule gives no F.
        for r in f_from_matches.OUTLIER_RATES:
            self.assertTrue(all(e == float("inf") for e in table[(16, r)]))
        # 256 clean matches with 1 px noise: F within about a pixel of the truth.
        self.assertLess(np.median(table[(256, 0.0)]), 1.5)
        # Half outliers: worse than clean at the same count.
        self.assertGreater(np.median(table[(64, 0.5)]), np.median(table[(64, 0.0)]))

    def test_cell_counts_missing_and_bad_fits_as_failures(self):
        median, failed, n = f_from_matches.cell([0.5, 1.0, 7.0, float("inf")])
        self.assertEqual(n, 4)
        self.assertAlmostEqual(failed, 0.5)
        self.assertAlmostEqual(median, 4.0)  # numpy's median of [0.5, 1, 7, inf]
        self.assertEqual(f_from_matches.fmt(float("inf"), 1.0), "no F (100%)")

    def test_matcher_output_measures_outlier_rate_against_the_true_f(self):
        F, a, b = synthetic_pair(n=100)
        tmp = os.path.join(os.environ.get("GIMM_TEST_TMP", "/tmp"), "f_from_matches")
        os.makedirs(os.path.join(tmp, "p0"), exist_ok=True)
        # A quarter of the matches moved 20 px across their epipolar lines (well beyond 3 px).
        lines = gimm.epipolar_lines_b(F, a)
        normals = lines[:, :2] / np.linalg.norm(lines[:, :2], axis=1, keepdims=True)
        wrong = b.copy()
        wrong[:25] += 20.0 * normals[:25]
        with open(os.path.join(tmp, "p0", "LCA_00-01.json"), "w") as f:
            json.dump({"points_a": a.tolist(), "points_b": wrong.tolist(),
                       "confidence": [1.0] * len(a)}, f)
        rows = f_from_matches.matcher_output(tmp, [("p0", "LCA_00-01", ""),
                                                   ("p0", "LCA_00-02", "")],
                                             [(F, a, b), (F, a, b)])
        self.assertEqual(len(rows), 1)  # the second pair has no predictions file
        count, outliers, _ = rows[0]
        self.assertEqual(count, 100)
        self.assertAlmostEqual(outliers, 0.25)


if __name__ == "__main__":
    unittest.main()
