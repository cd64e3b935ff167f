"""Runs the conan recipe's methods without conan (not installable offline), for package_recipes.

usage: conan_recipe_probe.py <packaging/conan/conanfile.py> <feature set>...
A feature set is features joined by "+" (io+dicom), or "core" for none. Prints JSON:
  {"version", "default_options", "sets": {set: {"cache_variables", "requires", "components"}}}
The stand-ins below record what the recipe asks of conan; they check only conan's rules that
the recipe could break here: options named as declared, invalid feature sets refused, and every
requirement used by a component and every component requirement declared (conan 2 refuses
both mistakes at install time).
"""
import importlib.util
import itertools
import json
import os
import sys
import types


class Recorded:
    """CMakeToolchain, CMakeDeps and CMake: only the cache variables are kept."""

    def __init__(self, conanfile, *args, **kwargs):
        self.cache_variables = {}
        conanfile.toolchains.append(self)

    def generate(self, *args, **kwargs):
        pass


class Component:
    def __init__(self):
        self.properties, self.requires, self.defines, self.system_libs = {}, [], [], []

    def set_property(self, name, value):
        self.properties[name] = value


class CppInfo(Component):
    def __init__(self):
        super().__init__()
        self.components = {}


class Components(dict):
    def __missing__(self, name):
        self[name] = Component()
        return self[name]


class Options:
    def __init__(self, values):
        self._values = dict(values)

    def get_safe(self, name):
        return self._values.get(name)

    def __getattr__(self, name):
        if name.startswith("_") or name not in self._values:
            raise AttributeError(f"the recipe reads an undeclared option '{name}'")
        return self._values[name]


class InvalidConfiguration(Exception):
    pass


class ConanFileStandIn:
    def __init__(self, recipe_folder, options):
        self.recipe_folder = recipe_folder
        self.version = None
        self.options = Options(options)
        self.settings = types.SimpleNamespace(os="Linux", compiler="gcc", arch="x86_64",
                                              build_type="Release")
        self.required, self.toolchains = [], []
        self.cpp_info = CppInfo()
        self.cpp_info.components = Components()

    def requires(self, reference, **traits):
        self.required.append(reference)


def install_conan_stand_ins():
    modules = {name: types.ModuleType(name) for name in
               ("conan", "conan.errors", "conan.tools", "conan.tools.cmake", "conan.tools.files",
                "conan.tools.build")}
    modules["conan"].ConanFile = ConanFileStandIn
    modules["conan.errors"].ConanInvalidConfiguration = InvalidConfiguration
    cmake = modules["conan.tools.cmake"]
    cmake.CMake = cmake.CMakeDeps = cmake.CMakeToolchain = Recorded
    cmake.cmake_layout = lambda *args, **kwargs: None
    modules["conan.tools.files"].copy = modules["conan.tools.files"].rmdir = lambda *a, **k: None
    modules["conan.tools.build"].can_run = lambda *args: True
    sys.modules.update(modules)


def fail(message):
    sys.exit(message)


def main(recipe_path, feature_sets):
    install_conan_stand_ins()
    spec = importlib.util.spec_from_file_location("gimm_conanfile", recipe_path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    recipe = module.GimmConan
    folder = os.path.dirname(os.path.abspath(recipe_path))
    if set(recipe.options) != set(recipe.default_options):
        fail(f"options {sorted(recipe.options)} but defaults for {sorted(recipe.default_options)}")

    def instance(features):
        options = {name: name[len("with_"):] in features for name in recipe.options}
        return recipe(folder, options)

    probe = instance([])
    probe.set_version()
    out = {"version": str(probe.version), "default_options": recipe.default_options, "sets": {}}

    # Every combination that breaks a feature's "needs" must be refused by validate().
    features = [name[len("with_"):] for name in recipe.options]
    for n in range(len(features) + 1):
        for combination in itertools.combinations(features, n):
            broken = [f for f in combination
                      for need in module._FLAGS["features"][f]["needs"] if need not in combination]
            try:
                instance(combination).validate()
                refused = False
            except InvalidConfiguration:
                refused = True
            if refused != bool(broken):
                fail(f"validate() {'refuses' if refused else 'accepts'} {list(combination)}")

    for name in feature_sets:
        chosen = [] if name == "core" else name.split("+")
        conanfile = instance(chosen)
        conanfile.validate()
        conanfile.requirements()
        conanfile.generate()
        conanfile.package_info()
        cache = {}
        for toolchain in conanfile.toolchains:
            cache.update(toolchain.cache_variables)
        packages = {reference.split("/")[0] for reference in conanfile.required}
        components = {}
        used = set()
        for component_name, component in conanfile.cpp_info.components.items():
            components[component_name] = {"requires": component.requires,
                                          "properties": component.properties}
            for requirement in component.requires:
                if "::" in requirement:
                    package = requirement.split("::")[0]
                    if package not in packages:
                        fail(f"[{name}] component {component_name} requires {requirement}, "
                             f"which is not a requirement")
                    used.add(package)
                elif requirement not in conanfile.cpp_info.components:
                    fail(f"[{name}] component {component_name} requires an unknown component "
                         f"{requirement}")
        if used != packages:
            fail(f"[{name}] requirements no component uses: {sorted(packages - used)}")
        out["sets"][name] = {"cache_variables": cache, "requires": conanfile.required,
                             "components": components}
    print(json.dumps(out, indent=1, sort_keys=True))


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2:])
