# Stand-ins for the vcpkg helpers packaging/vcpkg/ports/gimm/portfile.cmake calls, so that
# run_recipes.cmake can run the port file itself without vcpkg (not installable offline). They
# do what vcpkg's helpers do for a release-only, header-only port on Linux, as far as gimm's
# files are concerned; they are not vcpkg: no toolchain file, no triplet, no dependency builds
# (the system's packages stand in for the ports), no post-build lint beyond run_recipes' checks.
# Set by the caller: PORT, FEATURES, CURRENT_PACKAGES_DIR, CURRENT_BUILDTREES_DIR,
# CURRENT_INSTALLED_DIR, GIMM_HIDE (-DCMAKE_DISABLE_FIND_PACKAGE_...=ON flags) and
# GIMM_CONAN_OPTIONS (the conan recipe's -D flags for the same features).

function(vcpkg_check_features)
  cmake_parse_arguments(PARSE_ARGV 0 arg "" "OUT_FEATURE_OPTIONS" "FEATURES")
  set(out "")
  list(LENGTH arg_FEATURES n)
  math(EXPR last "${n} - 1")
  foreach(i RANGE 0 ${last} 2)
    math(EXPR j "${i} + 1")
    list(GET arg_FEATURES ${i} feature)
    list(GET arg_FEATURES ${j} option)
    if(feature IN_LIST FEATURES)
      list(APPEND out "-D${option}=ON")
    else()
      list(APPEND out "-D${option}=OFF")
    endif()
  endforeach()
  set(${arg_OUT_FEATURE_OPTIONS} "${out}" PARENT_SCOPE)
endfunction()

