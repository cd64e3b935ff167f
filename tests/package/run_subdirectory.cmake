# Configures, builds and runs tests/package/subdirectory: gimm by add_subdirectory with
# GIMM_WITH_IO and GIMM_WITH_EMBREE off, and the optional packages hidden from find_package.
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
execute_process(COMMAND ${CMAKE_COMMAND} --build ${WORK} RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "building the README example on gimm::gimm alone failed")
endif()
execute_process(COMMAND ${WORK}/gimm_readme_example RESULT_VARIABLE rc OUTPUT_QUIET)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the README example built without io and Embree failed")
endif()
