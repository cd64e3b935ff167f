"""Shared fixtures of the gimm Python tests: paths, one phantom and its LCA renderer."""
import functools
import os
import subprocess

import numpy as np

import gimm

TMP = os.environ.get("GIMM_TEST_TMP", "/tmp/gimm-python-tests")
EXAMPLES = os.environ.get("GIMM_TEST_EXAMPLES", "")
SEED = 7


def tmp_path(*parts):
    path = os.path.join(TMP, *parts)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    return path


def cli(name):
    """The path of a gimm CLI of the build, or None when it was not built."""
    path = os.path.join(EXAMPLES, name)
    return path if EXAMPLES and os.access(path, os.X_OK) else None


def run(*args):
    done = subprocess.run([str(a) for a in args], capture_output=True, text=True)
    if done.returncode != 0:
        raise AssertionError(f"{args[0]} failed ({done.returncode}):\n{done.stdout}{done.stderr}")
    return done.stdout


@functools.lru_cache(maxsize=None)
def phantom():
    return gimm.make_phantom(seed=SEED)


@functools.lru_cache(maxsize=None)
def lca():
    p = phantom()
    return gimm.split_coronary_systems(p["label"], p["geometry"])["lca"]


@functools.lru_cache(maxsize=None)
def renderer():
    p = phantom()
    return gimm.Renderer(p["hu"], lca(), geometry=p["geometry"])


def carm(primary, secondary, size=128):
    """An LCA view of the phantom: 2 mm pixels at 128 px (the shipped weights' input size)."""
    p = phantom()
    return gimm.CArm(primary_deg=primary, secondary_deg=secondary, rows=size, cols=size,
                     pixel_mm=256.0 / size, isocenter=gimm.vessel_isocenter(lca(), p["geometry"]))


def is_capsule_view(array):
    """True when `array` is a numpy view of a buffer owned by a pybind11 capsule (no copy)."""
    return (isinstance(array, np.ndarray) and not array.flags.owndata
            and type(array.base).__name__ == "PyCapsule")
