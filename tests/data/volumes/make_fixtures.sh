#!/usr/bin/env bash
# Regenerates the fixtures in this folder (see README.md). Needs Debian's python3-nibabel and
# plastimatch (scripts/install-deps.sh bench). Run from this folder.
set -euo pipefail
cd "$(dirname "$0")"
/usr/bin/python3 - <<'PY'
import numpy as np, nibabel as nib
# 5x4x3 int16, every voxel distinct (a flipped or swapped axis changes the values), negatives
# and values beyond 8 bits.
i, j, k = np.meshgrid(np.arange(5), np.arange(4), np.arange(3), indexing="ij")
data = ((i + 10 * j + 100 * k) * 7 - 1000).astype(np.int16)
# RAS affine: a 30 degree rotation about (1, 2, 3), spacing 0.75, 0.5, 1.25 mm, origin (12.5,
# -30.25, 101) mm (dyadic numbers, exact in the header's float32).
axis = np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0)
t = np.deg2rad(30.0)
K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
R = np.eye(3) + np.sin(t) * K + (1 - np.cos(t)) * K @ K
A = np.eye(4)
A[:3, :3] = R @ np.diag([0.75, 0.5, 1.25])
A[:3, 3] = [12.5, -30.25, 101.0]
img = nib.Nifti1Image(data, A)
img.set_qform(A, code=1)
img.set_sform(A, code=1)
nib.save(img, "source.nii")
PY
plastimatch convert --input source.nii --output-img ct.nrrd        # attached, gzip
plastimatch convert --input source.nii --output-img ct_nhdr.nhdr   # detached, raw
plastimatch convert --input source.nii --output-img ct.mha         # LOCAL, raw
plastimatch convert --input source.nii --output-img ct_mhd.mhd     # detached, raw
