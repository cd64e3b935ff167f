"""Volumes and rendering from Python: zero-copy outputs, the same line integrals as gimm-drr and as
an analytic chord-length computation, the GIL released, files and bad inputs."""
import glob
import json
import os
import shutil
import threading
import time
import unittest

import numpy as np
from PIL import Image

import gimm
from common import carm, cli, is_capsule_view, lca, phantom, renderer, run, tmp_path


def box_chords(camera, lo, hi):
    """Chord length (mm) of every pixel's ray through the world box [lo, hi] (slab method)."""
    out = np.zeros((camera.rows, camera.cols))
    for v in range(camera.rows):
        for u in range(camera.cols):
            origin, d = camera.ray(u, v)
            with np.errstate(divide="ignore", invalid="ignore"):
                t1, t2 = (lo - origin) / d, (hi - origin) / d
            enter = np.nanmax(np.minimum(t1, t2))
            leave = np.nanmin(np.maximum(t1, t2))
            out[v, u] = max(0.0, leave - enter)
    return out


class ZeroCopy(unittest.TestCase):
    def test_render_outputs_are_views_of_gimm_buffers(self):
        view = renderer().render(carm(30, 20))
        self.assertEqual(set(view), {"line_integrals", "intensity", "vessel_mask"})
        for name, array in view.items():
            self.assertTrue(is_capsule_view(array), name)
            self.assertEqual(array.shape, (128, 128))
            self.assertTrue(array.flags.c_contiguous and array.flags.writeable, name)
        self.assertEqual(view["line_integrals"].dtype, np.float32)
        self.assertEqual(view["vessel_mask"].dtype, np.uint8)
        np.testing.assert_allclose(view["intensity"], np.exp(-view["line_integrals"]), rtol=1e-6)
        self.assertGreater(int(view["vessel_mask"].sum()), 100)
        # The buffer outlives the renderer and everything else but the array.
        r = gimm.Renderer(phantom()["hu"], geometry=phantom()["geometry"])
        li = r.render(carm(0, 0))["line_integrals"]
        before = li.copy()
        del r
        np.testing.assert_array_equal(li, before)
        plain = gimm.Renderer(phantom()["hu"], geometry=phantom()["geometry"])
        self.assertEqual(set(plain.render(carm(0, 0), intensity=False)), {"line_integrals"})

    def test_phantom_and_read_volume_are_views_too(self):
        p = phantom()
        for name in ("hu", "label"):
            self.assertTrue(is_capsule_view(p[name]), name)
            self.assertTrue(p[name].flags.f_contiguous)
        self.assertEqual(p["hu"].shape, (128, 128, 64))
        path = tmp_path("volumes", "hu.nii.gz")
        gimm.write_nifti(path, p["hu"], p["geometry"])
        hu, geometry = gimm.read_volume(path, dtype="int16")
        self.assertTrue(is_capsule_view(hu))
        np.testing.assert_array_equal(hu, p["hu"])
        for key in ("spacing", "origin", "direction"):
            np.testing.assert_allclose(geometry[key], p["geometry"][key], atol=1e-5)
        as_float, _ = gimm.read_volume(path)
        self.assertEqual(as_float.dtype, np.float32)
        np.testing.assert_array_equal(as_float, p["hu"].astype(np.float32))
        # read_nifti: the same for NIfTI, and refuses another format by what it reads.
        nifti, nifti_geometry = gimm.read_nifti(path, dtype="int16")
        self.assertTrue(is_capsule_view(nifti))
        np.testing.assert_array_equal(nifti, hu)
        np.testing.assert_array_equal(nifti_geometry["direction"], geometry["direction"])
        nrrd = tmp_path("volumes", "not-nifti.nii")
        with open(nrrd, "wb") as f:
            f.write(b"NRRD0004\n" + bytes(400))
        with self.assertRaisesRegex(gimm.FormatError, "not-nifti.nii"):
            gimm.read_nifti(nrrd)
        with self.assertRaisesRegex(ValueError, "read_nifti: dtype must be"):
            gimm.read_nifti(path, dtype="float64")
        # A bool mask is written as uint8, and a gimm.Volume with its own geometry.
        mask_path = tmp_path("volumes", "mask.nii.gz")
        gimm.write_nifti(mask_path, lca().astype(bool), p["geometry"])
        np.testing.assert_array_equal(gimm.read_nifti(mask_path, dtype="uint8")[0], lca())
        gimm.write_nifti(mask_path, gimm.Volume(lca(), p["geometry"]))
        back, back_geometry = gimm.read_nifti(mask_path, dtype="uint8")
        np.testing.assert_array_equal(back, lca())
        np.testing.assert_allclose(back_geometry["origin"], p["geometry"]["origin"], atol=1e-5)

    def test_nifti_orientation_matches_nibabel(self):
        try:
            import nibabel
        except ImportError:
            self.skipTest("no nibabel (python3-nibabel)")
        rng = np.random.default_rng(0)
        volume = rng.normal(size=(6, 5, 4)).astype(np.float32)
        direction = np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]])  # a rotated grid
        path = tmp_path("volumes", "oriented.nii")
        gimm.write_nifti(path, volume, dict(spacing=[1.5, 2, 3], origin=[-10, 20, 5],
                                            direction=direction))
        image = nibabel.load(path)
        np.testing.assert_array_equal(np.asarray(image.dataobj), volume)  # [i, j, k], as gimm
        lps_from_ras = np.diag([-1.0, -1, 1])
        affine = image.affine
        np.testing.assert_allclose(lps_from_ras @ affine[:3, 3], [-10, 20, 5], atol=1e-4)
        np.testing.assert_allclose(lps_from_ras @ affine[:3, :3], direction @ np.diag([1.5, 2, 3]),
                                   atol=1e-5)
        back, geometry = gimm.read_volume(path)
        np.testing.assert_array_equal(back, volume)
        np.testing.assert_allclose(geometry["direction"], direction, atol=1e-6)


