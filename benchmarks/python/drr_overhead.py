#!/usr/bin/python3
"""The cost of calling gimm from Python: one 512 x 512 DRR of the ImageCAS-size phantom
(512 x 512 x 256 voxels) through gimm.Renderer.render against the same render in C++
(gimm_render_bench's BM_ViewRenderer_ImageCAS_512det: same phantom, recipe, pads, camera,
outputs), in one run on the same machine.

    PYTHONPATH=build/python benchmarks/python/drr_overhead.py build [--repeats 5] [--rounds 3]

Interleaves the two (C++ then Python, --rounds times). Prints both medians and the overhead (Python / C++ - 1). Target (issue 19): <= 5%.

Then the GIL: 4 renders on one OpenMP thread each, from one Python thread in turn against two
Python threads at once (gimm.set_num_threads(1) in each): with the GIL released during a
render, two threads take about half the time on two free cores.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import threading
import time

import gimm


def python_renderer():
    p = gimm.make_phantom(seed=1, size="imagecas")
    renderer = gimm.Renderer(p["hu"], p["label"], geometry=p["geometry"])
    camera = gimm.CArm(primary_deg=30.0, secondary_deg=20.0).camera()  # the bench's test_camera(30)
    renderer.render(camera)  # warm-up: first-touch of the output buffers, thread pool start
    return renderer, camera


def python_times(renderer, camera, repeats):
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        view = renderer.render(camera)
        times.append(time.perf_counter() - start)
        assert view["intensity"].shape == (512, 512)
    return times


def cpp_times(build, repeats):
    exe = os.path.join(build, "benchmarks", "gimm_render_bench")
    if not os.access(exe, os.X_OK):
        sys.exit(f"error: drr_overhead: {exe} not built (cmake --build {build} --target "
                 "gimm_render_bench)")
    out = subprocess.run([exe, "--benchmark_filter=^BM_ViewRenderer_ImageCAS_512det",
                          f"--benchmark_repetitions={repeats}", "--benchmark_format=json"],
                         capture_output=True, text=True, check=True).stdout
    runs = [b for b in json.loads(out)["benchmarks"] if b.get("run_type") == "iteration"]
    return [b["real_time"] / 1e3 for b in runs]  # ms -> s


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("build", help="the CMake build folder")
    parser.add_argument("--repeats", type=int, default=5, help="renders per side per round")
    parser.add_argument("--rounds", type=int, default=3, help="C++ then Python, this many times")
    args = parser.parse_args(argv)
    if args.repeats < 2 or args.rounds < 1:
        parser.error(f"need --repeats >= 2 and --rounds >= 1, got {args.repeats} and {args.rounds}")
    # Interleaved rounds, so that a change in the machine's load falls on both sides alike.
    renderer, camera = python_renderer()
    cpp, py = [], []
    for _ in range(args.rounds):
        cpp += cpp_times(args.build, args.repeats)
        py += python_times(renderer, camera, args.repeats)
    cpp, py = statistics.median(cpp), statistics.median(py)
    n = args.rounds * args.repeats
    print(f"C++     {cpp * 1e3:8.2f} ms per 512^2 DRR (median of {n})")
    print(f"Python  {py * 1e3:8.2f} ms per 512^2 DRR (median of {n})")
    print(f"overhead {100 * (py / cpp - 1):+.1f}% ({gimm.get_num_threads()} threads)")

    def render_single_threaded(count):
        gimm.set_num_threads(1)  # per calling thread (OpenMP keeps it per thread)
        for _ in range(count):
            renderer.render(camera)

    start = time.perf_counter()
    render_single_threaded(4)
    serial = time.perf_counter() - start
    threads = [threading.Thread(target=render_single_threaded, args=(2,)) for _ in range(2)]
    start = time.perf_counter()
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    parallel = time.perf_counter() - start
    print(f"GIL: 4 single-threaded renders in {serial:.2f} s from one Python thread, "
          f"{parallel:.2f} s from two ({serial / parallel:.2f}x)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
