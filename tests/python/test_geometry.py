"""gimm.CArm, gimm.Camera, epipolar geometry, gating and triangulation from Python, against the
C++ conventions (docs/conventions.md) and the gimm-carm CLI."""
import json
import pickle
import unittest

import numpy as np

import gimm
from common import cli, run


def random_points(n, seed=0, spread=40.0):
    return np.random.default_rng(seed).uniform(-spread, spread, size=(n, 3))


class CArmConventions(unittest.TestCase):
    def test_ap_shows_patient_left_on_the_right_and_head_on_top(self):
        camera = gimm.CArm(rows=256, cols=256, pixel_mm=1.0).camera()
        centre = (256 - 1) / 2
        uv, depth = camera.project(np.array([[0.0, 0, 0], [20, 0, 0], [0, 0, 20], [0, -20, 0]]))
        np.testing.assert_allclose(uv[0], [centre, centre])
        self.assertGreater(uv[1, 0], centre + 10)  # +x (patient left): right of centre
        self.assertAlmostEqual(uv[1, 1], centre)
        self.assertLess(uv[2, 1], centre - 10)  # +z (head): above the centre
        self.assertAlmostEqual(uv[2, 0], centre)
        # The source is posterior (+y): an anterior point (-y) is deeper.
        self.assertAlmostEqual(depth[0], 750.0)
        self.assertAlmostEqual(depth[3], 770.0)
        np.testing.assert_allclose(camera.center, [0, 750, 0], atol=1e-9)

    def test_lao_and_cranial_move_the_source_to_the_right_and_the_feet(self):
        lao = gimm.CArm(primary_deg=30)
        self.assertLess(lao.source_position()[0], -300)  # LAO: source at the patient's right
        cranial = gimm.CArm(secondary_deg=20)
        self.assertLess(cranial.source_position()[2], -200)  # cranial: source towards the feet
        np.testing.assert_allclose(np.linalg.norm(lao.source_direction()), 1.0)

    def test_projection_is_P_and_rays_go_back_through_the_point(self):
        carm = gimm.CArm(primary_deg=-25, secondary_deg=15, isocenter=[5, -10, 30])
        camera = carm.camera()
        X = random_points(20)
        uv, depth = camera.project(X)
        x = np.c_[X, np.ones(len(X))] @ camera.P.T
        np.testing.assert_allclose(uv, x[:, :2] / x[:, 2:], rtol=1e-12, atol=1e-9)
        self.assertTrue(np.all(depth > 0))
        P = camera.K @ np.c_[camera.R, camera.t]
        np.testing.assert_allclose(camera.P, P, rtol=1e-12)
        for (u, v), point in zip(uv, X):
            origin, direction = camera.ray(u, v)
            self.assertAlmostEqual(np.linalg.norm(direction), 1.0)
            off = (point - origin) - np.dot(point - origin, direction) * direction
            self.assertLess(np.linalg.norm(off), 1e-8)
        one_uv, one_depth = camera.project(X[0])
        self.assertEqual(one_uv.shape, (2,))
        self.assertAlmostEqual(one_depth, depth[0])
        self.assertEqual(camera.on_detector(np.array([[0, 0], [-1, 0], [511.4, 511.4]])).tolist(),
                         [True, False, True])

    def test_table_non_square_pixels_principal_point_and_orthographic(self):
        carm = gimm.CArm(isocenter=[1, 2, 3], table_mm=[10, 20, 30])
        np.testing.assert_allclose(carm.view_isocenter(), [-9, -18, -27])  # the patient rode +table
        carm.patient_position = "FFS"
        np.testing.assert_allclose(carm.table_shift(), [-10, 20, -30])
        self.assertEqual(carm.patient_position, "FFS")
        carm = gimm.CArm(pixel_mm=0.5, pixel_row_mm=0.25, principal_point=[100, 200])
        K = carm.camera().K
        self.assertAlmostEqual(K[0, 0], 2000.0)
        self.assertAlmostEqual(K[1, 1], -4000.0)
        np.testing.assert_allclose(K[:2, 2], [100, 200])
        carm.principal_point = None
        np.testing.assert_allclose(carm.principal_point_or_centre(), [255.5, 255.5])
        ortho = gimm.CArm(model="orthographic").camera()
        np.testing.assert_allclose(ortho.P[2], [0, 0, 0, 1])
        self.assertEqual(ortho.model, "orthographic")

    def test_same_camera_as_gimm_carm(self):
        exe = cli("gimm-carm")
        if exe is None:
            self.skipTest("gimm-carm not built")
        for flags, kwargs in [
            (["--primary", "30", "--secondary", "20", "--rows", "64", "--cols", "80"],
             dict(primary_deg=30, secondary_deg=20, rows=64, cols=80)),
            (["--primary", "-35.5", "--secondary", "-22", "--isocenter", "1.5", "-2", "3",
              "--table", "10", "-5", "40", "--sid", "1100", "--sod", "780", "--pixel", "0.3"],
             dict(primary_deg=-35.5, secondary_deg=-22, isocenter=[1.5, -2, 3],
                  table_mm=[10, -5, 40], sid_mm=1100, sod_mm=780, pixel_mm=0.3)),
            (["--primary", "45", "--secondary", "0", "--model", "orthographic", "--principal-point",
              "200", "250"],
             dict(primary_deg=45, model="orthographic", principal_point=[200, 250])),
        ]:
            j = json.loads(run(exe, *flags))
            camera = gimm.CArm(**kwargs).camera()
            for key in ("K", "R", "t", "P", "center"):
                np.testing.assert_allclose(getattr(camera, key), np.array(j[key]).reshape(
                    getattr(camera, key).shape), rtol=1e-14, atol=1e-9, err_msg=key)

    def test_pickle_and_repr(self):
        carm = gimm.CArm(primary_deg=12, isocenter=[1, 2, 3], table_mm=[4, 5, 6],
                         principal_point=[10, 20], patient_position="FFS", pixel_row_mm=0.4)
        back = pickle.loads(pickle.dumps(carm))
        np.testing.assert_array_equal(back.camera().P, carm.camera().P)
        self.assertEqual(back.patient_position, "FFS")
        camera = carm.camera()
        np.testing.assert_array_equal(pickle.loads(pickle.dumps(camera)).P, camera.P)
        self.assertIn("perspective", repr(camera))
        self.assertIn("primary_deg=12", repr(carm))
        rebuilt = gimm.Camera(camera.K, camera.R, camera.t, camera.rows, camera.cols)
        np.testing.assert_array_equal(rebuilt.P, camera.P)

    def test_bad_values_raise_gimm_error_naming_the_field(self):
        with self.assertRaisesRegex(gimm.Error, "SID must exceed SOD"):
            gimm.CArm(sid_mm=500).camera()
        with self.assertRaisesRegex(gimm.Error, "secondary angle"):
            gimm.CArm(secondary_deg=95).validate()
        with self.assertRaisesRegex(ValueError, "perspective"):
            gimm.CArm(model="fisheye")
        with self.assertRaisesRegex(gimm.Error, "R must be a rotation"):
            gimm.Camera(np.diag([1000.0, -1000, 1]), np.eye(3) * 2, np.zeros(3), 10, 10)

    def test_bad_arrays_raise_clear_errors(self):
        camera = gimm.CArm().camera()
        with self.assertRaisesRegex(ValueError, r"points: expected shape \(N, 3\), got \(4, 2\)"):
            camera.project(np.zeros((4, 2)))
        with self.assertRaisesRegex(TypeError, "points"):
            camera.project(np.array([["a", "b", "c"]]))
        with self.assertRaisesRegex(ValueError, r"isocenter: expected shape \(3,\)"):
            gimm.CArm(isocenter=[1, 2])
        with self.assertRaisesRegex(TypeError, "camera_a"):
            gimm.fundamental_from_cameras("not a camera", camera)


