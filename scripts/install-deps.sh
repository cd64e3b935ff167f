#!/usr/bin/env bash
# Installs the Debian packages gimm needs, and only those that are missing.
# Idempotent: a second run installs nothing and does not touch apt's lists.
#
#   scripts/install-deps.sh            build + tests + examples (the default)
#   scripts/install-deps.sh bench      + side-by-side anchors (plastimatch, OpenCV, hyperfine, Node/npm)
#   scripts/install-deps.sh train      + PyTorch (with OpenBLAS) for tools/train
#   scripts/install-deps.sh fuzz       + clang and its libFuzzer/sanitizer runtimes (tests/fuzz)
#   scripts/install-deps.sh all        everything
set -euo pipefail

core=(build-essential cmake pkg-config git libeigen3-dev libglm-dev libembree-dev
      nlohmann-json3-dev catch2 libbenchmark-dev libcli11-dev zlib1g-dev libpng-dev
      clang-format gnuplot-nox python3-numpy python3-nibabel libgdcm-dev libgdcm-tools
      pybind11-dev python3-pybind11 python3-pil python3-matplotlib python3-pip python3-setuptools
      python3-wheel)
bench=(plastimatch libopencv-dev python3-opencv hyperfine)
train=(python3-torch libopenblas0-pthread)
fuzz=(clang libclang-rt-14-dev)

wanted=("${core[@]}")
for group in "$@"; do
  case "$group" in
    core) ;;
    bench) wanted+=("${bench[@]}") ;;
    train) wanted+=("${train[@]}") ;;
    fuzz) wanted+=("${fuzz[@]}") ;;
    all) wanted+=("${bench[@]}" "${train[@]}" "${fuzz[@]}") ;;
    *) echo "error: install-deps.sh: unknown group '$group' (core|bench|train|fuzz|all)" >&2; exit 2 ;;
  esac
done

# The matcher side by side runs ONNX Runtime under Node (onnxruntime-node, from the npm
# registry, installed by benchmarks/matcher/side_by_side.sh). A Node that brings its own npm
# (e.g. NodeSource's) is kept; otherwise Debian's nodejs and npm.
if [[ " ${wanted[*]} " == *" plastimatch "* ]] && ! command -v npm >/dev/null; then
  wanted+=(nodejs npm)
fi

missing=()
for pkg in "${wanted[@]}"; do
  dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing+=("$pkg")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#wanted[@]} packages present"
  exit 0
fi

sudo=""
[ "$(id -u)" -eq 0 ] || sudo="sudo"
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
