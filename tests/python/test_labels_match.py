"""Anatomy, labels, the learned matcher and the evaluation from Python, against gimm-match and
gimm-eval where they are built."""
import json
import os
import unittest

import numpy as np

import gimm
from common import carm, cli, is_capsule_view, lca, phantom, renderer, run, tmp_path

VIEW_A, VIEW_B = (40.0, 20.0), (-30.0, 20.0)  # LCA: LAO cranial (class 8), RAO cranial (10)
VIEW_B_NEAR = (10.0, 20.0)  # 30 degrees from VIEW_A


class Anatomy(unittest.TestCase):
    def test_phantom_centerlines_as_arrays(self):
        p = phantom()
        for system in ("LCA", "RCA"):
            c = p["centerlines"][system]
            n = len(c["points"])
            self.assertGreater(n, 50)
            self.assertEqual(c["points"].shape, (n, 3))
            for key in ("radius", "branch", "index"):
                self.assertEqual(c[key].shape, (n,), key)
            self.assertEqual(c["branch"].dtype, np.int32)
            self.assertTrue((c["radius"] > 0).all())
            self.assertEqual(len(c["branch_names"]), len(c["branch_parents"]))
            self.assertEqual({c["branch_systems"][b] for b in c["branch"]}, {system})
        names = p["centerlines"]["LCA"]["branch_names"]
        self.assertIn("LAD", names)
        split = gimm.split_coronary_systems(p["label"], p["geometry"])
        self.assertEqual(split["lca_voxels"], int(split["lca"].sum()))
        self.assertEqual(split["lca_voxels"] + split["rca_voxels"] + split["dropped_voxels"],
                         int(p["label"].sum()))
        # LPS: the left tree lies further to the patient's left (+x) than the right one.
        lx = p["centerlines"]["LCA"]["points"][:, 0].mean()
        rx = p["centerlines"]["RCA"]["points"][:, 0].mean()
        self.assertGreater(lx, rx)

    def test_extracted_centerlines_follow_the_analytic_ones(self):
        p = phantom()
        extracted = gimm.extract_centerlines(lca(), p["geometry"], system="LCA")
        truth = p["centerlines"]["LCA"]["points"]
        d = np.linalg.norm(extracted["points"][:, None, :] - truth[None, :, :], axis=2).min(axis=1)
        self.assertLess(np.median(d), 2.0)  # mm, on a 1.6 x 1.6 x 2 mm grid

    def test_view_protocol(self):
        views = gimm.routine_views()
        self.assertEqual([v["id"] for v in views], list(range(1, 12)))
        self.assertEqual(gimm.view_class_from_angles(*VIEW_A, system="LCA"), (8, 0.0))
        self.assertEqual(gimm.view_class_from_angles(*VIEW_B, system="LCA"), (10, 0.0))
        self.assertEqual(gimm.view_class_from_angles(0, 0)[0], 5)
        self.assertGreater(gimm.view_class_from_angles(90, 0)[1], 20)
        primary, secondary = gimm.sample_view(8, seed=3)
        self.assertTrue(25 <= primary <= 65 and 10 <= secondary <= 35)
        self.assertEqual(gimm.sample_view(8, seed=3), (primary, secondary))
        with self.assertRaisesRegex(gimm.Error, "view class id must be in 1..11, got 12"):
            gimm.sample_view(12)
        with self.assertRaisesRegex(gimm.Error, "LCA"):
            gimm.view_class_from_angles(0, 0, system="LAD")

    def test_plan_views_as_gimm_dataset_plans(self):
        ranges = {v["id"]: v for v in gimm.routine_views()}
        for system, classes in (("LCA", 7), ("RCA", 4)):
            plan = gimm.plan_views(system, seed=5)
            self.assertEqual(len(plan["views"]), classes)
            self.assertEqual(len(plan["pairs"]), classes * (classes - 1) // 2)
            self.assertEqual({ranges[v["view_class"]]["system"] for v in plan["views"]}, {system})
            for v in plan["views"]:  # inside the class's ranges widened by the 5 deg jitter
                lo, hi = ranges[v["view_class"]]["primary_deg"]
                self.assertTrue(lo - 5 <= v["primary_deg"] <= hi + 5, v)
                lo, hi = ranges[v["view_class"]]["secondary_deg"]
                self.assertTrue(lo - 5 <= v["secondary_deg"] <= hi + 5, v)
            for a, b in plan["pairs"]:
                self.assertLess(plan["views"][a]["view_class"], plan["views"][b]["view_class"])
            self.assertEqual(plan, gimm.plan_views(system, seed=5))
            self.assertNotEqual(plan, gimm.plan_views(system, seed=6))
            per_pair = gimm.plan_views(system, mode="per_pair", seed=5)
            self.assertEqual(len(per_pair["views"]), 2 * len(plan["pairs"]))
            self.assertEqual(per_pair["pairs"][0], (0, 1))
        with self.assertRaisesRegex(gimm.Error, "shared|per_pair"):
            gimm.plan_views("LCA", mode="both")


class Labels(unittest.TestCase):
    def test_label_view_projects_with_the_camera(self):
        points = phantom()["centerlines"]["LCA"]
        camera = carm(*VIEW_A).camera()
        view = renderer().render(camera)
        labels = gimm.label_view(points, camera, view["vessel_mask"], renderer=renderer())
        uv, depth = camera.project(points["points"])
        np.testing.assert_array_equal(labels["uv"], uv)
        np.testing.assert_array_equal(labels["depth"], depth)
        self.assertTrue(labels["in_image"].all())
        self.assertGreater(labels["on_mask"].mean(), 0.8)
        np.testing.assert_array_equal(labels["valid"],
                                      labels["in_front"] & labels["in_image"] & labels["on_mask"])
        self.assertGreater(labels["visible"].mean(), 0.5)
        plain = gimm.label_view(points["points"], camera)  # (N, 3) points, no mask
        self.assertTrue(plain["on_mask"].all() and plain["visible"].all())

    def test_label_pair_is_consistent_with_F(self):
        points = phantom()["centerlines"]["LCA"]
        a, b = carm(*VIEW_A), carm(*VIEW_B)
        ma = renderer().render(a)["vessel_mask"]
        mb = renderer().render(b)["vessel_mask"]
        pair = gimm.label_pair(points, a, b, ma, mb, sparse_count=20, seed=1)
        m = len(pair["points_a"])
        self.assertGreater(m, 100)
        self.assertLess(gimm.symmetric_epipolar_distance_sq(pair["F"], pair["points_a"],
                                                            pair["points_b"]).max(), 1e-12)
        np.testing.assert_allclose(a.camera().project(pair["world_mm"])[0], pair["points_a"])
        self.assertEqual(len(set(pair["sparse"].tolist())), 20)
        self.assertLess(pair["sparse"].max(), m)
        # The sparse labels are farthest-point sampling of the dense ones' world points.
        np.testing.assert_array_equal(
            gimm.farthest_point_sampling(pair["world_mm"], 20, seed=1), pair["sparse"])
        fps = gimm.farthest_point_sampling(pair["world_mm"], 5, seed=9)
        d = np.linalg.norm(pair["world_mm"][:, None] - pair["world_mm"][fps[:4]][None], axis=2)
        self.assertEqual(fps[4], d.min(axis=1).argmax())  # the farthest from the first four
        self.assertEqual(len(gimm.farthest_point_sampling(pair["world_mm"][:3], 10)), 3)
        self.assertIs(pair["mask_a"], ma)
        # Exact predictions score perfectly under the protocol.
        exact = {"points_a": pair["points_a"], "points_b": pair["points_b"]}
        pooled = gimm.evaluate(pair, exact, top_k=0)["pooled"]
        self.assertEqual(pooled["prec_1px"], 1.0)
        self.assertEqual(pooled["mean_px"], 0.0)
        self.assertEqual(pooled["mean_mm"], 0.0)
        self.assertEqual(pooled["coverage"], 1.0)


class Matching(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.matcher = gimm.Matcher()

    def test_matcher_returns_finite_arrays_gated_by_the_exact_F(self):
        self.assertEqual(self.matcher.input_size, 128)
        a, b = carm(*VIEW_A), carm(*VIEW_B)
        ia = renderer().render(a)["intensity"]
        ib = renderer().render(b)["intensity"]
        out = self.matcher.match(ia, ib, 8, 10, a.camera(), b.camera())
        n = len(out["confidence"])
        self.assertGreater(out["candidates"], 10)  # the phantom-trained network: a few dozen
        self.assertGreater(n, 0)
        self.assertEqual(out["points_a"].shape, (n, 2))
        self.assertEqual(out["points_b"].shape, (n, 2))
        for key in ("points_a", "points_b", "confidence"):
            self.assertTrue(np.isfinite(out[key]).all(), key)
        self.assertEqual(out["F_source"], "cameras")
        np.testing.assert_allclose(out["F"], gimm.fundamental_from_cameras(a, b))
        # The shipped weights' recorded gate by default: hard 4 px, then B snapped onto its line.
        d2 = gimm.symmetric_epipolar_distance_sq(out["F"], out["points_a"], out["points_b"])
        self.assertLessEqual(d2.max(), 1e-6)
        self.assertEqual(n + out["dropped_by_gate"] + out["dropped_in_padding"],
                         out["candidates"])
        # Each argument given overrides its recorded value.
        tight = self.matcher.match(ia, ib, 8, 10, a.camera(), b.camera(), delta_px=2.0,
                                   snap_to_epipolar=False)
        d2 = gimm.symmetric_epipolar_distance_sq(tight["F"], tight["points_a"], tight["points_b"])
        self.assertLessEqual(d2.max(), 4.0 + 1e-9)  # the hard gate: <= 2 px
        self.assertGreater(d2.max(), 1e-6)  # not snapped
        self.assertGreater(tight["dropped_by_gate"], out["dropped_by_gate"])
        self.assertTrue(is_capsule_view(out["confidence"]))
        # Without cameras: F from the matches (or none), nothing dropped by a gate off.
        free = self.matcher.match(ia, ib, 8, 10, gate="none")
        self.assertEqual(free["F_source"], "none")
        self.assertEqual(free["dropped_by_gate"], 0)
        # Exposed fields: a match with an end outside its field is dropped and counted.
        left = np.zeros(ia.shape, np.uint8)
        left[:, :ia.shape[1] // 2] = 1
        inside = self.matcher.match(ia, ib, 8, 10, gate="none", field_a=left)
        expected = np.rint(free["points_a"][:, 0]) < ia.shape[1] // 2
        self.assertGreater(expected.sum(), 0)
        self.assertLess(expected.sum(), len(expected))
        np.testing.assert_array_equal(inside["points_a"], free["points_a"][expected])
        self.assertEqual(inside["dropped_outside_field"], int((~expected).sum()))
        with self.assertRaisesRegex(ValueError, "field_b is 3 x 2, its image"):
            self.matcher.match(ia, ib, field_b=np.ones((2, 3), np.uint8))
        # Scored against the pair's labels: finite numbers.
        pair = gimm.label_pair(phantom()["centerlines"]["LCA"], a, b,
                               renderer().render(a)["vessel_mask"],
                               renderer().render(b)["vessel_mask"])
        pooled = gimm.evaluate(pair, out)["pooled"]
        self.assertGreater(pooled["scored"], 0)
        self.assertTrue(np.isfinite(pooled["mean_px"]) and np.isfinite(pooled["prec_3px"]))

    def rendered_pair(self, size=128, views=(VIEW_A, VIEW_B)):
        """gimm-drr's two views of the phantom, size x size pixels over 256 mm: their file
        prefixes (PNG, camera JSON)."""
        drr = cli("gimm-drr")
        if drr is None or cli("gimm-match") is None:
            self.skipTest("gimm-drr / gimm-match not built")
        key = "" if (size, views) == (128, (VIEW_A, VIEW_B)) else f"-{size}-{views[1][0]:g}"
        prefixes = [tmp_path("match", name + key) for name in ("a", "b")]
        if all(os.path.exists(prefix + ".camera.json") for prefix in prefixes):
            return prefixes
        p = phantom()
        hu, label = tmp_path("match", "hu.nii.gz"), tmp_path("match", "label.nii.gz")
        gimm.write_nifti(hu, p["hu"], p["geometry"])
        gimm.write_nifti(label, p["label"], p["geometry"])
        for prefix, (primary, secondary) in zip(prefixes, views):
            run(drr, "--volume", hu, "--label", label, "--system", "LCA", "--primary", primary,
                "--secondary", secondary, "--rows", size, "--cols", size, "--pixel", 256.0 / size,
                "--out", prefix, "--quiet")
        return prefixes

    def test_same_matches_as_gimm_match(self):
        prefixes, match = self.rendered_pair(), cli("gimm-match")
        out = tmp_path("match", "matches.json")
        run(match, "--image-a", prefixes[0] + ".png", "--image-b", prefixes[1] + ".png",
            "--class-a", 8, "--class-b", 10, "--camera-a", prefixes[0] + ".camera.json",
            "--camera-b", prefixes[1] + ".camera.json", "--out", out)
        reference = gimm.read_matches(out)
        mine = self.matcher.match(gimm.read_png(prefixes[0] + ".png"),
                                  gimm.read_png(prefixes[1] + ".png"), 8, 10,
                                  gimm.read_camera(prefixes[0] + ".camera.json"),
                                  gimm.read_camera(prefixes[1] + ".camera.json"))
        self.assertGreater(len(reference["confidence"]), 0)
        for key in ("points_a", "points_b", "confidence", "F"):
            np.testing.assert_allclose(mine[key], reference[key], rtol=1e-12, atol=1e-12,
                                       err_msg=key)
        self.assertEqual(reference["F_source"], mine["F_source"])

    def geometric_same_as_gimm_match(self, *extra):
        # 256 px of 1 mm and views 30 degrees apart, where the segmenting matcher is at its best
        # (docs/stability.md): at 128 px of 2 mm and 70 degrees (VIEW_A, VIEW_B) it keeps 3
        # matches, too few to compare.
        prefixes, match = self.rendered_pair(256, (VIEW_A, VIEW_B_NEAR)), cli("gimm-match")
        images = [gimm.read_png(prefix + ".png") for prefix in prefixes]
        cameras = [gimm.read_camera(prefix + ".camera.json") for prefix in prefixes]
        out = tmp_path("match", "geometric.json")
        run(match, "--method", "geometric", "--image-a", prefixes[0] + ".png", "--image-b",
            prefixes[1] + ".png", "--camera-a", prefixes[0] + ".camera.json", "--camera-b",
            prefixes[1] + ".camera.json", "--out", out, *extra)
        reference = gimm.read_matches(out)
        mine = gimm.match_geometric(*images, *cameras,
                                    exact_vesselness="--exact-vesselness" in extra,
                                    keep_catheter="--keep-catheter" in extra)
        # 8 matches fast, 10 exact since the tree prior (29-30 before); on this pair most of them
        # join rib edges of the two views, so this compares the two front ends, not accuracy.
        # The catheter cue drops the straight rib edges: fast and with the cue, none is left
        # (so the fast kernels are compared with --keep-catheter), exact and with it, 5.
        self.assertGreaterEqual(len(reference["confidence"]), 5, extra)
        for key in ("points_a", "points_b", "confidence", "F"):
            np.testing.assert_allclose(mine[key], reference[key], rtol=1e-12, atol=1e-12,
                                       err_msg=f"{key} {extra}")
        self.assertEqual(mine["F_source"], "cameras")
        # The triangulated points reproject onto both matched pixels (within the tolerance).
        world = mine["world_mm"]
        self.assertEqual(world.shape, (len(mine["confidence"]), 3))
        for camera, key in zip(cameras, ("points_a", "points_b")):
            homog = np.c_[world, np.ones(len(world))] @ np.asarray(camera.P).T
            reprojected = homog[:, :2] / homog[:, 2:]
            self.assertLess(np.median(np.linalg.norm(reprojected - mine[key], axis=1)), 1.5)

    def test_geometric_same_matches_as_gimm_match(self):
        self.geometric_same_as_gimm_match("--keep-catheter")

    # The reference kernels in both. (gimm-match used to apply --exact-vesselness only with
    # --dataset: on one pair it ran the fast kernels, 29 matches against the module's 30.)
    def test_geometric_exact_vesselness_same_matches_as_gimm_match(self):
        self.geometric_same_as_gimm_match("--exact-vesselness")

    def test_geometric_exact_vesselness_keep_catheter_same_matches_as_gimm_match(self):
        self.geometric_same_as_gimm_match("--exact-vesselness", "--keep-catheter")

    def test_geometric_repeated_calls_agree(self):
        # The module keeps the matcher's working memory between calls: a pair matched again
        # after pairs of another size and mode gives what it gave the first time.
        # Segmented: 8 matches, on rib edges the catheter cue would drop (kept here).
        big = [carm(*VIEW_A, size=256), carm(*VIEW_B_NEAR, size=256)]
        small = [carm(*VIEW_A), carm(*VIEW_B)]
        render = renderer()
        rendered = {id(c): render.render(c) for c in big + small}

        def match(cameras, masks=False):
            r = [rendered[id(c)] for c in cameras]
            extra = (dict(mask_a=r[0]["vessel_mask"], mask_b=r[1]["vessel_mask"]) if masks else
                     dict(keep_catheter=True))
            return gimm.match_geometric(r[0]["intensity"], r[1]["intensity"], *cameras, **extra)

        first = [match(big), match(small, masks=True)]
        self.assertGreaterEqual(len(first[0]["confidence"]), 5)
        self.assertGreater(len(first[1]["confidence"]), 10)
        again = [match(small, masks=True), match(big)]
        for was, now in zip(first, reversed(again)):
            for key in ("points_a", "points_b", "confidence", "margin", "world_mm"):
                np.testing.assert_array_equal(was[key], now[key], err_msg=key)

    def test_geometric_masks_and_bad_input(self):
        a, b = carm(*VIEW_A), carm(*VIEW_B)
        rendered = [renderer().render(camera) for camera in (a, b)]
        found = gimm.match_geometric(rendered[0]["intensity"], rendered[1]["intensity"], a, b,
                                     mask_a=rendered[0]["vessel_mask"],
                                     mask_b=rendered[1]["vessel_mask"])
        self.assertGreater(len(found["confidence"]), 10)
        # With masks every A point lies on A's vessel mask.
        mask = rendered[0]["vessel_mask"]
        cols, rows = np.rint(found["points_a"]).astype(int).T
        self.assertTrue(np.all(mask[rows, cols] != 0))
        image = rendered[0]["intensity"]
        with self.assertRaisesRegex(ValueError, "both mask_a and mask_b, or neither"):
            gimm.match_geometric(image, image, a, b, mask_a=mask)
        small = np.ones((32, 32), np.float32)
        with self.assertRaisesRegex(gimm.Error, "camera A is 128x128 px, image A 32x32"):
            gimm.match_geometric(small, small, a, b)
        with self.assertRaisesRegex(gimm.Error, "tolerance"):
            gimm.match_geometric(image, image, a, b, tolerance_px=0.0)
        # A stricter threshold keeps a subset, each match at or above it; a negative one is
        # refused.
        strict = gimm.match_geometric(rendered[0]["intensity"], rendered[1]["intensity"], a, b,
                                      mask_a=rendered[0]["vessel_mask"],
                                      mask_b=rendered[1]["vessel_mask"], min_confidence=3.0)
        self.assertGreater(len(strict["confidence"]), 0)
        self.assertLess(len(strict["confidence"]), len(found["confidence"]))
        # The threshold is on the margin: every match kept has a larger margin than every match
        # it drops, and the kept matches are the default's, ranked as before.
        # (a junction pixel ends two chains, so one place can be matched twice: the keys hold
        # the confidence and the margin too)
        def keys(r):
            return [tuple(p) + tuple(q) + (c, m) for p, q, c, m in
                    zip(r["points_a"], r["points_b"], r["confidence"], r["margin"])]
        default, kept = keys(found), keys(strict)
        self.assertTrue(set(kept) <= set(default))
        dropped = [k[-1] for k in default if k not in set(kept)]
        self.assertGreater(strict["margin"].min(), max(dropped))
        self.assertTrue(np.all(found["confidence"] <= found["margin"]))
        with self.assertRaisesRegex(gimm.Error, "minimum confidences must be finite and >= 0"):
            gimm.match_geometric(image, image, a, b, min_confidence=-1.0)
        empty = gimm.match_geometric(np.full(image.shape, 0.8, np.float32),
                                     np.full(image.shape, 0.8, np.float32), a, b)
        self.assertEqual(empty["points_a"].shape, (0, 2))

    def test_same_scores_as_gimm_eval(self):
        a, b = carm(*VIEW_A), carm(*VIEW_B)
        pair = gimm.label_pair(phantom()["centerlines"]["LCA"], a, b,
                               renderer().render(a)["vessel_mask"],
                               renderer().render(b)["vessel_mask"], sparse_count=20, seed=2)
        sparse = pair["sparse"]
        truth_path = tmp_path("eval", "truth.json")
        with open(truth_path, "w") as f:
            json.dump({"format": "gimm-truth/1", "pair": "phantom-7/LCA_8-10",
                       "points_a": pair["points_a"][sparse].tolist(),
                       "points_b": pair["points_b"][sparse].tolist(),
                       "world_mm": pair["world_mm"][sparse].tolist(),
                       "F": pair["F"].tolist()}, f)
        predictions = self.matcher.match(renderer().render(a)["intensity"],
                                         renderer().render(b)["intensity"], 8, 10, a, b)
        matches_path = tmp_path("eval", "matches.json")
        gimm.write_matches(matches_path, predictions, pair="phantom-7/LCA_8-10")
        back = gimm.read_matches(matches_path)
        np.testing.assert_array_equal(back["points_a"], predictions["points_a"])
        truth = gimm.read_user_truth(truth_path, radius_px=3.0)
        self.assertEqual(truth["mask_a"].dtype, np.uint8)
        for k in (20, 0):
            mine = gimm.evaluate(truth, back, top_k=k)["pooled"]
            # The same from plain arrays (the discs come from radius_px).
            plain = {key: pair[key][sparse] for key in ("points_a", "points_b", "world_mm")}
            plain["F"] = pair["F"]
            self.assertEqual(gimm.evaluate(plain, predictions, top_k=k)["pooled"], mine)
            exe = cli("gimm-eval")
            if exe is None:
                continue
            out_dir = tmp_path("eval", f"out-{k}", "x")[:-2]
            run(exe, "--truth", truth_path, "--matches", matches_path, "--top-k", k,
                "--out", out_dir)
            with open(out_dir + "/summary.json") as f:
                reference = json.load(f)["pooled"]
            self.assertEqual(set(reference), set(mine))
            for key, value in reference.items():
                if value is None:
                    self.assertIsNone(mine[key], key)
                else:
                    self.assertAlmostEqual(mine[key], value, places=12, msg=key)
        if cli("gimm-eval") is None:
            self.skipTest("gimm-eval not built (scored in Python only)")

    def test_network_image(self):
        # What the network sees (match/network_input.hpp): the shipped weights see intensities;
        # the vessel-enhanced input keeps a dark line and drops a dark step.
        self.assertEqual(self.matcher.input, "intensity")
        image = np.full((64, 64), 0.8, np.float32)
        image[:, :24] = 0.35
        image[:, 39:42] *= 0.5
        same = gimm.network_image(image, "intensity")
        self.assertEqual(same.dtype, np.float32)
        np.testing.assert_array_equal(same, image)
        enhanced = gimm.network_image(image.astype(np.float64), "vesselness")
        self.assertEqual(enhanced.shape, (64, 64))
        self.assertLess(enhanced[40, 40], 0.05)
        self.assertGreater(enhanced[40, 10], 0.9)
        self.assertGreater(enhanced[40, 23], 0.8)
        with self.assertRaisesRegex(gimm.Error, "intensity\\|vesselness, got 'edges'"):
            gimm.network_image(image, "edges")

    def test_bad_images(self):
        image = np.ones((128, 128), np.float32)
        with self.assertRaisesRegex(TypeError, r"image_a: .* got uint8 .*image / 255"):
            self.matcher.match(np.ones((128, 128), np.uint8), image)
        with self.assertRaisesRegex(ValueError, r"image_b: expected a 2D array, got shape \(128,"):
            self.matcher.match(image, np.ones(128, np.float32))
        with self.assertRaisesRegex(gimm.Error, "give both cameras or neither"):
            self.matcher.match(image, image, camera_a=carm(0, 0))
        with self.assertRaisesRegex(gimm.Error, "too small for the matcher"):
            self.matcher.match(np.ones((4, 4)), np.ones((4, 4)), input_size=0)
        with self.assertRaises(gimm.IoError) as caught:
            gimm.Matcher(tmp_path("match", "missing.safetensors"))
        self.assertIn("missing.safetensors", str(caught.exception))
        with self.assertRaisesRegex(ValueError, "missing 'points_b'"):
            gimm.evaluate({"points_a": np.zeros((3, 2))}, {"points_a": np.zeros((0, 2)),
                                                          "points_b": np.zeros((0, 2))})


if __name__ == "__main__":
    unittest.main()
