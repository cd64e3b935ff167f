#!/usr/bin/env bash
# Builds the libFuzzer targets (clang; tests/fuzz/reader_libfuzzer.cpp, one per reader, and the
# Siddon traversal) and fuzzes each on a working copy of its committed corpus.
#
#   tests/fuzz/run.sh --seconds S [--build DIR] [TARGET ...]   explore for S seconds per target
#   tests/fuzz/run.sh --runs N [--build DIR] [TARGET ...]      N inputs per target, seed 1:
#                                                              deterministic (what CI runs)
#
# DIR defaults to build-fuzz. TARGET: a reader name (nifti, png8, dicom, ...; tests/CMakeLists.txt
# lists them) or siddon; default all. Per target: DIR/fuzz/<target>.log (libFuzzer's output),
# crashing inputs in DIR/fuzz/artifacts/, the grown corpus in DIR/fuzz/corpus/<target>/. Prints
# one line per target (inputs run, coverage, corpus size, result) and exits 1 if any target
# found a defect.
set -euo pipefail
src=$(cd "$(dirname "$0")/../.." && pwd)
usage="usage: tests/fuzz/run.sh --seconds S | --runs N [--build DIR] [TARGET ...]"
budget=() build=build-fuzz targets=()
while [ $# -gt 0 ]; do
  case $1 in
    --seconds|--runs)
      [[ ${2:-} =~ ^[1-9][0-9]*$ ]] || { echo "error: run.sh: $1 needs a positive integer, got '${2:-}'" >&2; exit 2; }
      [ "$1" = --seconds ] && budget=(-max_total_time="$2") || budget=(-runs="$2" -seed=1)
      shift 2 ;;
    --build) build=${2:?$usage}; shift 2 ;;
    -*) echo "error: run.sh: unknown option '$1' ($usage)" >&2; exit 2 ;;
    *) targets+=("$1"); shift ;;
  esac
done
[ ${#budget[@]} -gt 0 ] || { echo "error: run.sh: give --seconds S or --runs N ($usage)" >&2; exit 2; }
command -v clang++ >/dev/null || { echo "error: run.sh: clang++ not found (apt-get install clang)" >&2; exit 2; }

readers=$(sed -n '/set(GIMM_READER_FUZZ_TARGETS/,/)/p' "$src/tests/CMakeLists.txt" |
          tr -d '()' | sed 's/set//; s/GIMM_READER_FUZZ_TARGETS//' | tr -s ' \n' ' ')
[ ${#targets[@]} -gt 0 ] || targets=($readers siddon)
for t in "${targets[@]}"; do
  [[ " $readers siddon " == *" $t "* ]] || { echo "error: run.sh: no fuzz target '$t' (one of:$readers siddon)" >&2; exit 2; }
done

cmake -S "$src" -B "$build" -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=Release \
  -DGIMM_FUZZ_LIBFUZZER=ON -DGIMM_BUILD_PYTHON=OFF > "$build.configure.log" 2>&1 ||
  { tail -20 "$build.configure.log" >&2; exit 1; }
# Both binaries in one build (parallel); each reader is a link to gimm_fuzz_readers.
cmake --build "$build" -j2 --target gimm_libfuzzers

out=$build/fuzz
mkdir -p "$out/artifacts"
status=0
printf '%-14s %10s %8s %8s  %s\n' target runs cov corpus result
for t in "${targets[@]}"; do
  corpus=$out/corpus/$t
  mkdir -p "$corpus"
  # The committed seeds; the large ones are the committed test fixtures, not copied into
  # tests/fuzz/corpus.
  [ -d "$src/tests/fuzz/corpus/$t" ] && cp -n "$src/tests/fuzz/corpus/$t"/* "$corpus"/
  case $t in
    matcher) cp -n "$src/tests/data/nn/parity_weights.safetensors" "$corpus/fixture.safetensors" ;;
    safetensors) cp -n "$src/tests/data/nn/parity_expected.safetensors" "$corpus/fixture.safetensors" ;;
    nrrd) cp -n "$src/tests/data/volumes/ct.nrrd" "$corpus/fixture.nrrd" ;;
    metaimage) cp -n "$src/tests/data/volumes/ct.mha" "$corpus/fixture.mha" ;;
  esac
  bin=$build/tests/gimm_fuzz_$t
  [ "$t" = siddon ] && bin=$build/tests/gimm_siddon_libfuzzer
  log=$out/$t.log
  result=ok
  "$bin" "${budget[@]}" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
    -artifact_prefix="$out/artifacts/$t-" "$corpus" > "$log" 2>&1 || { result="DEFECT (see $log)"; status=1; }
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | grep -o '[0-9]*' || true)
  printf '%-14s %10s %8s %8s  %s\n' "$t" "${runs:--}" "${cov:--}" "$(ls "$corpus" | wc -l)" "$result"
done
exit $status
