#!/usr/bin/env bash
# The test suite under AddressSanitizer and UBSan (gcc): every C++ test room and the CLI tests,
# whose tools are built sanitized too, and the sanitized-only targets (GIMM_SANITIZER_TESTS: the
# traversal's ASan tests and fuzz target, the readers' mutation fuzzer), so an out-of-bounds read, a use after free, a leak or
# undefined behaviour anywhere a test reaches fails the run. What it leaves out, and why: the
# package tests (they build consumers of the installed headers, not the sanitized tree), the
# Python module and the tests that import it or PyTorch (an ASan runtime has to be preloaded
# into python3 for those), the Python-only tests (layer rule, atlas scripts) and clang-format.
#
#   tests/sanitize/run.sh [--build DIR]      (default build-asan; CI runs it after the tests)
set -euo pipefail
src=$(cd "$(dirname "$0")/../.." && pwd)
build=build-asan
while [ $# -gt 0 ]; do
  case $1 in
    --build) build=${2:?usage: tests/sanitize/run.sh [--build DIR]}; shift 2 ;;
    *) echo "error: sanitize/run.sh: unknown argument '$1' (usage: tests/sanitize/run.sh [--build DIR])" >&2; exit 2 ;;
  esac
done
flags="-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer"
# -O1 for all: ASan's own advice, and half the compile time of -O3.
cmake -S "$src" -B "$build" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_FLAGS_RELEASE="-O1 -DNDEBUG" \
  -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_EXE_LINKER_FLAGS="$flags" -DGIMM_TESTS_OPT=-O1 \
  -DGIMM_BUILD_PYTHON=OFF -DGIMM_BUILD_BENCHMARKS=OFF -DGIMM_SANITIZER_TESTS=ON \
  > "$build.configure.log" 2>&1 ||
  { tail -20 "$build.configure.log" >&2; exit 1; }
cmake --build "$build" -j2
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:strict_string_checks=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
ctest --test-dir "$build" -j2 --output-on-failure \
  -E '^(package_.*|clang_format|python|train|layers|atlas_tools)$'
