#!/usr/bin/python3
"""What a zero-copy volume input saves: preparing gimm.Renderer for the ImageCAS-size phantom
(512 x 512 x 256 int16 voxels, its left coronary tree) from the CT as make_phantom returns it
(int16, Fortran order: read in place) against the same CT in layouts gimm must copy first
(float64; C-ordered float32). Time and the process's peak resident memory of each preparation
(Linux: the peak is reset through /proc/self/clear_refs before each).

    PYTHONPATH=build/python benchmarks/python/volume_input.py [--repeats 3]
"""
import argparse
import statistics
import sys
import time

import numpy as np

import gimm


def rss_mb(field):
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(field + ":"):
                return int(line.split()[1]) / 1024
    raise RuntimeError(f"no {field} in /proc/self/status")


def reset_peak():
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")  # resets VmHWM to the current resident size


def prepare(volume, mask, geometry, repeats):
    times, peaks = [], []
    for _ in range(repeats):
        reset_peak()
        before = rss_mb("VmRSS")
        start = time.perf_counter()
        renderer = gimm.Renderer(volume, mask, geometry=geometry)
        times.append(time.perf_counter() - start)
        peaks.append(rss_mb("VmHWM") - before)
        del renderer
    return statistics.median(times), statistics.median(peaks)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3, help="preparations per layout")
    args = parser.parse_args(argv)
    if args.repeats < 1:
        parser.error(f"need --repeats >= 1, got {args.repeats}")
    p = gimm.make_phantom(seed=1, size="imagecas")
    lca = gimm.split_coronary_systems(p["label"], p["geometry"])["lca"]
    layouts = [("int16, Fortran order (read in place)", p["hu"]),
               ("float64, Fortran order (converted copy)", p["hu"].astype(np.float64, order="F")),
               ("float32, C order (reordered copy)", np.ascontiguousarray(p["hu"], np.float32))]
    print(f"CT {p['hu'].shape} int16 = {p['hu'].nbytes / 2**20:.0f} MB; "
          f"{gimm.get_num_threads()} threads; median of {args.repeats}")
    for name, volume in layouts:
        view = gimm.Volume(volume, p["geometry"]).is_view
        seconds, peak = prepare(volume, lca, p["geometry"], args.repeats)
        print(f"{name:42s} view={str(view):5s} {seconds:6.2f} s  peak +{peak:6.0f} MB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