class Epipolar(unittest.TestCase):
    def setUp(self):
        self.a = gimm.CArm(primary_deg=30, secondary_deg=20).camera()
        self.b = gimm.CArm(primary_deg=-30, secondary_deg=-5).camera()
        self.X = random_points(60, seed=1)
        self.xa, _ = self.a.project(self.X)
        self.xb, _ = self.b.project(self.X)
        self.F = gimm.fundamental_from_cameras(self.a, self.b)

    def test_exact_F_satisfies_xb_F_xa(self):
        h = lambda x: np.c_[x, np.ones(len(x))]
        residual = np.einsum("ni,ij,nj->n", h(self.xb), self.F, h(self.xa))
        self.assertLess(np.abs(residual).max(), 1e-9)
        d2 = gimm.symmetric_epipolar_distance_sq(self.F, self.xa, self.xb)
        self.assertLess(d2.max(), 1e-16)
        self.assertLess(gimm.sampson_distance_sq(self.F, self.xa, self.xb).max(), 1e-16)
        lines = gimm.epipolar_lines_b(self.F, self.xa)
        np.testing.assert_allclose(np.einsum("ni,ni->n", lines, h(self.xb)), 0, atol=1e-9)
        # The same from CArms directly; F is normalised (unit norm, largest entry positive).
        np.testing.assert_array_equal(
            gimm.fundamental_from_cameras(gimm.CArm(primary_deg=30, secondary_deg=20),
                                          gimm.CArm(primary_deg=-30, secondary_deg=-5)), self.F)
        self.assertAlmostEqual(np.linalg.norm(self.F), 1.0)

    def test_8pt_and_ransac_recover_F(self):
        F8 = gimm.fundamental_8pt(self.xa, self.xb)
        self.assertLess(gimm.symmetric_epipolar_distance_sq(F8, self.xa, self.xb).max(), 1e-8)
        weighted = gimm.fundamental_8pt(self.xa, self.xb, weights=np.linspace(0.1, 1, 60))
        self.assertLess(gimm.symmetric_epipolar_distance_sq(weighted, self.xa, self.xb).max(), 1e-8)
        one_zero_weight = np.r_[np.zeros(1), np.ones(7)]  # 7 positive weights: degenerate
        self.assertIsNone(gimm.fundamental_8pt(self.xa[:8], self.xb[:8], weights=one_zero_weight))
        xb = self.xb.copy()
        xb[::4] += np.random.default_rng(2).uniform(20, 60, size=xb[::4].shape)  # 25% outliers
        r = gimm.estimate_fundamental_ransac(self.xa, xb, threshold_px=0.5, seed=3)
        outlier = np.zeros(60, bool)
        outlier[::4] = True
        np.testing.assert_array_equal(r["inliers"], ~outlier)
        self.assertEqual(r["num_inliers"], 45)
        self.assertLess(gimm.symmetric_epipolar_distance_sq(r["F"], self.xa, self.xb).max(), 1e-6)
        again = gimm.estimate_fundamental_ransac(self.xa, xb, threshold_px=0.5, seed=3)
        np.testing.assert_array_equal(again["F"], r["F"])
        with self.assertRaisesRegex(gimm.Error, "need at least 8 correspondences, got 5"):
            gimm.fundamental_8pt(self.xa[:5], self.xb[:5])
        with self.assertRaisesRegex(gimm.Error, "x_a has 60 points but x_b has 59"):
            gimm.fundamental_8pt(self.xa, self.xb[:59])

    def test_gates(self):
        xb = self.xb.copy()
        xb[:10, 0] += 10  # off their epipolar lines
        conf = np.linspace(1, 0.5, 60)
        hard = gimm.gate_with_fundamental(self.F, self.xa, xb, conf)
        self.assertEqual(int(hard["keep"].sum()), 50)
        np.testing.assert_array_equal(hard["confidence"][10:], conf[10:])
        np.testing.assert_array_equal(hard["confidence"][:10], 0)
        soft = gimm.gate_with_fundamental(self.F, self.xa, xb, conf, mode="soft", tau=2.0)
        np.testing.assert_allclose(soft["confidence"], conf * np.exp(-soft["distance_sq"] / 4))
        ref = gimm.gate_reference(self.xa, self.xb, conf, min_matches=32)
        self.assertIsNotNone(ref["F"])
        self.assertTrue(ref["keep"].all())
        none = gimm.gate_reference(self.xa[:20], self.xb[:20], conf[:20])  # < min_matches
        self.assertIsNone(none["F"])
        self.assertIsNone(gimm.fundamental_from_matches(self.xa[:20], self.xb[:20], conf[:20]))
        with self.assertRaisesRegex(gimm.Error, "gate mode"):
            gimm.gate_with_fundamental(self.F, self.xa, xb, conf, mode="sharp")

    def test_triangulate(self):
        for method in ("dlt", "midpoint"):
            X = gimm.triangulate([self.a, self.b], np.stack([self.xa[0], self.xb[0]]), method)
            np.testing.assert_allclose(X, self.X[0], atol=1e-6)
            many = gimm.triangulate([self.a, self.b], np.stack([self.xa, self.xb]), method=method)
            np.testing.assert_allclose(many, self.X, atol=1e-6)
        self.assertIsNone(gimm.triangulate([self.a, self.a], np.stack([self.xa[0], self.xa[0]])))
        with self.assertRaisesRegex(ValueError, "3 views for 2 cameras"):
            gimm.triangulate([self.a, self.b], np.zeros((3, 2)))


if __name__ == "__main__":
    unittest.main()
