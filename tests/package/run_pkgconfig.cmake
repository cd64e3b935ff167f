# Installs gimm from the build tree, moves the prefix, and compiles and runs two consumers
# with nothing but the flags of the moved prefix's .pc files.
include(${CMAKE_CURRENT_LIST_DIR}/install_gimm.cmake)
# pkg-config, from a moved prefix: the .pc files find the headers from their own place. Both
# consumers are compiled and run with nothing but pkg-config's flags.
find_program(PKG_CONFIG pkg-config REQUIRED)
find_program(CXX_FOR_PC NAMES c++ g++ REQUIRED)
file(RENAME ${WORK}/prefix ${WORK}/moved)
if(NOT EXISTS ${WORK}/moved/share/doc/gimm/LICENSE)
  message(FATAL_ERROR "the package does not install its LICENSE")
endif()
# gimm: the README's example (the renderer, OpenMP); gimm-io: the recipes' test_package with its
# PNG round trip, which needs the module's libraries (zlib, libpng) and compiles in 5 s (main.cpp,
# the CMake consumer's, instantiates the geometry's decompositions: 15 s).
foreach(consumer "tests/package/readme_example.cpp;gimm;-DGIMM_TP_IO=0"
                 "packaging/test_package/test_package.cpp;gimm-io;-DGIMM_TP_IO=1")
  list(GET consumer 0 path)
  list(GET consumer 1 module)
  list(GET consumer 2 define)
  get_filename_component(source ${path} NAME_WE)
  execute_process(COMMAND ${CMAKE_COMMAND} -E env PKG_CONFIG_PATH=${WORK}/moved/share/pkgconfig
    ${PKG_CONFIG} --cflags --libs ${module} OUTPUT_VARIABLE flags RESULT_VARIABLE rc
    ERROR_VARIABLE err OUTPUT_STRIP_TRAILING_WHITESPACE)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "pkg-config ${module} from the moved prefix failed: ${err}")
  endif()
  if(NOT flags MATCHES "-I${WORK}/moved/" OR NOT flags MATCHES "EIGEN_DONT_PARALLELIZE")
    message(FATAL_ERROR "pkg-config ${module}: flags '${flags}' lack the moved include "
                        "directory or EIGEN_DONT_PARALLELIZE")
  endif()
  separate_arguments(flag_list UNIX_COMMAND "${flags}")
  execute_process(COMMAND ${CXX_FOR_PC} -std=c++17 -O1 ${define} ${GIMM_SOURCE}/${path}
    ${flag_list} -o ${WORK}/pc_${source} RESULT_VARIABLE rc ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "compiling ${source}.cpp with pkg-config ${module} failed: ${err}")
  endif()
  execute_process(COMMAND ${WORK}/pc_${source} ${WORK} RESULT_VARIABLE rc OUTPUT_QUIET)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "the pkg-config build of ${source}.cpp failed to run")
  endif()
  message(STATUS "pkg-config ${module}: ${source}.cpp built from the moved prefix and ran")
endforeach()
