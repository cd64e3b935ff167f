"""gimm: anatomy-grounded synthetic coronary angiography and multi-view matching.

The C++ toolkit (include/gimm/) from Python, numpy in and out (docs/python.md):

    import gimm
    p = gimm.make_phantom(seed=7)
    trees = gimm.split_coronary_systems(p["label"], p["geometry"])
    renderer = gimm.Renderer(p["hu"], trees["lca"], geometry=p["geometry"])
    carm = gimm.CArm(primary_deg=30, secondary_deg=20, rows=256, cols=256, pixel_mm=1.0,
                     isocenter=gimm.vessel_isocenter(trees["lca"], p["geometry"]))
    view = renderer.render(carm.camera())   # dict of numpy arrays, no copy

Conventions: world = patient LPS mm; images (rows, cols) with pixel centres at integers and
points as (u, v) = (column, row); volumes [i, j, k] in Fortran order with a geometry dict;
x_b^T F x_a = 0. Errors raise gimm.Error (gimm.IoError, gimm.FormatError).
"""
from ._gimm import *  # noqa: F401,F403  (the compiled module: every public name)
from ._gimm import Error, FormatError, IoError, __version__  # noqa: F401
