#!/usr/bin/python3
"""Which gimm C-arm pose reproduces the reference generator's (primary, secondary) view.

The released reference generator (Phys_DRR / angio_cip, docs/recipes.md) loads an ImageCAS
NIfTI with nibabel, reorders it to (Z, Y, X) = data[:, :, ::-1].transpose(2, 1, 0), rotates the
voxel *index* grid with R = _rotation_matrix_x(secondary) @ _rotation_matrix_z(primary) about
the grid centre c = (shape - 1) / 2 (scipy affine_transform, whose matrix maps output to input
coordinates, so a point p of the input lands at q = R^T (p - c) + c), sums along the rotated Y
axis and labels a 3D point with pixel (u, v) = (q_X, q_Z), as its project_3d_to_2d does.

This tool models that pixel map for points (no reference code is used), derives the gimm
orthographic camera that reproduces it, and checks the result against gimm's own camera
(`gimm-carm --model orthographic`): the pixel of random points in both, the viewing direction,
and a cropped image (the reference's column crop as a shifted principal point). With
--image-check it also renders point sources with scipy's affine_transform the way the
reference does and checks that the summed image peaks where the point map says (i.e. that the
output->input reading of the matrix is right).

Closed form, for a volume whose NIfTI axes are i -> patient left, j -> posterior, k -> head
(RAS affine diag(-s_x, -s_y, s_z), as gimm-phantom writes and gimm assumes ImageCAS files are):

    gimm primary   = -(reference secondary)      gimm secondary = -(reference primary)
    orthographic, pixel at the isocentre = 1 voxel index unit, isocentre = grid centre,
    detector rows x cols = K x I (the reference's (Z, X) image), principal point
    ((I - 1) / 2 - x_offset, (K - 1) / 2) for a reference image cropped at column x_offset.

It is exact only when the voxels are isotropic: the reference rotates index space and never
uses the spacing for its geometry, so with anisotropic voxels its pixel map is not a rigid
camera with square pixels (reported, not checked, for --aniso-spacing).

Usage:
  /usr/bin/python3 tools/reference_angles.py                  # full check, exits 1 on failure
  /usr/bin/python3 tools/reference_angles.py --map 45 -20     # just print the gimm angles
  /usr/bin/python3 tools/reference_angles.py --image-check    # also the scipy render check
  /usr/bin/python3 tools/reference_angles.py --nifti 1.img.nii.gz   # axes from a real header
Options: --gimm-carm PATH, --shape I J K, --spacing S, --aniso-spacing SX SY SZ, --points N,
--seed N, --tol PX. Needs numpy (scipy for --image-check, nibabel for --nifti).
Exit status: 0 all checks pass, 1 a check failed, 2 usage or environment error.
"""
import argparse
import json
import math
import os
import shutil
import subprocess
import sys

import numpy as np

SID_MM, SOD_MM = 1000.0, 750.0  # gimm-carm defaults; orthographic pixel at iso = pixel SOD/SID
# gimm's camera axes at AP (columns x_cam, y_cam, z_cam in LPS), geometry/carm.hpp
AP_AXES = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]).T
# (Z, Y, X) index offset = J (i, j, k) offset: Z = K-1-k, Y = j, X = i
J_ZYX = np.array([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])


# ----------------------------------------------------------------------------- reference side
def ref_rotation(primary_deg, secondary_deg):
    """The reference's R = Rx(secondary) @ Rz(primary), in float32 as it builds them, acting
    on (Z, Y, X) index vectors. 'Rz' rotates components 0-1 (Z, Y); 'Rx' components 1-2 (Y, X)."""
    t, f = np.deg2rad(primary_deg), np.deg2rad(secondary_deg)
    rz = np.array([[np.cos(t), -np.sin(t), 0], [np.sin(t), np.cos(t), 0], [0, 0, 1]],
                  dtype=np.float32)
    rx = np.array([[1, 0, 0], [0, np.cos(f), -np.sin(f)], [0, np.sin(f), np.cos(f)]],
                  dtype=np.float32)
    return rx @ rz  # float32 product, as in the reference


