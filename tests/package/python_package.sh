#!/usr/bin/env bash
# The Python package as a user gets it, offline: an sdist of python/ that builds in a clean
# folder (nothing of the tree around it), its wheel installed with --target, imported from
# another folder, the LICENSE in the wheel's metadata, gimm.torch and the weights inside.
#
#   tests/package/python_package.sh WORK_DIR        (CI: .ci/run; about 3 minutes on 2 cores)
set -euo pipefail
src=$(cd "$(dirname "$0")/../.." && pwd)
work=${1:?usage: tests/package/python_package.sh WORK_DIR}
rm -rf "$work" && mkdir -p "$work"
work=$(cd "$work" && pwd) # every step below runs in another folder
mkdir -p "$work/sdist" "$work/clean" "$work/dist" "$work/site" "$work/elsewhere"
py=/usr/bin/python3
(cd "$src/python" && $py setup.py -q sdist -d "$work/sdist" > "$work/sdist.log" 2>&1) ||
  { tail -20 "$work/sdist.log" >&2; echo "error: python_package: the sdist failed" >&2; exit 1; }
tar xzf "$work"/sdist/gimm-*.tar.gz -C "$work/clean"
(cd "$work"/clean/gimm-* && GIMM_BUILD_JOBS=2 $py -m pip wheel --no-build-isolation --no-deps \
   -w "$work/dist" . > "$work/wheel.log" 2>&1) ||
  { tail -30 "$work/wheel.log" >&2; echo "error: python_package: the sdist does not build in a clean folder" >&2; exit 1; }
wheel=$(ls "$work"/dist/gimm-*.whl)
$py -m zipfile -l "$wheel" > "$work/wheel.txt"
for want in "dist-info/LICENSE" "gimm/torch.py" "gimm/weights/gimm-phantom-128.safetensors" \
            "gimm/_gimm"; do
  grep -q "$want" "$work/wheel.txt" ||
    { echo "error: python_package: $want is not in $(basename "$wheel")" >&2; exit 1; }
done
$py -m pip install --no-deps --no-index --target "$work/site" "$wheel" > "$work/install.log" 2>&1 ||
  { tail -20 "$work/install.log" >&2; exit 1; }
cd "$work/elsewhere"
PYTHONPATH="$work/site" $py -c '
import gimm, os, sys
assert gimm.__file__.startswith(sys.argv[1]), gimm.__file__
p = gimm.make_phantom(seed=3)
print("python_package: gimm", gimm.__version__, "from", os.path.dirname(gimm.__file__),
      "renders a phantom of", p["hu"].shape)
' "$work/site"
