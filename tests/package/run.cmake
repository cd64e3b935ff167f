# Installs gimm from the build tree into a private prefix, then configures, builds and runs
# the consumer project in tests/package against the *installed* package.
include(${CMAKE_CURRENT_LIST_DIR}/install_gimm.cmake)
# -O1, no build type: what is tested is finding, compiling, linking and running against the
# package, not the consumer's speed (-O3 doubled the test's time).
execute_process(COMMAND ${CMAKE_COMMAND} -S ${GIMM_SOURCE}/tests/package -B ${WORK}/build
  -DCMAKE_PREFIX_PATH=${WORK}/prefix -DCMAKE_BUILD_TYPE= -DCMAKE_CXX_FLAGS=-O1 RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "configuring the consumer against the installed gimm failed")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} --build ${WORK}/build --parallel 2 RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "building the consumer failed")
endif()
execute_process(COMMAND ${WORK}/build/gimm_consumer RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the consumer failed")
endif()
execute_process(COMMAND ${WORK}/build/gimm_dicom_consumer ${WORK}/consumer.dcm RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the DICOM consumer failed")
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
