# cmake -DCLANG_FORMAT=... -DSOURCE=... -P check_format.cmake
# Fails, listing the files, if any C++ file under include/ examples/ tests/ benchmarks/
# packaging/ is not formatted as .clang-format says. Fix with: scripts/format.sh
file(GLOB_RECURSE files
  ${SOURCE}/include/*.hpp ${SOURCE}/examples/*.cpp ${SOURCE}/examples/*.hpp
  ${SOURCE}/tests/*.cpp ${SOURCE}/tests/*.hpp ${SOURCE}/benchmarks/*.cpp ${SOURCE}/benchmarks/*.hpp
  ${SOURCE}/packaging/*.cpp)
execute_process(COMMAND ${CLANG_FORMAT} --dry-run --Werror ${files}
  RESULT_VARIABLE rc ERROR_VARIABLE err OUTPUT_QUIET)
if(NOT rc EQUAL 0)
  string(REGEX MATCHALL "[^\n]*error:[^\n]*" lines "${err}")
  list(LENGTH lines count)
  list(SUBLIST lines 0 20 shown)
  string(REPLACE ";" "\n" shown "${shown}")
  message(FATAL_ERROR "clang-format: ${count} formatting differences, first ones:\n${shown}\nrun scripts/format.sh")
endif()
