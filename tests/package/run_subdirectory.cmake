# Configures, builds and runs tests/package/subdirectory: gimm by plain add_subdirectory with
# the optional packages hidden from find_package (the parts turn themselves off); and checks
# that a part asked for with its package missing fails naming the switch.
file(REMOVE_RECURSE ${WORK})
execute_process(COMMAND ${CMAKE_COMMAND} -S ${GIMM_SOURCE}/tests/package/subdirectory -B ${WORK}
  -DGIMM_SOURCE=${GIMM_SOURCE} -DCMAKE_BUILD_TYPE= -DCMAKE_CXX_FLAGS=-O1  # as run.cmake
  -DCMAKE_DISABLE_FIND_PACKAGE_nlohmann_json=ON -DCMAKE_DISABLE_FIND_PACKAGE_ZLIB=ON
  -DCMAKE_DISABLE_FIND_PACKAGE_PNG=ON -DCMAKE_DISABLE_FIND_PACKAGE_embree=ON
  -DCMAKE_DISABLE_FIND_PACKAGE_GDCM=ON
  RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "configuring gimm by add_subdirectory without io and Embree failed")
endif()
# A part asked for (ON) whose package is missing: the error names the package and the switch.
execute_process(COMMAND ${CMAKE_COMMAND} -S ${GIMM_SOURCE}/tests/package/subdirectory
  -B ${WORK}-on -DGIMM_SOURCE=${GIMM_SOURCE} -DGIMM_WITH_EMBREE=ON
  -DCMAKE_DISABLE_FIND_PACKAGE_embree=ON
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
file(REMOVE_RECURSE ${WORK}-on)
if(rc EQUAL 0 OR NOT err MATCHES "GIMM_WITH_EMBREE=ON" OR NOT err MATCHES "embree"
   OR NOT err MATCHES "-DGIMM_WITH_EMBREE=OFF")
  message(FATAL_ERROR "GIMM_WITH_EMBREE=ON without Embree: expected an error naming the switch, "
                      "got exit ${rc}: ${err}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} --build ${WORK} RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "building the README example on gimm::gimm alone failed")
endif()
execute_process(COMMAND ${WORK}/gimm_readme_example RESULT_VARIABLE rc OUTPUT_QUIET)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the README example built without io and Embree failed")
endif()
