"""XA DICOM from Python (gimm.read_xa_dicom / write_xa_dicom): a written C-arm and image read
back, the same camera as gimm-carm --dicom prints, bad files named. Skipped in builds without
GDCM."""
import json
import unittest

import numpy as np

import gimm
from common import cli, run, tmp_path


@unittest.skipUnless(hasattr(gimm, "read_xa_dicom"), "gimm built without DICOM (GDCM)")
class XaDicom(unittest.TestCase):
    def written(self):
        carm = gimm.CArm(primary_deg=25.5, secondary_deg=-15.25, sid_mm=1100.0, sod_mm=800.0,
                         rows=48, cols=64, pixel_mm=0.4, table_mm=[5.0, -3.0, 10.0])
        v, u = np.mgrid[0:48, 0:64]
        image = ((u + 2 * v) / (63 + 94)).astype(np.float32)  # a ramp over [0, 1]
        path = tmp_path("dicom", "ramp.dcm")
        gimm.write_xa_dicom(path, image, carm)
        return path, carm, image

    def test_round_trip(self):
        path, carm, image = self.written()
        frame = gimm.read_xa_dicom(path)
        back = frame["carm"]
        for field in ("primary_deg", "secondary_deg", "sid_mm", "sod_mm", "pixel_mm"):
            self.assertAlmostEqual(getattr(back, field), getattr(carm, field), places=6, msg=field)
        np.testing.assert_allclose(back.table_mm, carm.table_mm, atol=1e-6)
        self.assertEqual((back.rows, back.cols), (48, 64))
        self.assertEqual(frame["image"].dtype, np.float32)
        # Stored as 16 bits, read back windowed by the 0.5th and 99.5th percentiles of the
        # stored values (io/dicom.hpp percentile_window).
        stored = np.rint(image.astype(np.float64) * 65535)
        ranked = np.sort(stored.ravel())
        lo, hi = (ranked[int(q * (ranked.size - 1))] for q in (0.005, 0.995))
        np.testing.assert_allclose(frame["image"], np.clip((stored - lo) / (hi - lo), 0, 1),
                                   atol=1e-6)
        self.assertEqual((frame["frame"], frame["frames"]), (0, 1))
        self.assertIn("(0018,1510)", frame["explain"])
        self.assertTrue(any(t["tag"] == "(0018,1510)" for t in frame["tags"]))
        # The reference table is the file's own until set: the camera is the C-arm's at table 0.
        back.reference_table_mm = back.table_mm
        carm.reference_table_mm = carm.table_mm
        np.testing.assert_allclose(back.camera().P, carm.camera().P, rtol=1e-9, atol=1e-9)

    def test_same_camera_as_gimm_carm(self):
        exe = cli("gimm-carm")
        if exe is None:
            self.skipTest("gimm-carm not built")
        path, _, _ = self.written()
        printed = json.loads(run(exe, "--dicom", path))
        camera = gimm.read_xa_dicom(path)["carm"].camera()
        np.testing.assert_allclose(camera.K, np.asarray(printed["K"]), atol=1e-9)
        np.testing.assert_allclose(camera.R, np.asarray(printed["R"]), atol=1e-12)
        np.testing.assert_allclose(camera.t, np.asarray(printed["t"]), atol=1e-9)

    def test_bad_files_are_named(self):
        text = tmp_path("dicom", "text.dcm")
        with open(text, "w") as f:
            f.write("not a DICOM file at all")
        with self.assertRaisesRegex(gimm.Error, "text.dcm"):
            gimm.read_xa_dicom(text)
        with self.assertRaisesRegex(gimm.IoError, "missing.dcm"):
            gimm.read_xa_dicom(tmp_path("dicom", "missing.dcm"))
        path, carm, image = self.written()
        with self.assertRaisesRegex(gimm.Error, "frame"):
            gimm.read_xa_dicom(path, frame=3)
        with self.assertRaisesRegex(gimm.Error, "64 x 48"):
            gimm.write_xa_dicom(tmp_path("dicom", "wrong.dcm"), image[:, :10], carm)

    def test_palette_colour_is_an_error_not_an_abort(self):
        # GDCM asserts on PALETTE COLOR without its tables, which killed the interpreter.
        path, _, _ = self.written()
        data = open(path, "rb").read()
        mono = b"\x28\x00\x04\x00CS\x0c\x00MONOCHROME2 "
        self.assertIn(mono, data)
        palette = tmp_path("dicom", "palette.dcm")
        with open(palette, "wb") as f:
            f.write(data.replace(mono, b"\x28\x00\x04\x00CS\x0e\x00PALETTE COLOR "))
        with self.assertRaisesRegex(gimm.FormatError, "palette.dcm.*PALETTE COLOR"):
            gimm.read_xa_dicom(palette)
        self.assertIsNone(gimm.read_xa_dicom(path)["field"])  # no shutter tags

    def test_exposed_field(self):
        # A dark 20 px frame around a bright field: cut, with a margin; no frame: kept whole.
        image = np.full((128, 128), 0.6, np.float32)
        framed = image.copy()
        framed[:20, :] = framed[-20:, :] = framed[:, :20] = framed[:, -20:] = 0.1
        field = gimm.exposed_field(framed)
        self.assertEqual(field.dtype, np.uint8)
        self.assertEqual(field[:20].sum() + field[:, :20].sum(), 0)
        self.assertEqual(field[40:88, 40:88].min(), 1)
        self.assertEqual(gimm.exposed_field(image).min(), 1)
        with self.assertRaisesRegex(gimm.Error, "16 x 16"):
            gimm.exposed_field(np.zeros((8, 8), np.float32))


if __name__ == "__main__":
    unittest.main()