def ref_pixels(p_zyx, primary_deg, secondary_deg, shape_zyx, x_offset=0.0):
    """Pixel (u, v) of (Z, Y, X) index points p (N x 3): q = R^T (p - c) + c, u = q_X, v = q_Z."""
    R = ref_rotation(primary_deg, secondary_deg).astype(np.float64)
    c = ((np.array(shape_zyx, dtype=np.float32) - 1.0) / 2.0).astype(np.float64)
    q = (p_zyx - c) @ R + c  # rows: (R^T (p - c))^T
    return np.stack([q[:, 2] - x_offset, q[:, 0]], axis=1)


# ----------------------------------------------------------------------------- geometry
class Grid:
    """NIfTI grid: shape (I, J, K), LPS direction matrix D (columns = i, j, k axes), spacing."""

    def __init__(self, shape_ijk, spacing, d_lps=None, origin=None):
        self.shape = np.array(shape_ijk, dtype=int)
        self.spacing = np.array(spacing, dtype=float)
        self.D = np.eye(3) if d_lps is None else np.array(d_lps, dtype=float)
        centre = (self.shape - 1) / 2.0
        # default: grid centred on the world origin (as gimm-phantom writes it)
        self.origin = (-self.D @ (self.spacing * centre)) if origin is None else np.array(origin)

    @property
    def shape_zyx(self):
        return (self.shape[2], self.shape[1], self.shape[0])

    def world(self, ijk):
        return ijk * self.spacing @ self.D.T + self.origin

    def ijk_from_zyx(self, p_zyx):
        return np.stack([p_zyx[:, 2], p_zyx[:, 1], self.shape[2] - 1 - p_zyx[:, 0]], axis=1)

    def centre_world(self):
        return self.world(((self.shape - 1) / 2.0)[None, :])[0]


def ref_affine_camera(grid, primary_deg, secondary_deg):
    """The reference's pixel map as world LPS mm -> pixel: (u, v) = A (X - X_c) + (cu, cv)."""
    R = ref_rotation(primary_deg, secondary_deg).astype(np.float64)
    # p - c = J diag(1/s) D^T (X - X_c);  (u, v) offsets = rows X, Z of R^T (p - c)
    A3 = R.T @ J_ZYX @ np.diag(1.0 / grid.spacing) @ grid.D.T
    A = A3[[2, 0], :]
    ray_world = grid.D @ (grid.spacing * (J_ZYX.T @ R[:, 1]))  # rotated Y axis, world mm
    return A, ray_world / np.linalg.norm(ray_world)


def gimm_pose_from_affine(A):
    """Orthographic gimm pose reproducing pixel map A (2 x 3), if it is a similarity:
    returns (primary, secondary, pixel_mm_at_iso, roll_residual, similarity_residual)."""
    f = 0.5 * (np.linalg.norm(A[0]) + np.linalg.norm(A[1]))
    r, d = A[0] / f, A[1] / f
    similarity = max(abs(np.linalg.norm(r) - 1), abs(np.linalg.norm(d) - 1), abs(r @ d))
    x_cam = r / np.linalg.norm(r)
    y_cam = -d - (-d @ x_cam) * x_cam
    y_cam /= np.linalg.norm(y_cam)
    z_cam = np.cross(x_cam, y_cam)
    M = np.stack([x_cam, y_cam, z_cam], axis=1) @ AP_AXES.T  # M = Rz(a) Rx(-b)
    a = math.degrees(math.atan2(M[1, 0], M[0, 0]))
    b = math.degrees(math.atan2(-M[2, 1], M[2, 2]))
    roll = np.abs(M - gimm_M(a, b)).max()
    return a, b, 1.0 / f, roll, similarity


def gimm_M(a_deg, b_deg):
    a, b = math.radians(a_deg), math.radians(b_deg)
    rz = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])
    rxm = np.array([[1, 0, 0], [0, math.cos(b), math.sin(b)], [0, -math.sin(b), math.cos(b)]])
    return rz @ rxm


def closed_form(primary_ref, secondary_ref):
    return -secondary_ref, -primary_ref


# ----------------------------------------------------------------------------- gimm side
def find_gimm_carm(explicit):
    if explicit:
        return explicit
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    for sub in ("build-ref", "build", "build-ds"):
        p = os.path.join(root, sub, "examples", "gimm-carm")
        if os.access(p, os.X_OK):
            return p
    return shutil.which("gimm-carm")


