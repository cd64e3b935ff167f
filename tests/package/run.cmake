# Installs gimm from the build tree into a private prefix, then configures, builds and runs
# the consumer project in tests/package against the *installed* package.
file(REMOVE_RECURSE ${WORK})
execute_process(COMMAND ${CMAKE_COMMAND} --install ${GIMM_BUILD} --prefix ${WORK}/prefix
  RESULT_VARIABLE rc OUTPUT_QUIET)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "install of gimm failed")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -S ${GIMM_SOURCE}/tests/package -B ${WORK}/build
  -DCMAKE_PREFIX_PATH=${WORK}/prefix -DCMAKE_BUILD_TYPE=Release RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "configuring the consumer against the installed gimm failed")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} --build ${WORK}/build RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "building the consumer failed")
endif()
execute_process(COMMAND ${WORK}/build/gimm_consumer RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the consumer failed")
endif()
execute_process(COMMAND ${WORK}/build/gimm_readme_example RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the README's C++ example failed")
endif()
# An unknown component is named in the error.
execute_process(COMMAND ${CMAKE_COMMAND} -S ${GIMM_SOURCE}/tests/package/bad_component
  -B ${WORK}/bad_component -DCMAKE_PREFIX_PATH=${WORK}/prefix RESULT_VARIABLE rc
  OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(rc EQUAL 0 OR NOT "${out}${err}" MATCHES "no component 'rendering'")
  message(FATAL_ERROR "find_package(gimm COMPONENTS rendering) did not name the component: ${err}")
endif()
# The README shows the example exactly as it is built here.
file(READ ${GIMM_SOURCE}/tests/package/readme_example.cpp example)
file(READ ${GIMM_SOURCE}/README.md readme)
string(FIND "${readme}" "${example}" at)
if(at EQUAL -1)
  message(FATAL_ERROR "README.md does not hold tests/package/readme_example.cpp verbatim")
endif()
# pkg-config, from a moved prefix: the .pc files find the headers from their own place. Both
# consumers are compiled and run with nothing but pkg-config's flags.
find_program(PKG_CONFIG pkg-config)
find_program(CXX_FOR_PC NAMES c++ g++)
if(PKG_CONFIG AND CXX_FOR_PC)
  file(RENAME ${WORK}/prefix ${WORK}/moved)
  if(NOT EXISTS ${WORK}/moved/share/doc/gimm/LICENSE)
    message(FATAL_ERROR "the package does not install its LICENSE")
  endif()
  foreach(consumer "readme_example;gimm" "main;gimm-io")
    list(GET consumer 0 source)
    list(GET consumer 1 module)
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
    execute_process(COMMAND ${CXX_FOR_PC} -std=c++17 -O1 ${GIMM_SOURCE}/tests/package/${source}.cpp
      ${flag_list} -o ${WORK}/pc_${source} RESULT_VARIABLE rc ERROR_VARIABLE err)
    if(NOT rc EQUAL 0)
      message(FATAL_ERROR "compiling ${source}.cpp with pkg-config ${module} failed: ${err}")
    endif()
    execute_process(COMMAND ${WORK}/pc_${source} RESULT_VARIABLE rc OUTPUT_QUIET)
    if(NOT rc EQUAL 0)
      message(FATAL_ERROR "the pkg-config build of ${source}.cpp failed to run")
    endif()
    message(STATUS "pkg-config ${module}: ${source}.cpp built from the moved prefix and ran")
  endforeach()
endif()
