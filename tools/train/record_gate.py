#!/usr/bin/env python3
"""Records in matcher weights the epipolar gate they were tuned with (gimm-match's default).

    /usr/bin/python3 tools/train/record_gate.py W.safetensors --gate hard --delta 4 --snap

Rewrites only __metadata__["gimm_config"]["gate"] = {"mode", "delta_px", "snap"}; the tensors
are copied byte for byte (numpy only, no PyTorch). Choose the gate on a tuning split, not on the
test split (tools/atlas/gate_sweep.py, weights/README.md).
"""
import argparse
import json
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from safetensors_io import load_file, save_file  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("weights", help="gimm matcher weights (safetensors), rewritten in place")
    parser.add_argument("--gate", required=True, choices=["hard", "soft", "logit", "none"])
    parser.add_argument("--delta", type=float, help="hard gate threshold, px (needed for hard)")
    parser.add_argument("--snap", action="store_true", help="B points onto their epipolar lines")
    args = parser.parse_args()
    if args.gate == "hard" and (args.delta is None or not math.isfinite(args.delta) or args.delta <= 0):
        parser.error(f"--gate hard needs --delta > 0, got {args.delta}")
    if args.snap and args.gate == "none":
        parser.error("--snap needs a gate, got --gate none")
    try:
        tensors, meta = load_file(args.weights)
    except (OSError, ValueError) as e:
        sys.exit(f"error: record_gate.py: {e}")
    if "gimm_config" not in meta:
        sys.exit(f"error: record_gate.py: {args.weights}: no gimm_config in __metadata__")
    config = json.loads(meta["gimm_config"])
    config["gate"] = {"mode": args.gate, "snap": args.snap}
    if args.delta is not None:
        config["gate"]["delta_px"] = args.delta
    meta["gimm_config"] = json.dumps(config, sort_keys=True)
    save_file(args.weights, tensors, meta)  # atomic: a temporary file, then a rename
    print(f"record_gate: {args.weights}: gate {config['gate']}")


if __name__ == "__main__":
    main()