class RenderValues(unittest.TestCase):
    def test_same_line_integrals_as_gimm_drr(self):
        exe = cli("gimm-drr")
        if exe is None:
            self.skipTest("gimm-drr not built (the analytic test below still runs)")
        p = phantom()
        hu, label = tmp_path("drr", "hu.nii.gz"), tmp_path("drr", "label.nii.gz")
        gimm.write_nifti(hu, p["hu"], p["geometry"])
        gimm.write_nifti(label, p["label"], p["geometry"])
        prefix = tmp_path("drr", "lao30cra20")
        run(exe, "--volume", hu, "--label", label, "--system", "LCA", "--primary", "30",
            "--secondary", "20", "--rows", "128", "--cols", "128", "--pixel", "2", "--out", prefix,
            "--quiet")
        reference = np.load(prefix + ".npy")
        self.assertEqual(reference.dtype, np.float32)
        # The same inputs as gimm-drr: the files (NIfTI keeps the grid in float32), its system
        # split and its isocentre rule.
        ct, geometry = gimm.read_volume(hu)
        vessels = gimm.split_coronary_systems(gimm.read_volume(label, dtype="uint8")[0],
                                              geometry)["lca"]
        view_carm = gimm.CArm(primary_deg=30, secondary_deg=20, rows=128, cols=128, pixel_mm=2,
                              isocenter=gimm.vessel_isocenter(vessels, geometry))
        view = gimm.Renderer(ct, vessels, geometry=geometry).render(view_carm)
        np.testing.assert_array_equal(view["line_integrals"], reference)
        camera = gimm.read_camera(prefix + ".camera.json")
        np.testing.assert_allclose(camera.P, view_carm.camera().P, rtol=1e-12)
        # The phantom straight from memory differs from the files' float32 grid by rounding only.
        np.testing.assert_allclose(renderer().render(carm(30, 20))["line_integrals"], reference,
                                   rtol=1e-5, atol=1e-6)

    def test_line_integrals_are_attenuation_times_chord_length(self):
        mu = 0.02  # mm^-1, a uniform box: line integral = mu * chord
        dims, spacing = np.array([40, 30, 20]), np.array([2.0, 2.5, 3.0])
        lo = -dims * spacing / 2
        hi = -lo
        origin = lo + spacing / 2  # centre of voxel (0, 0, 0)
        volume = np.full(tuple(dims), mu, np.float32, order="F")
        camera = gimm.CArm(primary_deg=20, secondary_deg=10, rows=48, cols=48,
                           pixel_mm=2.5).camera()
        expected = mu * box_chords(camera, lo, hi)
        self.assertGreater(expected.max(), 0.5)
        r = gimm.Renderer(volume, spacing=spacing, origin=origin, recipe="none", pad_mm=0)
        np.testing.assert_allclose(r.render(camera)["line_integrals"], expected, atol=2e-5)
        # Trilinear marching blurs the box's faces and edges over a voxel (the field falls off
        # linearly outside the last voxel centres): compared on the rays through the box shrunk
        # by a voxel, where 95% are within 1%.
        through = box_chords(camera, lo + spacing, hi - spacing) > 0
        r = gimm.Renderer(volume, spacing=spacing, origin=origin, recipe="none", pad_mm=0,
                          projector="trilinear", step_mm=0.5)
        error = np.abs(r.render(camera)["line_integrals"] - expected)[through] / expected[through]
        self.assertLess(np.quantile(error, 0.95), 0.01)
        # The same box with the i axis flipped (direction -x, origin at the other end).
        flipped = gimm.Renderer(volume[::-1], spacing=spacing, recipe="none", pad_mm=0,
                                origin=[hi[0] - spacing[0] / 2, origin[1], origin[2]],
                                direction=np.diag([-1.0, 1, 1]))
        np.testing.assert_allclose(flipped.render(camera)["line_integrals"], expected, atol=2e-5)

    def test_input_layouts_and_dtypes_give_the_same_image(self):
        p = phantom()
        camera = carm(-30, -20)
        base = renderer().render(camera)["line_integrals"]
        for hu in (np.ascontiguousarray(p["hu"]), p["hu"].astype(np.float32),
                   np.asfortranarray(p["hu"].astype(np.float64))):
            r = gimm.Renderer(hu, lca().astype(bool), geometry=p["geometry"])
            np.testing.assert_array_equal(r.render(camera)["line_integrals"], base)
        # The ITK/SimpleITK (z, y, x) C-ordered layout: its transpose is gimm's, as a view.
        zyx = np.ascontiguousarray(p["hu"].T)
        r = gimm.Renderer(zyx.T, lca(), geometry=p["geometry"])
        np.testing.assert_array_equal(r.render(camera)["line_integrals"], base)

    def test_volume_reads_the_callers_array_in_place(self):
        p = phantom()
        hu = p["hu"].astype(np.float32, order="F")
        v = gimm.Volume(hu, p["geometry"])
        self.assertTrue(v.is_view)
        self.assertEqual((v.dtype, v.shape), ("float32", hu.shape))
        self.assertIs(v.array, hu)
        # gimm reads the caller's memory: a write to the array is what gimm sees next.
        self.assertEqual(v[10, 20, 30], float(hu[10, 20, 30]))
        hu[10, 20, 30] = 1234.5
        self.assertEqual(v[10, 20, 30], 1234.5)
        world = gimm.Volume(hu, p["geometry"]).geometry
        np.testing.assert_allclose(world["spacing"], p["geometry"]["spacing"])
        # The Volume keeps the buffer alive after the caller drops it.
        ref = hu.copy()
        del hu
        self.assertEqual(v[10, 20, 30], 1234.5)
        np.testing.assert_array_equal(v.array, ref)
        # sample(): trilinear in world mm as gimm's Volume samples it: a voxel centre gives the
        # voxel, the midpoint of two neighbours along j their mean, outside the grid 0.
        g = p["geometry"]
        centre = lambda i, j, k: g["origin"] + g["direction"] @ (g["spacing"] * [i, j, k])
        self.assertEqual(v.sample(centre(10, 20, 30)), 1234.5)
        self.assertAlmostEqual(v.sample(centre(40, 50.5, 20)),
                               (float(ref[40, 50, 20]) + float(ref[40, 51, 20])) / 2, places=4)
        self.assertEqual(v.sample(centre(-5, 0, 0)), 0.0)
        # int16 CTs (as make_phantom and most CCTA files hold them) and masks, uint8 and bool,
        # in Fortran order are read in place too.
        ct16 = gimm.Volume(p["hu"], p["geometry"])
        self.assertTrue(ct16.is_view and ct16.dtype == "int16")
        self.assertIs(ct16.array, p["hu"])
        self.assertEqual(ct16[5, 6, 7], float(p["hu"][5, 6, 7]))
        m = gimm.Volume(lca(), p["geometry"])
        self.assertTrue(m.is_view and m.dtype == "uint8")
        self.assertTrue(gimm.Volume(lca().astype(bool), p["geometry"]).is_view)

    def test_volume_copies_when_the_layout_is_not_gimms(self):
        p = phantom()
        hu32 = p["hu"].astype(np.float32, order="F")
        readonly = hu32.copy(order="F")
        readonly.flags.writeable = False
        for name, array, dtype in (("C order", np.ascontiguousarray(hu32), None),
                                   ("int16 as float32", p["hu"], "float32"),
                                   ("float64", hu32.astype(np.float64, order="F"), None),
                                   ("read-only", readonly, None), ("strided", hu32[::2], None)):
            v = gimm.Volume(array, p["geometry"], dtype=dtype)
            self.assertFalse(v.is_view, name)
            self.assertFalse(np.shares_memory(v.array, array), name)
            self.assertTrue(v.array.flags.f_contiguous, name)
            np.testing.assert_array_equal(v.array, array.astype(np.float32), err_msg=name)
        # A copy is a copy: later writes to the caller's array are not seen.
        c = np.ascontiguousarray(hu32)
        v = gimm.Volume(c, p["geometry"])
        c[1, 2, 3] = -999
        self.assertEqual(v[1, 2, 3], float(hu32[1, 2, 3]))
        # Its array's memory is gimm's copy, kept alive by the Volume.
        a = v.array
        del v
        self.assertEqual(float(a[1, 2, 3]), float(hu32[1, 2, 3]))

    def test_renderer_and_volume_functions_take_a_volume(self):
        p = phantom()
        camera = carm(-30, -20)
        base = renderer().render(camera)
        hu = gimm.Volume(p["hu"].astype(np.float32, order="F"), p["geometry"])
        mask = gimm.Volume(lca(), p["geometry"])
        hu16 = gimm.Volume(p["hu"], p["geometry"])
        for v, m in ((hu, mask), (hu, lca()), (hu16, mask)):
            view = gimm.Renderer(v, m).render(camera)
            np.testing.assert_array_equal(view["line_integrals"], base["line_integrals"])
            np.testing.assert_array_equal(view["vessel_mask"], base["vessel_mask"])
        # int16 read in place gives what the float32 copy gives, in both projectors' paths.
        for projector in ("siddon", "trilinear"):
            a = gimm.Renderer(p["hu"], lca(), geometry=p["geometry"], projector=projector)
            b = gimm.Renderer(p["hu"].astype(np.float32), lca(), geometry=p["geometry"],
                              projector=projector)
            np.testing.assert_array_equal(a.render(camera)["line_integrals"],
                                          b.render(camera)["line_integrals"])
        split = gimm.split_coronary_systems(gimm.Volume(p["label"], p["geometry"]))
        np.testing.assert_array_equal(split["lca"], lca())
        np.testing.assert_allclose(gimm.vessel_isocenter(mask),
                                   gimm.vessel_isocenter(lca(), p["geometry"]))
        # recipe='none' keeps the attenuation: a view is copied, so the caller's later writes
        # do not reach the renderer.
        mu = np.full((20, 20, 20), 0.02, np.float32, order="F")
        r = gimm.Renderer(gimm.Volume(mu, spacing=[2, 2, 2]), recipe="none", pad_mm=0)
        cam = gimm.CArm(rows=32, cols=32, pixel_mm=4.0).camera()
        before = r.render(cam)["line_integrals"].copy()
        mu[:] = 5.0
        np.testing.assert_array_equal(r.render(cam)["line_integrals"], before)
        self.assertGreater(before.max(), 0.5)

    def test_volume_refusals(self):
        p = phantom()
        hu = gimm.Volume(p["hu"], p["geometry"])
        with self.assertRaisesRegex(ValueError, "carries its geometry"):
            gimm.Renderer(hu, geometry=p["geometry"])
        with self.assertRaisesRegex(TypeError, "mask: expected a gimm.Volume of dtype uint8, got "
                                               "one of int16"):
            gimm.Renderer(hu, hu)
        with self.assertRaisesRegex(TypeError, "volume: expected a gimm.Volume of dtype float32 "
                                               "or int16, got one of uint8"):
            gimm.Renderer(gimm.Volume(lca(), p["geometry"]))
        with self.assertRaisesRegex(ValueError, "dtype must be 'float32', 'int16' or 'uint8', "
                                                "got 'float64'"):
            gimm.Volume(p["hu"], dtype="float64")
        with self.assertRaisesRegex(gimm.Error, "recipe 'none'.*must be float, not an integer"):
            gimm.Renderer(p["hu"], geometry=p["geometry"], recipe="none")
        with self.assertRaisesRegex(IndexError, r"voxel \(128, 0, 0\) is outside"):
            hu[128, 0, 0]
        with self.assertRaisesRegex(gimm.Error, "spacing 0 must be in \\[1e-4, 1e4\\] mm, got -1"):
            gimm.Volume(p["hu"], spacing=[-1, 1, 1])
        with self.assertRaisesRegex(ValueError, "Volume: expected a 3D array"):
            gimm.Volume(np.zeros((4, 4), np.float32))
        with self.assertRaisesRegex(ValueError, "mask values must be in"):
            gimm.Volume(np.full((2, 2, 2), 300, np.int32), dtype="uint8")
        with self.assertRaisesRegex(gimm.Error, "image and label grids disagree: dimensions"):
            gimm.Renderer(hu, np.zeros((4, 4, 4), np.uint8))

    def test_vessel_depth_and_occlusion(self):
        p = phantom()
        r = gimm.Renderer(p["hu"], lca(), geometry=p["geometry"], vessel_depth=True)
        view = r.render(carm(30, 20))
        self.assertEqual(view["overlap"].dtype, np.uint8)
        mask = view["vessel_mask"] > 0
        self.assertTrue(np.isfinite(view["depth_mm"][mask]).mean() > 0.9)
        self.assertTrue(np.isinf(view["depth_mm"][~mask]).all())
        points = p["centerlines"]["LCA"]["points"]
        seen = r.unoccluded(carm(30, 20), points)
        self.assertEqual(seen.shape, (len(points),))
        self.assertGreater(seen.mean(), 0.5)

    def test_mesh_vessels_as_gimm_dataset_renders_them(self):
        """vessels='mesh' (Embree) gives gimm-dataset --vessels mesh's masks and images for the
        same patient and views."""
        exe = cli("gimm-dataset")
        if exe is None:
            self.skipTest("gimm-dataset not built")
        root = tmp_path("mesh", "ds", "x")[:-2]
        shutil.rmtree(root, ignore_errors=True)  # this build's files, never an earlier run's
        run(exe, "--phantom", 1, "--style", "drr", "--rows", 48, "--cols", 64, "--pixel", 4.0,
            "--seed", 3, "--vessels", "mesh", "--out", root, "--quiet")
        p = gimm.make_phantom(seed=3 * 1000003)  # the dataset's patient 0 (its seed rule)
        lca_mask = gimm.split_coronary_systems(p["label"], p["geometry"])["lca"]
        r = gimm.Renderer(p["hu"], lca_mask, geometry=p["geometry"], vessels="mesh")
        views = glob.glob(os.path.join(root, "patients", "*", "views", "LCA_*.camera.json"))
        self.assertEqual(len(views), 7)
        for path in views:
            camera = gimm.read_camera(path)
            with open(path) as f:
                window = json.load(f)["intensity_window"]
            out = r.render(camera)
            prefix = path[:-len(".camera.json")]
            written_mask = np.asarray(Image.open(prefix + ".mask.png"))
            np.testing.assert_array_equal(out["vessel_mask"] > 0, written_mask > 0, err_msg=path)
            self.assertEqual(out["overlap"].dtype, np.uint8)  # the mesh mode's overlap count
            # The PNG is the intensity min-max scaled to 16 bits (render/drr.hpp).
            png = np.asarray(Image.open(prefix + ".png")).astype(np.float64) / 65535.0
            expected = window["min"] + (window["max"] - window["min"]) * png
            np.testing.assert_allclose(out["intensity"], expected,
                                       atol=(window["max"] - window["min"]) / 65535.0)
        voxel = gimm.Renderer(p["hu"], lca_mask, geometry=p["geometry"]).render(camera)
        self.assertFalse(np.array_equal(voxel["intensity"], out["intensity"]))
        # smooth_voxel_steps (gimm-dataset --smooth-background): the background changes, the
        # vessel mask does not.
        smooth = gimm.Renderer(p["hu"], lca_mask, geometry=p["geometry"], vessels="mesh",
                               smooth_voxel_steps=True).render(camera)
        np.testing.assert_array_equal(smooth["vessel_mask"], out["vessel_mask"])
        self.assertGreater(np.abs(smooth["line_integrals"] - out["line_integrals"]).max(), 1e-3)
        with self.assertRaisesRegex(ValueError, "vessels must be 'voxel' or 'mesh', got 'x'"):
            gimm.Renderer(p["hu"], lca_mask, geometry=p["geometry"], vessels="x")
        with self.assertRaisesRegex(ValueError, "needs the vessel mask"):
            gimm.Renderer(p["hu"], geometry=p["geometry"], vessels="mesh")