def gimm_camera(exe, a, b, rows, cols, pixel_iso_mm, iso, principal=None):
    cmd = [exe, "--primary", repr(a), "--secondary", repr(b), "--model", "orthographic",
           "--rows", str(rows), "--cols", str(cols),
           "--pixel", repr(pixel_iso_mm * SID_MM / SOD_MM),
           "--sid", repr(SID_MM), "--sod", repr(SOD_MM),
           "--isocenter", *[repr(float(x)) for x in iso]]
    if principal is not None:
        cmd += ["--principal-point", repr(float(principal[0])), repr(float(principal[1]))]
    out = subprocess.run(cmd, capture_output=True, text=True)
    if out.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed: {out.stderr.strip()}")
    cam = json.loads(out.stdout)
    return np.array(cam["P"]), np.array(cam["principal_axis"])


def project_P(P, X):
    h = np.hstack([X, np.ones((len(X), 1))]) @ P.T
    return h[:, :2] / h[:, 2:3]


# ----------------------------------------------------------------------------- checks
def default_angle_pairs(rng, extra):
    """Reference (primary, secondary) pairs: the corners of the 11 view classes' ranges
    widened by 5 degrees (sample_projection_angles), AP, and a few random pairs."""
    ranges = [((0, 0), (15, 30)), ((40, 60), (0, 0)), ((30, 50), (10, 25)), ((-40, -20), (0, 15)),
              ((0, 0), (0, 0)), ((0, 0), (-30, -20)), ((30, 60), (15, 30)),
              ((35, 55), (-35, -20)), ((-40, -20), (15, 30)), ((-25, -10), (-25, -15))]
    pairs = {(0.0, 0.0)}
    for (plo, phi), (slo, shi) in ranges:
        for p in (plo - 5, phi + 5):
            for s in (slo - 5, shi + 5):
                pairs.add((float(p), float(s)))
    for _ in range(6):
        pairs.add((float(rng.uniform(-65, 65)), float(rng.uniform(-40, 40))))
    return sorted(pairs) + list(extra)


