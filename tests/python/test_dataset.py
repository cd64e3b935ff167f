"""gimm.Dataset and gimm.match_baseline against the CLIs on the same gimm-dataset folder:
the pairs read as gimm-eval reads them, the baselines equal to gimm-baseline's files, and the
scores of evaluate() over the dataset equal to gimm-eval's."""
import glob
import json
import os
import shutil
import unittest

import numpy as np

import gimm
from common import cli, run, tmp_path


_MADE = []


def dataset():
    """A one-patient dataset made by this build's gimm-dataset (64 x 80 px views), or None. Made
    once per run, never taken from an earlier run (an older gimm-dataset's files)."""
    exe = cli("gimm-dataset")
    if exe is None:
        return None
    root = tmp_path("dataset", "ds", "x")[:-2]
    if not _MADE:
        shutil.rmtree(root, ignore_errors=True)
        run(exe, "--phantom", 1, "--style", "drr", "--rows", 64, "--cols", 80, "--pixel", 3.0,
            "--seed", 5, "--out", root, "--quiet")
        _MADE.append(root)
    return root


class DatasetTest(unittest.TestCase):
    def setUp(self):
        self.root = dataset()
        if self.root is None:
            self.skipTest("gimm-dataset not built")
        self.ds = gimm.Dataset(self.root)

    def test_pairs_as_written(self):
        ids = self.ds.pair_ids()
        self.assertEqual(len(ids), 27)  # LCA 7 views, RCA 4
        self.assertEqual(self.ds.patients(), ["phantom-0000"])
        self.assertEqual(sorted(ids), sorted(self.ds.pair_ids("train") + self.ds.pair_ids("val")
                                             + self.ds.pair_ids("test")))
        pair = self.ds.pair(ids[0])
        patient, name = ids[0].split("/")
        with open(os.path.join(self.root, "patients", patient, "pairs", name + ".json")) as f:
            written = json.load(f)
        fields = written["dense_fields"]
        dense = np.asarray(written["dense"], float).reshape(-1, len(fields))
        col = lambda key: dense[:, fields.index(key)]  # noqa: E731
        np.testing.assert_array_equal(pair["points_a"], np.stack([col("u_a"), col("v_a")], 1))
        np.testing.assert_array_equal(pair["points_b"], np.stack([col("u_b"), col("v_b")], 1))
        np.testing.assert_array_equal(pair["world_mm"],
                                      np.stack([col("x_mm"), col("y_mm"), col("z_mm")], 1))
        np.testing.assert_array_equal(pair["F"], np.asarray(written["F"]))
        self.assertEqual((pair["view_a"], pair["view_b"]), (written["view_a"], written["view_b"]))
        self.assertEqual(pair["view_class_a"], written["view_class_a"])
        self.assertEqual(pair["system"], name[:3])
        self.assertEqual(pair["mask_a"].shape, (64, 80))
        self.assertEqual(pair["mask_a"].dtype, np.uint8)
        self.assertTrue(pair["mask_a"].any())
        # The camera and the image of view A, as gimm-match reads them.
        camera = self.ds.camera(patient, pair["view_a"])
        self.assertEqual(camera.shape, (64, 80))
        uv, _ = camera.project(pair["world_mm"])
        np.testing.assert_allclose(uv, pair["points_a"], atol=1e-6)
        image = self.ds.image(patient, pair["view_a"])
        np.testing.assert_array_equal(
            image, gimm.read_png(os.path.join(self.root, "patients", patient, "views",
                                              pair["view_a"] + ".png")))
        self.assertEqual(self.ds.manifest["format"], "gimm-dataset/2")

    def test_baselines_equal_gimm_baseline_and_scores_equal_gimm_eval(self):
        baseline, evaluate = cli("gimm-baseline"), cli("gimm-eval")
        if baseline is None or evaluate is None:
            self.skipTest("gimm-baseline / gimm-eval not built")
        for method, flags, kwargs in (("epipolar", ["--max-points", 50], {"max_points": 50}),
                                      ("oracle", ["--sigma", 1.5], {"sigma_px": 1.5})):
            pred = tmp_path("dataset", "pred-" + method, "x")[:-2]
            run(baseline, "--dataset", self.root, "--method", method, "--seed", 4, "--out", pred,
                *flags)
            truths, mine = [], []
            for pair_id in self.ds.pair_ids():
                truth = self.ds.pair(pair_id)
                ours = gimm.match_baseline(truth, method, seed=4, **kwargs)
                theirs = gimm.read_matches(os.path.join(pred, pair_id + ".json"))
                for key in ("points_a", "points_b", "confidence"):
                    np.testing.assert_array_equal(ours[key], theirs[key], err_msg=pair_id)
                truths.append(truth)
                mine.append(ours)
            out = tmp_path("dataset", "eval-" + method, "x")[:-2]
            run(evaluate, "--dataset", self.root, "--predictions", pred, "--out", out)
            with open(os.path.join(out, "summary.json")) as f:
                reference = json.load(f)["pooled"]
            # evaluate_dataset is gimm-eval --dataset's job: the same summary, the same files.
            ours = gimm.evaluate_dataset(self.root, pred)
            self.assertEqual(ours.pop("missing"), [])
            with open(os.path.join(out, "summary.json")) as f:
                self.assertEqual(ours, json.load(f))
            mine_out = tmp_path("dataset", "evalpy-" + method)
            shutil.rmtree(mine_out, ignore_errors=True)
            gimm.evaluate_dataset(self.root, pred, out=mine_out)
            for name in ("summary.json", "table.md", "worst_pairs.md", "topk.tsv"):
                with open(os.path.join(out, name), "rb") as a, \
                        open(os.path.join(mine_out, name), "rb") as b:
                    self.assertEqual(a.read(), b.read(), name)
            pooled = gimm.evaluate(truths, mine)["pooled"]
            for key, value in reference.items():
                if value is None:
                    self.assertIsNone(pooled[key], key)
                else:
                    self.assertAlmostEqual(pooled[key], value, places=12, msg=(method, key))
        self.assertGreater(len(glob.glob(os.path.join(pred, "*", "*.json"))), 0)

    def test_match_dataset_writes_what_the_clis_write(self):
        """gimm.match_dataset is gimm-match --dataset's and gimm-baseline's job: the same files,
        byte for byte, for the geometric matcher, the learned one and a baseline."""
        match, baseline = cli("gimm-match"), cli("gimm-baseline")
        if match is None or baseline is None:
            self.skipTest("gimm-match / gimm-baseline not built")
        cases = (
            ("geometric", [match, "--method", "geometric", "--segment"], {"segment": True}),
            (gimm.Matcher(), [match], {}),
            ("oracle", [baseline, "--method", "oracle", "--sigma", 2, "--seed", 3],
             {"sigma_px": 2.0, "seed": 3}),
        )
        for n, (matcher, command, options) in enumerate(cases):
            theirs = tmp_path("dataset", "cli-%d" % n, "x")[:-2]
            ours = tmp_path("dataset", "py-%d" % n, "x")[:-2]
            for folder in (theirs, ours):
                shutil.rmtree(folder, ignore_errors=True)
            run(*command, "--dataset", self.root, "--out", theirs)
            done = gimm.match_dataset(self.root, ours, matcher, **options)
            self.assertEqual(done["pairs"], 27)
            self.assertFalse(done["formed"])  # a drr-style dataset has no formed views
            files = sorted(os.path.relpath(f, theirs)
                           for f in glob.glob(os.path.join(theirs, "*", "*.json")))
            self.assertEqual(len(files), 27)
            self.assertEqual(files, sorted(os.path.relpath(f, ours)
                                           for f in glob.glob(os.path.join(ours, "*", "*.json"))))
            total = 0
            for f in files:
                with open(os.path.join(theirs, f), "rb") as a, open(os.path.join(ours, f), "rb") as b:
                    self.assertEqual(a.read(), b.read(), (matcher, f))
                total += len(gimm.read_matches(os.path.join(ours, f))["confidence"])
            self.assertEqual(total, done["matches"])
        geometric = gimm.read_matches(os.path.join(ours.replace("py-2", "py-0"), files[0]))
        self.assertEqual(geometric["F_source"], "cameras")  # the F the matches follow

    def test_match_dataset_refuses_what_it_would_ignore(self):
        out = tmp_path("dataset", "refused")
        shutil.rmtree(out, ignore_errors=True)
        with self.assertRaisesRegex(ValueError, r"'sigma_px'.*not options of the geometric"):
            gimm.match_dataset(self.root, out, "geometric", sigma_px=1.0)
        with self.assertRaisesRegex(ValueError, "matcher must be a gimm.Matcher or 'geometric'"):
            gimm.match_dataset(self.root, out, "nearest")
        with self.assertRaisesRegex(ValueError, "images must be 'auto', 'rendered' or 'formed'"):
            gimm.match_dataset(self.root, out, "oracle", images="x")
        with self.assertRaisesRegex(gimm.Error, "MatchRunOptions::images formed: .* no formed"):
            gimm.match_dataset(self.root, out, "geometric", images="formed")
        with self.assertRaisesRegex(gimm.Error, "oracle matcher does not look at them"):
            gimm.match_dataset(self.root, out, "oracle", noise_photons=100)
        with self.assertRaisesRegex(gimm.Error, "camera_error moves the cameras"):
            gimm.match_dataset(self.root, out, "geometric", use_cameras=False,
                               camera_error_deg=1.0)
        with self.assertRaisesRegex(gimm.Error, r"CameraError::deg must be in \[0, 45\]"):
            gimm.match_dataset(self.root, out, "geometric", camera_error_deg=90.0)
        with self.assertRaisesRegex(gimm.Error, "no pairs in"):
            gimm.match_dataset(self.root, out, "oracle", split="test")
        self.assertFalse(os.path.exists(out))  # nothing written by a refused run

    def test_evaluate_dataset_names_what_is_missing_or_wrong(self):
        pred = tmp_path("dataset", "pred-partial")
        shutil.rmtree(pred, ignore_errors=True)
        ids = self.ds.pair_ids()
        gimm.match_dataset(self.root, pred, "oracle")
        os.remove(os.path.join(pred, ids[0] + ".json"))
        scored = gimm.evaluate_dataset(self.root, pred, top_k=0, method="oracle")
        self.assertEqual(scored["missing"], [ids[0]])
        self.assertEqual(scored["method"], "oracle")
        self.assertEqual(scored["pooled"]["missing_pairs"], 1)
        self.assertEqual(len(scored["pairs"]), len(ids))
        with self.assertRaisesRegex(gimm.Error, "predictions directory .* does not exist"):
            gimm.evaluate_dataset(self.root, tmp_path("dataset", "nothing-here"))
        with self.assertRaisesRegex(ValueError, "top_k must be >= 0"):
            gimm.evaluate_dataset(self.root, pred, top_k=-1)
        with self.assertRaisesRegex(gimm.Error, "out"):
            gimm.evaluate_dataset(self.root, pred, out=pred)  # out over the predictions

    def test_bad_input_is_named(self):
        with self.assertRaisesRegex(gimm.Error, "nowhere"):
            gimm.Dataset(tmp_path("dataset", "nowhere"))
        with self.assertRaisesRegex(gimm.IoError, "phantom-0000/pairs/LCA_99-98.json"):
            self.ds.pair("phantom-0000/LCA_99-98")
        truth = self.ds.pair(self.ds.pair_ids()[0])
        with self.assertRaisesRegex(ValueError, "method must be 'epipolar' or 'oracle', got 'x'"):
            gimm.match_baseline(truth, "x")
        with self.assertRaisesRegex(ValueError, "sigma_px must be finite"):
            gimm.match_baseline(truth, "oracle", sigma_px=float("nan"))
        with self.assertRaisesRegex(ValueError, "max_points must be > 0"):
            gimm.match_baseline(truth, max_points=0)


if __name__ == "__main__":
    unittest.main()