class Torch(unittest.TestCase):
    def test_tensors_in_and_out_without_a_copy_out(self):
        try:
            import torch
        except ImportError:
            self.skipTest("no PyTorch (scripts/install-deps.sh train)")
        p = phantom()
        camera = carm(30, 20)
        base = renderer().render(camera)
        # In: CPU tensors are read through numpy's view of them (then copied into gimm).
        r = gimm.Renderer(torch.from_numpy(p["hu"]), torch.from_numpy(lca()),
                          geometry=p["geometry"])
        view = r.render(camera)
        np.testing.assert_array_equal(view["line_integrals"], base["line_integrals"])
        # Out: torch.from_numpy shares the buffer gimm rendered into.
        tensor = torch.from_numpy(view["intensity"])
        self.assertEqual(tensor.data_ptr(), view["intensity"].ctypes.data)
        del view
        self.assertAlmostEqual(float(tensor.mean()), float(base["intensity"].mean()), places=5)


class NonFiniteOptions(unittest.TestCase):
    """Options a user sets from Python are checked as the CLIs check their flags (before: a
    negative mu_water rendered, min_spur_mm=nan ran, a NaN point or F gave garbage)."""

    def test_recipe_values(self):
        p = phantom()
        for field, value in (("mu_water", -1.0), ("mu_water", float("nan")),
                             ("bone_weight", -0.5), ("lumen_hu", float("inf"))):
            with self.assertRaisesRegex(gimm.Error, rf"{field} must be .*, got (-1|-0.5|nan|inf)"):
                gimm.Renderer(p["hu"], lca(), geometry=p["geometry"], recipe={field: value})

    def test_centerline_options(self):
        p = phantom()
        for value in (float("nan"), -1.0):
            with self.assertRaisesRegex(gimm.Error, r"min_spur_mm must be >= 0, got (nan|-1)"):
                gimm.extract_centerlines(lca(), p["geometry"], min_spur_mm=value)

    def test_non_finite_points_and_matrices(self):
        pts = np.random.default_rng(0).random((20, 3))
        pts[7, 1] = np.nan
        with self.assertRaisesRegex(gimm.Error, "point 7 is not finite"):
            gimm.farthest_point_sampling(pts, 5)
        F = np.eye(3)
        F[0, 0] = np.nan
        xy = np.zeros((3, 2))
        with self.assertRaisesRegex(ValueError, "F: must be finite"):
            gimm.symmetric_epipolar_distance_sq(F, xy, xy)


