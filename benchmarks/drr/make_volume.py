#!/usr/bin/env python3
"""Writes float32 attenuation volumes (mm^-1) as NIfTI-1 for the DRR side-by-side.

  make_volume.py OUT.nii                 thorax scene (timing and orientation check)
  make_volume.py --blobs OUT.nii OUT.json  Gaussian blobs, analytic line integrals (accuracy)
  make_volume.py --cube OUT.nii          64^3 of 1.0 at 1.5 mm: line integral = chord length
  make_volume.py --thorax-flipped OUT.nii  the thorax stored with i and j reversed and direction
                                         cosines -1 on x and y: the same object in the world

Thorax: a thorax-like scene at 0.75 mm voxels (192 mm cube centred on the isocentre): a water body
ellipsoid, two air lungs, a bone spine cylinder posterior, a denser heart, and an asymmetric
marker (a bone rod on the patient's left, towards the head) so orientation errors show.
Blobs: 60 seeded Gaussian blobs (sigma 0.6-8 mm, peak 0.005-0.03 mm^-1, centres within 50 mm
of the isocentre) sampled at the voxel centres of the same 256^3 grid; the line integral of a
blob along a line at distance d from its centre is peak sigma sqrt(2 pi) exp(-d^2 / 2 sigma^2)
(the blobs end well inside the volume, so the infinite-line formula is exact to 1e-5).
World is LPS in gimm; the NIfTI sform stores RAS (x and y negated), as the standard says.
"""
import json
import struct
import sys

import numpy as np


def write_nifti(path, data, spacing, origin_lps, flip_xy=False):
    """sform: LPS index->world diag(spacing) from origin_lps, or with flip_xy diag(-sx, -sy, sz)
    (RAS-identity axes, as many scanners write), for which data is stored reversed in i and j."""
    nx, ny, nz = data.shape
    hdr = bytearray(352)
    struct.pack_into("<i", hdr, 0, 348)
    struct.pack_into("<8h", hdr, 40, 3, nx, ny, nz, 1, 1, 1, 1)
    struct.pack_into("<hh", hdr, 70, 16, 32)  # float32
    struct.pack_into("<8f", hdr, 76, 1.0, *spacing, 1, 1, 1, 1)
    struct.pack_into("<f", hdr, 108, 352.0)  # vox_offset
    struct.pack_into("<ff", hdr, 112, 1.0, 0.0)  # scl_slope, scl_inter
    struct.pack_into("<hh", hdr, 252, 0, 1)  # qform_code 0, sform_code 1
    ox, oy, oz = origin_lps
    sx = spacing[0] if flip_xy else -spacing[0]
    sy = spacing[1] if flip_xy else -spacing[1]
    struct.pack_into("<4f", hdr, 280, sx, 0, 0, -ox)
    struct.pack_into("<4f", hdr, 296, 0, sy, 0, -oy)
    struct.pack_into("<4f", hdr, 312, 0, 0, spacing[2], oz)
    hdr[344:348] = b"n+1\0"
    with open(path, "wb") as f:
        f.write(hdr)
        f.write(np.asfortranarray(data.astype("<f4")).tobytes(order="F"))


def main(path, n=256, spacing=0.75, flip_xy=False):
    c = (np.arange(n) - (n - 1) / 2) * spacing
    x, y, z = np.meshgrid(c, c, c, indexing="ij")  # LPS mm, i fastest on disk (Fortran order)
    mu = np.zeros((n, n, n), np.float32)
    body = (x / 90) ** 2 + (y / 70) ** 2 < 1
    mu[body] = 0.02
    lungs = (((x - 40) / 28) ** 2 + (y / 40) ** 2 + (z / 80) ** 2 < 1) | (
        ((x + 40) / 28) ** 2 + (y / 40) ** 2 + (z / 80) ** 2 < 1)
    mu[lungs] = 0.003
    heart = ((x - 10) / 45) ** 2 + ((y + 10) / 40) ** 2 + ((z + 10) / 50) ** 2 < 1
    mu[heart] = 0.021
    spine = (x / 15) ** 2 + ((y - 50) / 15) ** 2 < 1
    mu[spine & body] = 0.04
    marker = ((x - 60) / 4) ** 2 + ((y + 20) / 4) ** 2 < 1
    mu[marker & (z > 30)] = 0.05
    if flip_xy:  # voxel (0, 0, k) now at the far corner: LPS (c[-1], c[-1], z)
        write_nifti(path, mu[::-1, ::-1, :], (spacing,) * 3, (c[-1], c[-1], c[0]), flip_xy=True)
    else:
        write_nifti(path, mu, (spacing,) * 3, (c[0], c[0], c[0]))


def blobs(path, json_path, n=256, spacing=0.75, seed=2024, count=60):
    rng = np.random.default_rng(seed)
    params = [dict(centre=rng.uniform(-50, 50, 3).tolist(), sigma=float(rng.uniform(0.6, 8.0)),
                   peak=float(rng.uniform(0.005, 0.03))) for _ in range(count)]
    c = (np.arange(n) - (n - 1) / 2) * spacing
    mu = np.zeros((n, n, n), np.float64)
    for b in params:  # each blob on its +-6 sigma sub-box only
        lo = [max(0, int(np.floor((b["centre"][a] - 6 * b["sigma"] - c[0]) / spacing))) for a in range(3)]
        hi = [min(n, int(np.ceil((b["centre"][a] + 6 * b["sigma"] - c[0]) / spacing)) + 1) for a in range(3)]
        x, y, z = np.meshgrid(c[lo[0]:hi[0]], c[lo[1]:hi[1]], c[lo[2]:hi[2]], indexing="ij")
        r2 = (x - b["centre"][0]) ** 2 + (y - b["centre"][1]) ** 2 + (z - b["centre"][2]) ** 2
        mu[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]] += b["peak"] * np.exp(-r2 / (2 * b["sigma"] ** 2))
    write_nifti(path, mu.astype(np.float32), (spacing,) * 3, (c[0], c[0], c[0]))
    with open(json_path, "w") as f:
        json.dump(params, f)


def cube(path, n=64, spacing=1.5):
    c = (np.arange(n) - (n - 1) / 2) * spacing
    write_nifti(path, np.ones((n, n, n), np.float32), (spacing,) * 3, (c[0], c[0], c[0]))


if __name__ == "__main__":
    if sys.argv[1] == "--blobs":
        blobs(sys.argv[2], sys.argv[3])
    elif sys.argv[1] == "--thorax-flipped":
        main(sys.argv[2], flip_xy=True)
    elif sys.argv[1] == "--cube":
        cube(sys.argv[2])
    else:
        main(sys.argv[1])
