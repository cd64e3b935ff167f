#!/usr/bin/env python3
"""PyTorch CPU side of the matcher side by side: one pair, RUNS timed runs after a warm-up.

    run_torch.py WEIGHTS PAIRS_DIR SIZE RUNS DUMP_DIR
Prints one JSON line: engine, size, seconds per pair (median, min), matches, peak RSS (MB).
Threads: torch.set_num_threads(OMP_NUM_THREADS, default 2).
"""
import json
import os
import resource
import statistics
import sys
import time

import numpy as np
import torch

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tools", "train"))
from export import load_model  # noqa: E402


def main():
    weights, pairs, size, runs, dump = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), sys.argv[5]
    torch.set_num_threads(int(os.environ.get("OMP_NUM_THREADS", "2")))
    model = load_model(weights)
    data = np.fromfile(os.path.join(pairs, f"pair_{size}.f32"), dtype=np.float32).reshape(2, 1, 1, size, size)
    a, b = torch.from_numpy(data[0].copy()), torch.from_numpy(data[1].copy())
    times = []
    with torch.inference_mode():
        out = model(a, b, 1, 2)  # warm-up
        for _ in range(runs):
            start = time.perf_counter()
            out = model(a, b, 1, 2)
            times.append(time.perf_counter() - start)
    with open(os.path.join(dump, f"torch_{size}.json"), "w") as f:
        json.dump({"points0": out["points0"].tolist(), "points1": out["points1"].tolist(),
                   "mconf": out["mconf"].tolist()}, f)
    print(json.dumps({"engine": "pytorch", "size": size, "median_s": statistics.median(times),
                      "min_s": min(times), "matches": int(out["mconf"].numel()),
                      "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0}))


if __name__ == "__main__":
    main()