class GilAndThreads(unittest.TestCase):
    def test_thread_count_is_bounded(self):
        # 10**9 threads used to be accepted, and libgomp killed the interpreter at the next
        # render.
        for bad in (0, -2, 1025, 10**9):
            with self.assertRaisesRegex(ValueError, rf"\[1, 1024\], got {bad}"):
                gimm.set_num_threads(bad)
        before = gimm.get_num_threads()
        gimm.set_num_threads(2)
        self.assertEqual(gimm.get_num_threads(), 2)
        gimm.set_num_threads(before)

    def test_rendering_releases_the_gil(self):
        """The main thread runs Python code while another thread is inside render(): with the
        GIL held for the whole render, no main-thread tick could fall inside one."""
        r = renderer()
        camera = carm(30, 20, size=384).camera()
        renders, done = [], threading.Event()

        def work():
            gimm.set_num_threads(1)  # this thread's renders (OpenMP keeps it per thread)
            for _ in range(3):
                start = time.perf_counter()
                r.render(camera)
                renders.append((start, time.perf_counter()))
            done.set()

        worker = threading.Thread(target=work)
        ticks = []
        worker.start()
        while not done.is_set():
            ticks.append(time.perf_counter())
        worker.join()
        ticks = np.array(ticks)
        inside = [int(((ticks > a) & (ticks < b)).sum()) for a, b in renders]
        self.assertGreaterEqual(sum(n > 10 for n in inside), 2,
                                f"main-thread ticks inside each render: {inside}")


