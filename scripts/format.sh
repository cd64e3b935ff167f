#!/usr/bin/env bash
# Formats gimm's C++ sources in place with the root .clang-format.
set -euo pipefail
cd "$(dirname "$0")/.."
find include examples tests benchmarks packaging -name '*.hpp' -o -name '*.cpp' | xargs clang-format -i
