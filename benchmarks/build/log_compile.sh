#!/usr/bin/env bash
# A compiler launcher that appends each compile's wall time to $GIMM_COMPILE_LOG (an absolute
# path: make runs the compiles in several folders), as "seconds<TAB>object file". To see where
# a build's time goes, and what a change to one header costs (docs/performance.md, "Build"):
#   cmake -S . -B build-dev -DGIMM_UNITY_BUILD=OFF \
#     -DCMAKE_CXX_COMPILER_LAUNCHER=$PWD/benchmarks/build/log_compile.sh
#   GIMM_COMPILE_LOG=$PWD/times.tsv cmake --build build-dev -j2
#   benchmarks/build/header_cost.py build-dev times.tsv        # what a touched header costs
set -uo pipefail
log=${GIMM_COMPILE_LOG:-}
if [[ "$log" != /* ]]; then
  echo "log_compile.sh: set GIMM_COMPILE_LOG to an absolute path, got '$log'" >&2
  exit 2
fi
out="" prev=""
for arg in "$@"; do
  [ "$prev" = "-o" ] && out=$arg
  prev=$arg
done
start=$(date +%s%N)
"$@"
rc=$?
end=$(date +%s%N)
printf '%d.%03d\t%s\n' $(((end - start) / 1000000000)) $(((end - start) / 1000000 % 1000)) "$out" >>"$log"
exit $rc