class BadInput(unittest.TestCase):
    def test_missing_and_malformed_files(self):
        missing = tmp_path("volumes", "no-such-ct.nii.gz")
        with self.assertRaises(gimm.IoError) as caught:
            gimm.read_volume(missing)
        self.assertIn(missing, str(caught.exception))
        self.assertTrue(str(caught.exception).startswith("gimm: "))
        self.assertIsInstance(caught.exception, gimm.Error)
        self.assertIsInstance(caught.exception, OSError)
        bad = tmp_path("volumes", "garbage.nii")
        with open(bad, "wb") as f:
            f.write(b"not a nifti file" * 40)
        with self.assertRaises(gimm.FormatError) as caught:
            gimm.read_volume(bad)
        self.assertIn(bad, str(caught.exception))
        with self.assertRaisesRegex(gimm.Error, "unknown volume format"):
            gimm.read_volume(tmp_path("volumes", "ct.dcm"))

    def test_wrong_dtypes_and_shapes(self):
        p = phantom()
        hu, g = p["hu"], p["geometry"]
        with self.assertRaisesRegex(TypeError, "expected a real numeric array, got complex128"):
            gimm.Renderer(hu.astype(complex), geometry=g)
        with self.assertRaisesRegex(ValueError, r"expected a 3D array, got shape \(128, 128\)"):
            gimm.Renderer(hu[:, :, 0], geometry=g)
        with self.assertRaisesRegex(TypeError, "bool or integer mask"):
            gimm.Renderer(hu, lca().astype(np.float32), geometry=g)
        with self.assertRaisesRegex(TypeError, r"numpy array \(or a CPU tensor\), got list"):
            gimm.Renderer([[[0.0]]])
        with self.assertRaisesRegex(gimm.Error, "grids disagree"):
            gimm.Renderer(hu, lca()[:, :, :32], geometry=g)
        with self.assertRaisesRegex(gimm.Error, "recipe 'none'"):
            gimm.Renderer(hu, lca(), geometry=g, recipe="none")
        with self.assertRaisesRegex(ValueError, "unknown field 'lumen'"):
            gimm.Renderer(hu, geometry=g, recipe={"preset": "angiography", "lumen": 1})
        with self.assertRaisesRegex(ValueError, r"spacing: expected shape \(3,\), got \(2,\)"):
            gimm.Renderer(hu, spacing=[1, 1])
        with self.assertRaisesRegex(gimm.Error, "spacing 0 must be in"):
            gimm.Renderer(hu, spacing=[0, 1, 1])
        with self.assertRaisesRegex(TypeError, "expected a gimm.Camera or gimm.CArm"):
            renderer().render("AP")
        with self.assertRaisesRegex(ValueError, r"mask values must be in \[0, 255\]"):
            gimm.vessel_isocenter(lca().astype(np.int32) * 300, g)


if __name__ == "__main__":
    unittest.main()
