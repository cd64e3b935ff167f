"""Builds the Python module gimm (gimm._gimm from python/src, the package python/gimm) with
setuptools and Debian's pybind11, without a network and without CMake (docs/python.md):

    /usr/bin/python3 -m pip wheel --no-build-isolation --no-deps -w dist python/
    /usr/bin/python3 -m pip install --no-build-isolation python/

The headers come from this source tree (../include); Eigen from EIGEN3_INCLUDE_DIR (default
/usr/include/eigen3), GLM, nlohmann_json, libpng and zlib from the system, OpenMP from GCC. The
shipped matcher weights go into the wheel (gimm/weights/). GIMM_BUILD_JOBS compiles that many
sources at once (default 1). CMake's build (python/CMakeLists.txt) is the other way to build it.
"""
import os
import pathlib
import re
import shutil

from pybind11.setup_helpers import ParallelCompile, Pybind11Extension, build_ext
from setuptools import setup
from setuptools.command.build_py import build_py
from setuptools.command.sdist import sdist

HERE = pathlib.Path(__file__).resolve().parent
# What the build needs from the gimm tree around python/: in a clone, that tree; in an sdist
# (which cannot hold files outside python/), the copy the sdist command puts in _gimm_source/.
VENDORED = HERE / "_gimm_source"
TREE_FILES = ("include", "cmake/version.hpp.in", "CMakeLists.txt", "LICENSE",
              "weights/gimm-phantom-128.safetensors")
ROOT = HERE.parent if (HERE.parent / "include" / "gimm").is_dir() else VENDORED
WEIGHTS = ROOT / "weights" / "gimm-phantom-128.safetensors"
VERSION = re.search(r"project\(gimm VERSION ([0-9.]+)",
                    (ROOT / "CMakeLists.txt").read_text()).group(1)


def generated_include():
    """include/gimm/version.hpp as CMake makes it from cmake/version.hpp.in."""
    major, minor, patch = VERSION.split(".")
    text = (ROOT / "cmake" / "version.hpp.in").read_text()
    for key, value in (("PROJECT_VERSION_MAJOR", major), ("PROJECT_VERSION_MINOR", minor),
                       ("PROJECT_VERSION_PATCH", patch), ("PROJECT_VERSION", VERSION)):
        text = text.replace(f"@{key}@", value)
    out = HERE / "build" / "generated"
    (out / "gimm").mkdir(parents=True, exist_ok=True)
    header = out / "gimm" / "version.hpp"
    if not header.exists() or header.read_text() != text:
        header.write_text(text)
    return str(out)


class build_py_with_weights(build_py):
    """Copies the shipped matcher weights into the package (Matcher() finds them there)."""

    def run(self):
        super().run()
        target = pathlib.Path(self.build_lib) / "gimm" / "weights"
        target.mkdir(parents=True, exist_ok=True)
        shutil.copy2(WEIGHTS, target / WEIGHTS.name)


class sdist_with_tree(sdist):
    """An sdist that builds anywhere: the headers, the version template, the version's
    CMakeLists.txt, the LICENSE and the shipped weights copied into _gimm_source/ first."""

    def run(self):
        if ROOT != VENDORED:
            shutil.rmtree(VENDORED, ignore_errors=True)
            for name in TREE_FILES:
                source, target = ROOT / name, VENDORED / name
                target.parent.mkdir(parents=True, exist_ok=True)
                if source.is_dir():
                    shutil.copytree(source, target)
                else:
                    shutil.copy2(source, target)
        super().run()


ParallelCompile("GIMM_BUILD_JOBS", default=1).install()

module = Pybind11Extension(
    "gimm._gimm",
    # bind_dicom.cpp needs GDCM and the mesh mode Embree: CMake's build has them (GIMM_WITH_DICOM,
    # GIMM_WITH_EMBREE), the wheel does not (its Renderer refuses vessels='mesh' by name).
    sorted(str(p.relative_to(HERE)) for p in (HERE / "src").glob("*.cpp") if p.name != "bind_dicom.cpp"),
    include_dirs=[str(ROOT / "include"), generated_include(),
                  os.environ.get("EIGEN3_INCLUDE_DIR", "/usr/include/eigen3")],
    define_macros=[("EIGEN_DONT_PARALLELIZE", None), ("NDEBUG", None)],
    extra_compile_args=["-fopenmp", "-O3"],
    extra_link_args=["-fopenmp"],
    libraries=["png", "z"],
    cxx_std=17,
)

setup(
    version=VERSION,
    packages=["gimm"],
    package_data={"gimm": ["_gimm.pyi", "py.typed"]},
    ext_modules=[module],
    cmdclass={"build_ext": build_ext, "build_py": build_py_with_weights, "sdist": sdist_with_tree},
    license_files=["LICENSE"],
    zip_safe=False,
)
