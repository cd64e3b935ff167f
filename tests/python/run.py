#!/usr/bin/env python3
"""Runs the tests of the Python module gimm (tests/python/test_*.py) against a built module.

    run.py MODULE_DIR EXAMPLES_DIR TMP_DIR

MODULE_DIR holds the package gimm/ (the build tree's <build>/python); EXAMPLES_DIR the gimm CLIs
(gimm-drr, gimm-match, gimm-eval) that some tests compare against, skipped where absent;
TMP_DIR a scratch folder. Exits 77 (ctest: skipped) when the module was not built.
"""
import glob
import os
import sys
import unittest


def main() -> int:
    if len(sys.argv) != 4:
        print(__doc__, file=sys.stderr)
        return 2
    module_dir, examples, tmp = (os.path.abspath(a) for a in sys.argv[1:])
    if not glob.glob(os.path.join(module_dir, "gimm", "_gimm*.so")):
        print(f"python tests skipped: no gimm module in {module_dir}/gimm "
              "(configure with pybind11-dev installed, or -DGIMM_BUILD_PYTHON=ON)")
        return 77
    try:
        import numpy  # noqa: F401
    except ImportError:
        print(f"python tests skipped: {sys.executable} has no numpy (python3-numpy)")
        return 77
    sys.path.insert(0, module_dir)
    os.environ["PYTHONPATH"] = module_dir + os.pathsep + os.environ.get("PYTHONPATH", "")
    os.environ["GIMM_TEST_EXAMPLES"] = examples
    os.environ["GIMM_TEST_TMP"] = tmp
    os.makedirs(tmp, exist_ok=True)
    import gimm
    here = os.path.dirname(os.path.abspath(__file__))
    print(f"gimm {gimm.__version__} from {os.path.dirname(gimm.__file__)}; "
          f"CLIs from {examples}", flush=True)
    suite = unittest.defaultTestLoader.discover(here, pattern="test_*.py", top_level_dir=here)
    result = unittest.TextTestRunner(verbosity=2).run(suite)
    return 0 if result.wasSuccessful() else 1


if __name__ == "__main__":
    sys.exit(main())