def random_points(rng, shape_zyx, n):
    """Half integer voxel indices (the reference's skeleton points), half continuous."""
    hi = np.array(shape_zyx) - 1
    ints = np.stack([rng.integers(0, h + 1, n - n // 2) for h in hi], axis=1).astype(float)
    cont = rng.uniform(0, 1, (n // 2, 3)) * hi
    return np.vstack([ints, cont])


def check_points(args, exe, grid, pairs, rng, out):
    """gimm camera (closed-form angles) vs the reference's point map. Returns max |dpx|."""
    I, _, K = grid.shape
    iso = grid.centre_world()
    pts = random_points(rng, grid.shape_zyx, args.points)
    X = grid.world(grid.ijk_from_zyx(pts))
    worst = 0.0
    # columns: the closed-form gimm angles and their pixel / ray-direction error against gimm's
    # camera; then the pose fitted to the reference's pixel map alone (roll > 0: no C-arm pair)
    out.append(f"{'ref primary':>11} {'ref second.':>11} | {'gimm prim.':>10} {'gimm sec.':>10}"
               f" | {'max |du,dv| px':>14} {'ray angle':>10} | {'fitted prim.':>12}"
               f" {'fitted sec.':>11} {'roll':>8}")
    for (p, s) in pairs:
        a, b = closed_form(p, s)
        A, ray = ref_affine_camera(grid, p, s)
        fa, fb, fpix, roll, sim = gimm_pose_from_affine(A)
        fit_err = max(abs(fa - a), abs(fb - b), abs(fpix - grid.spacing[0]) / grid.spacing[0])
        P, axis = gimm_camera(exe, a, b, K, I, grid.spacing[0], iso)
        d = np.abs(project_P(P, X) - ref_pixels(pts, p, s, grid.shape_zyx)).max()
        ray_deg = math.degrees(math.acos(min(1.0, abs(float(axis @ ray)))))
        worst = max(worst, d, ray_deg, fit_err, roll, sim)
        out.append(f"{p:11.3f} {s:11.3f} | {a:10.3f} {b:10.3f} | {d:14.3e} {ray_deg:10.2e}"
                   f" | {fa:12.6f} {fb:11.6f} {roll:8.1e}")
    # a cropped reference image: columns [x0, x0 + W) -> shifted principal point
    x0, W = I // 4, K
    for (p, s) in pairs[:3]:
        a, b = closed_form(p, s)
        P, _ = gimm_camera(exe, a, b, K, W, grid.spacing[0], iso,
                           principal=((I - 1) / 2.0 - x0, (K - 1) / 2.0))
        d = np.abs(project_P(P, X) - ref_pixels(pts, p, s, grid.shape_zyx, x_offset=x0)).max()
        worst = max(worst, d)
        out.append(f"crop x_offset {x0}, width {W}, ref ({p:g}, {s:g}): max |du,dv| = {d:.3e} px")
    return worst


def report_anisotropy(grid, pairs, rng, out):
    """For anisotropic voxels: how far the reference's pixel map is from any rigid camera."""
    I, _, K = grid.shape
    pts = random_points(rng, grid.shape_zyx, 2000)
    X = grid.world(grid.ijk_from_zyx(pts))
    worst_sim, worst_px = 0.0, 0.0
    for (p, s) in pairs:
        A, _ = ref_affine_camera(grid, p, s)
        n0, n1 = np.linalg.norm(A[0]), np.linalg.norm(A[1])
        skew = abs(math.degrees(math.acos(A[0] @ A[1] / (n0 * n1))) - 90)
        worst_sim = max(worst_sim, abs(n0 / n1 - 1), skew / 90)
        # the closed-form camera, pixel = in-plane spacing, no gimm binary needed (P = K[R|t])
        a, b = closed_form(p, s)
        Rg = (gimm_M(a, b) @ AP_AXES).T
        uv = (X - grid.centre_world()) @ Rg[:2].T / grid.spacing[0]
        uv = np.stack([uv[:, 0] + (I - 1) / 2.0, -uv[:, 1] + (K - 1) / 2.0], axis=1)
        worst_px = max(worst_px, np.abs(uv - ref_pixels(pts, p, s, grid.shape_zyx)).max())
    out.append(f"anisotropic spacing {' x '.join(f'{x:g}' for x in grid.spacing)} mm: the reference's pixel map has "
               f"row norms differing by up to {100 * worst_sim:.1f}% / non-orthogonal rows, so "
               f"no orthographic C-arm reproduces it; the closed-form angles at pixel "
               f"{grid.spacing[0]:g} mm miss by up to {worst_px:.2f} px over the grid")


def image_check(pairs, out, tol_px=0.25):
    """Render point sources as the reference does (scipy affine_transform, trilinear, sum along
    axis 1) and compare each image's intensity centroid with the point map."""
    try:
        from scipy.ndimage import affine_transform
    except ImportError:
        out.append("image check: scipy not available (skipped)")
        return None
    shape = (29, 37, 45)  # (Z, Y, X), deliberately all different
    c = (np.array(shape, dtype=np.float32) - 1.0) / 2.0
    rng = np.random.default_rng(7)
    worst = 0.0
    for (p, s) in pairs:
        R = ref_rotation(p, s)
        for _ in range(2):
            pt = np.round(c + rng.uniform(-5, 5, 3)).astype(int)
            vol = np.zeros(shape, np.float32)
            vol[tuple(pt)] = 1.0
            rot = affine_transform(vol, matrix=R, offset=c - R @ c, order=1, mode="constant",
                                   cval=0.0, output_shape=shape)
            img = rot.sum(axis=1)  # (Z, X)
            rows, cols = np.indices(img.shape)
            w = img.sum()
            centroid = np.array([(cols * img).sum() / w, (rows * img).sum() / w])
            d = np.abs(centroid - ref_pixels(pt[None, :].astype(float), p, s, shape)[0]).max()
            worst = max(worst, d)
    out.append(f"image check (scipy affine_transform, {len(pairs)} poses x 2 point sources): "
               f"centroid vs point map max {worst:.3f} px (tolerance {tol_px})")
    return worst <= tol_px


def grid_from_nifti(path):
    import nibabel as nib
    img = nib.load(path)
    A = img.affine[:3, :3]
    d_ras = A / np.linalg.norm(A, axis=0)
    d_lps = np.diag([-1.0, -1.0, 1.0]) @ d_ras  # gimm reads NIfTI RAS as LPS
    zooms = np.linalg.norm(A, axis=0)
    codes = "".join(nib.aff2axcodes(img.affine))  # direction each of i, j, k points to
    return img.shape[:3], d_lps, zooms, codes


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--map", nargs=2, type=float, metavar=("PRIMARY", "SECONDARY"),
                    help="print the gimm angles for one reference pair and exit")
    ap.add_argument("--gimm-carm", help="gimm-carm binary (default: build*/examples, PATH)")
    ap.add_argument("--shape", nargs=3, type=int, default=[512, 512, 256], metavar=("I", "J", "K"),
                    help="NIfTI array shape (default 512 512 256)")
    ap.add_argument("--spacing", type=float, default=None,
                    help="isotropic voxel size of the checked grid, mm (default 0.4, or the "
                    "header's j spacing pixdim[2] with --nifti: the reference's ds)")
    ap.add_argument("--aniso-spacing", nargs=3, type=float, default=[0.4, 0.4, 0.5],
                    metavar=("SX", "SY", "SZ"), help="spacing for the anisotropy report")
    ap.add_argument("--nifti", help="take shape and axis directions from this NIfTI header")
    ap.add_argument("--angles", nargs=2, type=float, action="append", default=[],
                    metavar=("PRIMARY", "SECONDARY"), help="an extra reference pair to check")
    ap.add_argument("--points", type=int, default=400, help="random points per pose")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--tol", type=float, default=1e-3, help="pixel tolerance (default 1e-3)")
    ap.add_argument("--image-check", action="store_true",
                    help="also render point sources with scipy as the reference does")
    args = ap.parse_args()

    if args.map:
        a, b = closed_form(*args.map)
        print(json.dumps({"reference": {"primary": args.map[0], "secondary": args.map[1]},
                          "gimm": {"primary_deg": a, "secondary_deg": b,
                                   "model": "orthographic"}}))
        return 0

    exe = find_gimm_carm(args.gimm_carm)
    if not exe:
        print("reference_angles: gimm-carm not found; build it (cmake --build BUILD --target "
              "gimm-carm) or pass --gimm-carm", file=sys.stderr)
        return 2
    rng = np.random.default_rng(args.seed)
    pairs = default_angle_pairs(rng, [tuple(x) for x in args.angles])
    out = []
    d_lps, shape, axcodes = None, args.shape, "i, j, k -> L, P, S (assumed)"
    aniso = args.aniso_spacing
    if args.nifti:
        shape, d_lps, zooms, codes = grid_from_nifti(args.nifti)
        aniso = list(zooms)
        if args.spacing is None:
            args.spacing = float(zooms[1])
        axcodes = f"i, j, k -> {', '.join(codes)} (nibabel axis codes of {args.nifti}; voxel " \
                  f"{' x '.join(f'{z:g}' for z in zooms)} mm; checked at isotropic " \
                  f"{args.spacing:g} mm)"
    if args.spacing is None:
        args.spacing = 0.4
    grid = Grid(shape, [args.spacing] * 3, d_lps)
    out.append(f"grid {tuple(grid.shape)} (I, J, K), axes {axcodes}; gimm-carm: {exe}")
    out.append("mapping: gimm primary = -(ref secondary), gimm secondary = -(ref primary); "
               f"orthographic, pixel {args.spacing:g} mm at the isocentre (= 1 voxel), "
               f"{grid.shape[2]} rows x {grid.shape[0]} cols")
    try:
        worst = check_points(args, exe, grid, pairs, rng, out)
    except RuntimeError as e:
        print(f"reference_angles: {e}", file=sys.stderr)
        return 2
    ok = worst <= args.tol
    out.append(f"points: {args.points} per pose x {len(pairs)} poses; max deviation "
               f"{worst:.3e} (pixels, ray angle in degrees, fitted-vs-closed-form angles, roll) "
               f"-> {'PASS' if ok else 'FAIL'} (tolerance {args.tol})")
    if len(set(aniso)) > 1:
        report_anisotropy(Grid(shape, aniso, d_lps), pairs, rng, out)
    if args.image_check:
        res = image_check(pairs, out)
        ok = ok and (res is not False)
    print("\n".join(out))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
