# Conan 2 recipe for gimm, built from this checkout:
#   conan create packaging/conan -o "gimm/*:with_embree=True" --build=missing
# The CMake flags and the dependencies come from packaging/recipe-options.json, which the vcpkg
# port reads too; tests/package/run_recipes.cmake checks both against each other (docs/packaging.md).
import json
import os
import re

from conan import ConanFile
from conan.errors import ConanInvalidConfiguration
from conan.tools.cmake import CMake, CMakeDeps, CMakeToolchain, cmake_layout
from conan.tools.files import copy, rmdir

_FLAGS_FILE = "recipe-options.json"


def _load_flags():
    # Next to this file once exported to the cache (export() copies it), one folder up in the
    # checkout.
    here = os.path.dirname(os.path.abspath(__file__))
    for folder in (here, os.path.dirname(here)):
        path = os.path.join(folder, _FLAGS_FILE)
        if os.path.isfile(path):
            with open(path, encoding="utf-8") as f:
                return json.load(f)
    raise FileNotFoundError(f"gimm recipe: {_FLAGS_FILE} is neither in {here} nor above it")


def project_version(source_root):
    """The VERSION of project(gimm ...) in the top-level CMakeLists.txt: the one version number."""
    with open(os.path.join(source_root, "CMakeLists.txt"), encoding="utf-8") as f:
        found = re.search(r"^\s*project\s*\(\s*gimm\s+VERSION\s+([0-9]+(?:\.[0-9]+)*)", f.read(),
                          re.MULTILINE)
    if not found:
        raise ValueError("gimm recipe: no 'project(gimm VERSION x.y.z' line in CMakeLists.txt")
    return found.group(1)


def _component_ref(reference):
    # "zlib/[>=1.2.11 <2]" -> "zlib::zlib": a component requiring a whole package.
    name = reference.split("/")[0]
    return f"{name}::{name}"


_FLAGS = _load_flags()


class GimmConan(ConanFile):
    name = "gimm"
    description = ("Anatomy-grounded synthetic coronary angiography and geometry-informed "
                   "multi-view matching (header-only C++17)")
    license = "MIT"
    topics = ("angiography", "x-ray", "geometry", "header-only")
    package_type = "header-library"
    # Only for CMakeToolchain: no package_id() method, so conan clears settings, options and
    # requirements from the package id of a header-library. package() keeps only files that do
    # not depend on them (headers, version.hpp, LICENSE); the components come from package_info().
    settings = "os", "arch", "compiler", "build_type"
    options = {f"with_{f}": [True, False] for f in _FLAGS["features"]}
    default_options = {f"with_{f}": spec["default"] for f, spec in _FLAGS["features"].items()}
    no_copy_source = True

    def set_version(self):
        # Read from the checkout at export time; a version given on the command line must agree.
        version = project_version(os.path.join(self.recipe_folder, "..", ".."))
        if self.version and str(self.version) != version:
            raise ConanInvalidConfiguration(f"gimm is {version}, not {self.version}")
        self.version = version

    def export(self):
        copy(self, _FLAGS_FILE, os.path.join(self.recipe_folder, ".."), self.export_folder)

    def export_sources(self):
        root = os.path.join(self.recipe_folder, "..", "..")
        for pattern in ("CMakeLists.txt", "LICENSE", "cmake/*", "include/*"):
            copy(self, pattern, root, self.export_sources_folder)

    def _enabled(self):
        return [f for f in _FLAGS["features"] if self.options.get_safe(f"with_{f}")]

    def validate(self):
        for feature in self._enabled():
            for need in _FLAGS["features"][feature]["needs"]:
                if not self.options.get_safe(f"with_{need}"):
                    raise ConanInvalidConfiguration(f"gimm: with_{feature} needs with_{need}")

    def requirements(self):
        # Header-only: everything gimm's headers include or link reaches the consumer.
        references = list(_FLAGS["core"]["conan"])
        for feature in self._enabled():
            references += _FLAGS["features"][feature]["conan"]
        for reference in references:
            self.requires(reference, transitive_headers=True, transitive_libs=True)

    def layout(self):
        cmake_layout(self, src_folder=".")

    def generate(self):
        toolchain = CMakeToolchain(self)
        toolchain.cache_variables.update(_FLAGS["cmake_cache"])
        enabled = self._enabled()
        for feature, spec in _FLAGS["features"].items():
            toolchain.cache_variables[spec["option"]] = "ON" if feature in enabled else "OFF"
        toolchain.generate()
        CMakeDeps(self).generate()

    def build(self):
        # Nothing to compile: configuring generates gimm/version.hpp and the install rules.
        CMake(self).configure()

    def package(self):
        CMake(self).install()
        copy(self, "LICENSE", self.source_folder, os.path.join(self.package_folder, "licenses"))
        # Conan writes its own CMake and pkg-config files from package_info(); gimm's would
        # look for the dependencies outside conan.
        for folder in ("cmake", "pkgconfig", "doc"):
            rmdir(self, os.path.join(self.package_folder, "share", folder))

    def package_info(self):
        self.cpp_info.set_property("cmake_file_name", "gimm")
        # The union of the components; gimm::gimm is the core component, as in gimm's own config.
        self.cpp_info.set_property("cmake_target_name", "gimm::gimm_all")
        self.cpp_info.set_property("pkg_config_name", "gimm-all")
        core = self.cpp_info.components["gimm"]
        core.set_property("cmake_target_name", "gimm::gimm")
        core.set_property("pkg_config_name", "gimm")
        core.requires = [_component_ref(r) for r in _FLAGS["core"]["conan"]]
        # gimm parallelises its products itself; Eigen's own OpenMP split would change the last
        # bits with the thread count (CMakeLists.txt).
        core.defines = ["EIGEN_DONT_PARALLELIZE"]
        # OpenMP comes with the compiler, not from conan.
        openmp = ["/openmp"] if self.settings.compiler == "msvc" else ["-fopenmp"]
        core.cxxflags = openmp
        if self.settings.compiler != "msvc":
            core.sharedlinkflags = openmp
            core.exelinkflags = openmp
        core.bindirs = []
        core.libdirs = []
        for feature in self._enabled():
            spec = _FLAGS["features"][feature]
            component = self.cpp_info.components[feature]
            component.set_property("cmake_target_name", f"gimm::{feature}")
            component.set_property("pkg_config_name", f"gimm-{feature}")
            component.requires = (["gimm"] + list(spec["needs"]) +
                                  [_component_ref(r) for r in spec["conan"]])
            if feature == "io" and self.settings.os in ("Linux", "FreeBSD"):
                component.system_libs = ["pthread"]  # the dataset writer's thread
            component.bindirs = []
            component.libdirs = []
