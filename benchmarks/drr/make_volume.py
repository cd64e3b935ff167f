#!/usr/bin/env python3
"""Writes a 256^3 float32 attenuation volume (mm^-1) as NIfTI-1 for the DRR side-by-side.

A thorax-like scene at 0.75 mm voxels (192 mm cube centred on the isocentre): a water body
ellipsoid, two air lungs, a bone spine cylinder posterior, a denser heart, and an asymmetric
marker (a bone rod on the patient's left, towards the head) so orientation errors show.
World is LPS in gimm; the NIfTI sform stores RAS (x and y negated), as the standard says.
"""
import struct
import sys

import numpy as np


def write_nifti(path, data, spacing, origin_lps):
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
    struct.pack_into("<4f", hdr, 280, -spacing[0], 0, 0, -ox)
    struct.pack_into("<4f", hdr, 296, 0, -spacing[1], 0, -oy)
    struct.pack_into("<4f", hdr, 312, 0, 0, spacing[2], oz)
    hdr[344:348] = b"n+1\0"
    with open(path, "wb") as f:
        f.write(hdr)
        f.write(np.asfortranarray(data.astype("<f4")).tobytes(order="F"))


def main(path, n=256, spacing=0.75):
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
    write_nifti(path, mu, (spacing,) * 3, (c[0], c[0], c[0]))


if __name__ == "__main__":
    main(sys.argv[1])
