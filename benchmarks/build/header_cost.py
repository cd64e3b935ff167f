#!/usr/bin/env python3
"""What touching a header costs: the translation units that include it (from the compilers'
dependency files, *.o.d) and the sum of their compile times (from log_compile.sh's log). On N
cores a rebuild takes at least that sum / N, plus the links.

    benchmarks/build/header_cost.py BUILD_DIR TIMES_TSV [HEADER...]

HEADER is a path under include/ (gimm/geometry/camera.hpp); without any, every header of
include/gimm/geometry/. Prints one line per header, widest first."""
import pathlib
import sys


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    build, log = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])
    if not build.is_dir():
        sys.exit(f"header_cost: build folder '{build}' does not exist")
    if not log.is_file():
        sys.exit(f"header_cost: compile log '{log}' does not exist (see log_compile.sh)")
    seconds = {}
    for n, line in enumerate(log.read_text().splitlines(), 1):
        try:
            t, obj = line.split("\t")
            seconds[obj] = float(t)  # the last compile of a file counts
        except ValueError:
            sys.exit(f"header_cost: {log}:{n} is not 'seconds<TAB>object': {line!r}")
    units = {}  # object file -> its dependency list
    for dep in build.rglob("*.o.d"):
        obj = str(dep.relative_to(build))[: -len(".d")]
        times = [t for o, t in seconds.items() if obj.endswith(o) or o.endswith(obj)]
        units[obj] = (times[-1] if times else None, dep.read_text())
    if not units:
        sys.exit(f"header_cost: no dependency files (*.o.d) under '{build}': build it first")
    root = pathlib.Path(__file__).resolve().parents[2]
    headers = sys.argv[3:] or sorted(
        str(p.relative_to(root / "include")) for p in (root / "include/gimm/geometry").glob("*.hpp"))
    rows = []
    for header in headers:
        hits = [(t, obj) for obj, (t, deps) in units.items() if "include/" + header in deps]
        known = [t for t, _ in hits if t is not None]
        rows.append((sum(known), header, len(hits), len(hits) - len(known), sorted(hits, reverse=True, key=lambda h: h[0] or 0)))
    for total, header, count, unknown, hits in sorted(rows, reverse=True):
        top = ", ".join(f"{pathlib.Path(o).name} {t:.0f} s" for t, o in hits[:4] if t is not None)
        note = f" ({unknown} without a logged time)" if unknown else ""
        print(f"{header}: {count} files{note}, {total:.0f} s of compiling, "
              f">= {total / 2:.0f} s on 2 cores; largest: {top}")


if __name__ == "__main__":
    main()
