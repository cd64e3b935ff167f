"""The build-time tools of benchmarks/build/: the compiler launcher that logs each compile's
time, and header_cost.py, which sums the compile times of a header's includers; on a hand-made
build folder whose answers are known, and on bad input.

Run by ctest (build_tools); alone: build_tools_test.py TMP_DIR
"""
import os
import shutil
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
TOOLS = os.path.join(HERE, "..", "..", "benchmarks", "build")
LAUNCHER = os.path.join(TOOLS, "log_compile.sh")
COST = os.path.join(TOOLS, "header_cost.py")

sys.path.insert(0, HERE)
from harness import Harness  # noqa: E402

TMP = os.path.abspath(sys.argv[1])
shutil.rmtree(TMP, ignore_errors=True)
os.makedirs(TMP)
h = Harness(TOOLS)
check = h.check


def run(args, env=None):
    return subprocess.run(args, capture_output=True, text=True, env=env)


# --- log_compile.sh: runs the command, keeps its exit status, logs "seconds<TAB>output". -----
log = os.path.join(TMP, "times.tsv")
env = dict(os.environ, GIMM_COMPILE_LOG=log)
ok = run([LAUNCHER, "sh", "-c", "exit 0", "-o", "a/x.cpp.o"], env)
bad = run([LAUNCHER, "sh", "-c", "exit 3", "-o", "b/y.cpp.o"], env)
check(ok.returncode == 0, f"launcher: a passing command gives 0, got {ok.returncode}")
check(bad.returncode == 3, f"launcher: keeps the command's status 3, got {bad.returncode}")
lines = open(log).read().splitlines()
check(len(lines) == 2, f"launcher: one line per compile, got {lines}")
check([line.split("\t")[1] for line in lines] == ["a/x.cpp.o", "b/y.cpp.o"],
      f"launcher: logs the -o file, got {lines}")
check(all(float(line.split("\t")[0]) >= 0 for line in lines), f"launcher: seconds, got {lines}")
unset = run([LAUNCHER, "sh", "-c", "exit 0", "-o", "z.o"],
            {k: v for k, v in os.environ.items() if k != "GIMM_COMPILE_LOG"})
check(unset.returncode == 2 and "GIMM_COMPILE_LOG" in unset.stderr,
      f"launcher: no log path is an error naming it, got {unset.returncode} {unset.stderr!r}")
relative = run([LAUNCHER, "sh", "-c", "exit 0", "-o", "z.o"],
               dict(os.environ, GIMM_COMPILE_LOG="times.tsv"))
check(relative.returncode == 2 and "'times.tsv'" in relative.stderr,
      f"launcher: a relative log path is refused, got {relative.returncode} {relative.stderr!r}")

# --- header_cost.py: three files; two include camera.hpp (10 + 20 s), one carm.hpp (20 s). ----
build = os.path.join(TMP, "build")
deps = {
    "tests/CMakeFiles/t.dir/a.cpp.o": ["/src/include/gimm/geometry/camera.hpp"],
    "tests/CMakeFiles/t.dir/b.cpp.o": ["/src/include/gimm/geometry/camera.hpp",
                                       "/src/include/gimm/geometry/carm.hpp"],
    "CMakeFiles/u.dir/c.cpp.o": ["/src/include/gimm/core/error.hpp"],
}
for obj, headers in deps.items():
    os.makedirs(os.path.dirname(os.path.join(build, obj)), exist_ok=True)
    with open(os.path.join(build, obj + ".d"), "w") as f:
        f.write(obj + ": \\\n " + " \\\n ".join(headers) + "\n")
times = os.path.join(TMP, "cost.tsv")
with open(times, "w") as f:  # as the launcher writes them: relative to each target's folder
    f.write("10.0\tCMakeFiles/t.dir/a.cpp.o\n20.0\tCMakeFiles/t.dir/b.cpp.o\n"
            "5.0\tCMakeFiles/u.dir/c.cpp.o\n")
out = run([sys.executable, COST, build, times, "gimm/geometry/camera.hpp",
           "gimm/geometry/carm.hpp", "gimm/geometry/epipolar.hpp"])
check(out.returncode == 0, f"header_cost: runs, got {out.returncode} {out.stderr!r}")
got = out.stdout.splitlines()
check(len(got) == 3, f"header_cost: one line per header, got {got}")
check(got and got[0].startswith("gimm/geometry/camera.hpp: 2 files, 30 s of compiling, >= 15 s"),
      f"header_cost: camera.hpp first, 2 files, 30 s; got {got[:1]}")
check(len(got) > 1 and got[1].startswith("gimm/geometry/carm.hpp: 1 files, 20 s"),
      f"header_cost: carm.hpp 1 file, 20 s; got {got[1:2]}")
check(len(got) > 2 and got[2].startswith("gimm/geometry/epipolar.hpp: 0 files, 0 s"),
      f"header_cost: a header nothing includes costs nothing; got {got[2:3]}")
os.makedirs(TMP + "/empty", exist_ok=True)
for args, named, needle in [([build + "-missing", times], build + "-missing", "does not exist"),
                            ([build, times + "-missing"], times + "-missing", "does not exist"),
                            ([TMP + "/empty", times], TMP + "/empty", "no dependency files")]:
    r = run([sys.executable, COST] + args)
    check(r.returncode != 0 and needle in r.stderr and f"'{named}'" in r.stderr,
          f"header_cost {args}: fails naming '{named}' ({needle}), got {r.returncode} {r.stderr!r}")
with open(os.path.join(TMP, "broken.tsv"), "w") as f:
    f.write("10.0 no tab here\n")
r = run([sys.executable, COST, build, os.path.join(TMP, "broken.tsv")])
check(r.returncode != 0 and "broken.tsv:1" in r.stderr,
      f"header_cost: a malformed log line is named, got {r.returncode} {r.stderr!r}")

h.finish("build_tools")
