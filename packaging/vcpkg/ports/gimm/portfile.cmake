# vcpkg overlay port of gimm, built from the checkout it lives in:
#   vcpkg install gimm[io,embree,dicom] --overlay-ports=<checkout>/packaging/vcpkg/ports
# The CMake flags come from packaging/recipe-options.json, which the conan recipe reads too
# (docs/packaging.md); tests/package/run_recipes.cmake runs this file with stand-ins for the
# vcpkg helpers to check it.
get_filename_component(SOURCE_PATH "${CMAKE_CURRENT_LIST_DIR}/../../../.." ABSOLUTE)
# Header-only: one configuration is enough, and no debug tree is installed.
set(VCPKG_BUILD_TYPE release)

file(READ "${SOURCE_PATH}/packaging/recipe-options.json" gimm_flags)
set(common_options "")
string(JSON count LENGTH "${gimm_flags}" cmake_cache)
math(EXPR last "${count} - 1")
foreach(i RANGE ${last})
  string(JSON name MEMBER "${gimm_flags}" cmake_cache ${i})
  string(JSON value GET "${gimm_flags}" cmake_cache ${name})
  list(APPEND common_options "-D${name}=${value}")
endforeach()
# Each feature switches its GIMM_WITH_* option (the manifest's features carry the dependencies).
set(feature_pairs "")
string(JSON count LENGTH "${gimm_flags}" features)
math(EXPR last "${count} - 1")
foreach(i RANGE ${last})
  string(JSON feature MEMBER "${gimm_flags}" features ${i})
  string(JSON option GET "${gimm_flags}" features ${feature} option)
  list(APPEND feature_pairs ${feature} ${option})
endforeach()
vcpkg_check_features(OUT_FEATURE_OPTIONS feature_options FEATURES ${feature_pairs})

vcpkg_cmake_configure(SOURCE_PATH "${SOURCE_PATH}" OPTIONS ${common_options} ${feature_options})
vcpkg_cmake_install()
# gimm installs its config under share/cmake/gimm; vcpkg wants it in share/gimm.
vcpkg_cmake_config_fixup(PACKAGE_NAME gimm CONFIG_PATH share/cmake/gimm)
vcpkg_fixup_pkgconfig()

# The LICENSE goes to share/gimm/copyright instead of share/doc.
file(REMOVE_RECURSE "${CURRENT_PACKAGES_DIR}/debug" "${CURRENT_PACKAGES_DIR}/share/doc")
file(INSTALL "${CMAKE_CURRENT_LIST_DIR}/usage" DESTINATION "${CURRENT_PACKAGES_DIR}/share/${PORT}")
vcpkg_install_copyright(FILE_LIST "${SOURCE_PATH}/LICENSE")
