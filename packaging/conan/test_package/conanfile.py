# conan create's test of the gimm package: builds and runs packaging/test_package, the same
# project the vcpkg port's check builds (tests/package/run_recipes.cmake), with the components
# of the options the package was created with.
import os

from conan import ConanFile
from conan.tools.build import can_run
from conan.tools.cmake import CMake, CMakeToolchain, cmake_layout


class GimmTestPackageConan(ConanFile):
    settings = "os", "arch", "compiler", "build_type"
    generators = "CMakeDeps", "VirtualRunEnv"
    test_type = "explicit"

    def requirements(self):
        self.requires(self.tested_reference_str)

    def layout(self):
        cmake_layout(self, src_folder=os.path.join("..", "..", "test_package"))

    def generate(self):
        gimm = self.dependencies["gimm"]
        components = [c for c in ("io", "embree", "dicom") if gimm.options.get_safe(f"with_{c}")]
        toolchain = CMakeToolchain(self)
        toolchain.cache_variables["GIMM_TP_COMPONENTS"] = ";".join(components)
        toolchain.generate()

    def build(self):
        cmake = CMake(self)
        cmake.configure()
        cmake.build()

    def test(self):
        if can_run(self):
            binary = os.path.join(self.cpp.build.bindir, "gimm_test_package")
            # Its argument: a folder for the PNG and DICOM files it writes and reads back.
            self.run(f'"{binary}" "{self.build_folder}"', env="conanrun")
