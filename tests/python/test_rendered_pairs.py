"""gimm.torch (and tools/train/rendered_pairs.py over it): the on-the-fly training source gives
what gimm-dataset writes for the same patient and view angles (images, masks, classes, dense
labels), its stream is deterministic, and DataLoader batches it with workers. Skipped without PyTorch (scripts/install-deps.sh train)."""
import glob
import itertools
import json
import os
import shutil
import sys
import unittest

import numpy as np

from common import cli, run, tmp_path

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "tools", "train"))

try:
    import torch  # noqa: F401
except ImportError:
    torch = None


@unittest.skipIf(torch is None, "PyTorch missing (scripts/install-deps.sh train)")
class RenderedPairsTest(unittest.TestCase):
    def test_same_pairs_as_gimm_dataset(self):
        from gimm_data import load_pairs
        from rendered_pairs import render_patient
        exe = cli("gimm-dataset")
        if exe is None:
            self.skipTest("gimm-dataset not built")
        root = tmp_path("rendered", "dataset", "x")[:-2]
        shutil.rmtree(root, ignore_errors=True)  # this build's files, never an earlier run's
        run(exe, "--phantom", 1, "--style", "drr", "--rows", 64, "--cols", 80, "--pixel", 3.0,
            "--seed", 3, "--out", root, "--quiet")
        # The patient's seed (pipeline/patient.hpp phantom_sources: seed * 1000003 + index) and
        # the angles gimm-dataset drew for each view class.
        angles = {}
        for path in glob.glob(os.path.join(root, "patients", "*", "views", "*.camera.json")):
            with open(path) as f:
                cam = json.load(f)
            angles[(cam["system"], cam["view_class"])] = (cam["primary_deg"], cam["secondary_deg"])
        split = next(s for s in ("train", "val", "test")
                     if os.path.getsize(os.path.join(root, "splits", s + ".txt")) > 0)
        written = {(os.path.basename(p.path)[:3], p.class_a, p.class_b): p
                   for p in load_pairs(root, split, 40, progress=False)}
        mine = render_patient(3 * 1000003, lambda system, c: angles[(system, c)], 40, rows=64,
                              cols=80, pixel_mm=3.0)
        self.assertEqual(len(mine), len(written))
        self.assertEqual(len(mine), 21 + 6)  # LCA: 7 classes, RCA: 4
        self.assertGreater(sum(len(p.a) for p in mine), 27 * 10)  # labels in every pair
        for pair in mine:
            key = (pair.path.split("/")[1][:3], pair.class_a, pair.class_b)
            ref = written[key]
            self.assertEqual(pair.scale, ref.scale)
            np.testing.assert_array_equal(pair.mask_a, ref.mask_a, err_msg=str(key))
            np.testing.assert_array_equal(pair.mask_b, ref.mask_b, err_msg=str(key))
            # 16-bit quantised the same way, then resized: equal to float16 rounding.
            np.testing.assert_allclose(pair.image_a.float(), ref.image_a.float(), atol=1e-3)
            np.testing.assert_allclose(pair.image_b.float(), ref.image_b.float(), atol=1e-3)
            self.assertEqual(len(pair.a), len(ref.a), key)
            np.testing.assert_allclose(pair.a_full, ref.a_full, atol=1e-9)
            np.testing.assert_allclose(pair.b_full, ref.b_full, atol=1e-9)
            np.testing.assert_allclose(pair.world, ref.world, atol=1e-9)
            np.testing.assert_allclose(pair.a, ref.a, atol=1e-5)

    def test_stream_is_deterministic_and_varies_the_views(self):
        from rendered_pairs import RenderedPairs
        take = lambda seed: list(itertools.islice(iter(RenderedPairs([5], size=32, rows=48,  # noqa
                                                                     cols=48, pixel_mm=5.0,
                                                                     seed=seed)), 40))
        first, again, other = take(1), take(1), take(2)
        self.assertEqual([p.path for p in first], [p.path for p in again])
        for p, q in zip(first, again):
            np.testing.assert_array_equal(p.a_full, q.a_full)
        # 27 pairs per visit: pairs 28-40 are the same patient seen again with new views.
        by_name = {}
        for p in first:
            by_name.setdefault(p.path, []).append(p)
        revisited = [ps for ps in by_name.values() if len(ps) > 1]
        self.assertTrue(revisited)
        for ps in revisited:
            self.assertFalse(np.array_equal(ps[0].image_a.float(), ps[1].image_a.float()))
        self.assertNotEqual([p.a_full.shape for p in first], [p.a_full.shape for p in other])

    def test_dataloader_batches_dicts_with_workers(self):
        """gimm.torch: DataLoader(batch_size=4, num_workers=2) with collate_pairs yields batches
        of tensors; the two workers draw different views; the same seed gives the same batches."""
        from torch.utils.data import DataLoader

        from gimm.torch import RenderedPairs, collate_pairs

        def batches(seed):
            pairs = RenderedPairs([5, 6], size=32, rows=48, cols=48, pixel_mm=5.0, seed=seed)
            loader = DataLoader(pairs, batch_size=4, num_workers=2, collate_fn=collate_pairs)
            return list(itertools.islice(iter(loader), 3))

        first = batches(1)
        b = first[0]
        self.assertEqual(tuple(b["image_a"].shape), (4, 1, 32, 32))
        self.assertEqual(b["image_a"].dtype, torch.float32)
        self.assertEqual(tuple(b["class_a"].shape), (4,))
        self.assertEqual(tuple(b["mask_a"].shape), (4, 48, 48))
        self.assertEqual(tuple(b["scale"].shape), (4, 2))
        self.assertEqual(len(b["points_a"]), 4)
        self.assertEqual(len(b["name"]), 4)
        for pa, pb, w in zip(b["points_a"], b["points_b"], b["world_mm"]):
            self.assertEqual(pa.shape[1], 2)
            self.assertEqual(len(pa), len(pb))
            self.assertEqual(len(pa), len(w))
        # Workers take turns by batch: batch 0 from worker 0, batch 1 from worker 1, whose
        # streams differ.
        self.assertNotEqual(first[0]["name"] + [float(first[0]["image_a"].sum())],
                            first[1]["name"] + [float(first[1]["image_a"].sum())])
        again = batches(1)
        for x, y in zip(first, again):
            self.assertEqual(x["name"], y["name"])
            self.assertTrue(torch.equal(x["image_a"], y["image_a"]))

    def test_bad_sources_are_named(self):
        from rendered_pairs import RenderedPairs
        with self.assertRaisesRegex(ValueError, "no sources"):
            RenderedPairs([])
        with self.assertRaisesRegex(ValueError, "bad size 4"):
            RenderedPairs([1], size=4)
        import gimm
        stream = iter(RenderedPairs([("/nonexistent/ct.nii.gz", "/nonexistent/label.nii.gz")]))
        with self.assertRaisesRegex(gimm.Error, "ct.nii.gz"):
            next(stream)


if __name__ == "__main__":
    unittest.main()