function(vcpkg_cmake_configure)
  cmake_parse_arguments(PARSE_ARGV 0 arg "" "SOURCE_PATH" "OPTIONS")
  # The two recipes must configure gimm alike: compare before spending time on it.
  set(port "${arg_OPTIONS}")
  set(conan "${GIMM_CONAN_OPTIONS}")
  list(SORT port)
  list(SORT conan)
  if(NOT port STREQUAL conan)
    gimm_recipes_fail("flags" "the port passes\n  ${port}\nthe conan recipe\n  ${conan}")
  endif()
  # What vcpkg adds for every port (those that matter to gimm), then the port's options.
  execute_process(COMMAND ${CMAKE_COMMAND} -S ${arg_SOURCE_PATH} -B ${CURRENT_BUILDTREES_DIR}/rel
    -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX=${CURRENT_PACKAGES_DIR}
    -DCMAKE_INSTALL_LIBDIR=lib -DCMAKE_INSTALL_BINDIR=bin -DFETCHCONTENT_FULLY_DISCONNECTED=ON
    -DCMAKE_FIND_PACKAGE_NO_PACKAGE_REGISTRY=ON -DCMAKE_EXPORT_NO_PACKAGE_REGISTRY=ON
    ${arg_OPTIONS} ${GIMM_HIDE}
    RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
  if(NOT rc EQUAL 0)
    gimm_recipes_fail("vcpkg_cmake_configure" "configuring gimm failed:\n${out}")
  endif()
endfunction()

function(vcpkg_cmake_install)
  execute_process(COMMAND ${CMAKE_COMMAND} --build ${CURRENT_BUILDTREES_DIR}/rel --target install
    RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
  if(NOT rc EQUAL 0)
    gimm_recipes_fail("vcpkg_cmake_install" "building target install failed:\n${out}")
  endif()
endfunction()

# Moves the config files to share/<PACKAGE_NAME> and rewrites the prefix each computes from its
# own place for the new depth (two levels below the prefix), as vcpkg's helper does.
function(vcpkg_cmake_config_fixup)
  cmake_parse_arguments(PARSE_ARGV 0 arg "" "PACKAGE_NAME;CONFIG_PATH" "")
  set(from ${CURRENT_PACKAGES_DIR}/${arg_CONFIG_PATH})
  set(to ${CURRENT_PACKAGES_DIR}/share/${arg_PACKAGE_NAME})
  if(NOT IS_DIRECTORY ${from})
    gimm_recipes_fail("vcpkg_cmake_config_fixup" "'${from}' does not exist")
  endif()
  if(NOT from STREQUAL to)
    file(GLOB files ${from}/*)
    file(COPY ${files} DESTINATION ${to})
    file(REMOVE_RECURSE ${from})
    # An emptied .../cmake parent goes too (share/cmake here).
    get_filename_component(parent ${from} DIRECTORY)
    get_filename_component(parent_name ${parent} NAME)
    if(parent_name STREQUAL "cmake")
      file(REMOVE_RECURSE ${parent})
    endif()
  endif()
  set(up [[get_filename_component(_IMPORT_PREFIX "${_IMPORT_PREFIX}" PATH)]])
  file(GLOB cmake_files ${to}/*.cmake)
  foreach(file ${cmake_files})
    file(READ ${file} text)
    # Generated targets files: the file's folder, then one parent step per level.
    string(REGEX REPLACE "(get_filename_component\\(_IMPORT_PREFIX \"\\\${CMAKE_CURRENT_LIST_FILE}\" PATH\\)\n)(get_filename_component\\(_IMPORT_PREFIX \"\\\${_IMPORT_PREFIX}\" PATH\\)\n)+"
      "\\1${up}\n${up}\n" text "${text}")
    # configure_package_config_file's PACKAGE_PREFIX_DIR.
    string(REGEX REPLACE "(get_filename_component\\(PACKAGE_PREFIX_DIR \"\\\${CMAKE_CURRENT_LIST_DIR}/)(\\.\\./)+\" ABSOLUTE\\)"
      "\\1../../\" ABSOLUTE)" text "${text}")
    string(REPLACE "${CURRENT_INSTALLED_DIR}" [[${_IMPORT_PREFIX}]] text "${text}")
    string(REPLACE "${CURRENT_PACKAGES_DIR}" [[${_IMPORT_PREFIX}]] text "${text}")
    file(WRITE ${file} "${text}")
  endforeach()
endfunction()

# Makes every .pc file relative to its own place and checks that pkg-config reads it.
function(vcpkg_fixup_pkgconfig)
  file(GLOB_RECURSE pc_files ${CURRENT_PACKAGES_DIR}/*.pc)
  foreach(file ${pc_files})
    get_filename_component(dir ${file} DIRECTORY)
    file(RELATIVE_PATH up ${dir} ${CURRENT_PACKAGES_DIR})
    string(REGEX REPLACE "/$" "" up "${up}")
    file(READ ${file} text)
    string(REPLACE "${CURRENT_PACKAGES_DIR}" [[${prefix}]] text "${text}")
    string(REPLACE "${CURRENT_INSTALLED_DIR}" [[${prefix}]] text "${text}")
    string(REGEX REPLACE "(^|\n)[\t ]*prefix[\t ]*=[^\n]*" "" text "${text}")
    file(WRITE ${file} "prefix=\${pcfiledir}/${up}\n${text}")
    get_filename_component(module ${file} NAME_WE)
    execute_process(COMMAND ${CMAKE_COMMAND} -E env PKG_CONFIG_PATH=${dir}
      pkg-config --print-errors --exists ${module} RESULT_VARIABLE rc ERROR_VARIABLE err)
    if(NOT rc EQUAL 0)
      gimm_recipes_fail("vcpkg_fixup_pkgconfig" "pkg-config cannot read ${file}: ${err}")
    endif()
  endforeach()
endfunction()

function(vcpkg_install_copyright)
  cmake_parse_arguments(PARSE_ARGV 0 arg "" "" "FILE_LIST")
  set(text "")
  foreach(file ${arg_FILE_LIST})
    file(READ ${file} part)
    string(APPEND text "${part}")
  endforeach()
  file(WRITE ${CURRENT_PACKAGES_DIR}/share/${PORT}/copyright "${text}")
endfunction()
