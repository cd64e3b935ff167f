#!/usr/bin/env python3
"""Checks the Containerfile without a container engine (none runs here): its syntax (known
instructions, line continuations, FROM debian:12 first, stages named before COPY --from uses
them), that every COPY source exists, that the build stage's CMake configure succeeds with its
flags, and that the runtime packages (with their dependencies) cover every library the built
CLIs load.

    container_test.py SOURCE_DIR BUILD_DIR WORK_DIR
"""
import os
import re
import shlex
import shutil
import subprocess
import sys

SOURCE, BUILD, WORK = sys.argv[1:4]
INSTRUCTIONS = {"FROM", "RUN", "COPY", "ADD", "WORKDIR", "ENV", "ARG", "LABEL", "CMD",
                "ENTRYPOINT", "USER", "EXPOSE", "VOLUME", "SHELL", "HEALTHCHECK", "STOPSIGNAL"}
failures = []


def check(cond, what):
    if not cond:
        failures.append(what)


def instructions(path):
    """(line number, INSTRUCTION, arguments) with continuations joined and comments dropped."""
    out, pending, start = [], "", 0
    for n, raw in enumerate(open(path), 1):
        line = raw.rstrip("\n")
        if not pending and (not line.strip() or line.lstrip().startswith("#")):
            continue
        if not pending:
            start = n
        if line.endswith("\\"):
            pending += line[:-1] + " "
            continue
        text = (pending + line).strip()
        pending = ""
        word, _, args = text.partition(" ")
        out.append((start, word, args.strip()))
    check(not pending, f"{path}: ends inside a line continuation")
    return out


path = os.path.join(SOURCE, "Containerfile")
steps = instructions(path)
stages, runs, runtime_packages, configure = [], {}, [], None
for n, word, args in steps:
    check(word in INSTRUCTIONS, f"Containerfile:{n}: unknown instruction {word!r}")
    check(word == word.upper(), f"Containerfile:{n}: instruction {word!r} not upper case")
    if word == "FROM":
        m = re.fullmatch(r"(\S+)(?:\s+AS\s+(\S+))?", args, re.IGNORECASE)
        check(m and m.group(1) in ("debian:12", "debian:12-slim"),
              f"Containerfile:{n}: FROM {args!r}: the image is built on Debian 12")
        stages.append(m.group(2) if m else None)
        runs[len(stages) - 1] = []
    else:
        check(stages, f"Containerfile:{n}: {word} before the first FROM")
    if word == "COPY":
        parts = shlex.split(args)
        source_stage = [p for p in parts if p.startswith("--from=")]
        sources = [p for p in parts if not p.startswith("--")][:-1]
        if source_stage:
            name = source_stage[0].split("=", 1)[1]
            check(name in stages[:-1], f"Containerfile:{n}: COPY --from={name}: no earlier stage")
        else:
            for s in sources:
                check(os.path.exists(os.path.join(SOURCE, s)),
                      f"Containerfile:{n}: COPY source {s!r} is not in the source tree")
    if word == "RUN" and stages:
        runs[len(stages) - 1].append(args)
        for command in re.split(r"&&", args):
            words = shlex.split(command)
            if words and words[0].startswith("scripts/"):
                script = os.path.join(SOURCE, words[0])
                check(os.access(script, os.X_OK), f"Containerfile:{n}: {words[0]} is not an "
                      "executable script of the source tree")
            if words[:2] == ["cmake", "-S"]:
                configure = words
            if words[:1] == ["apt-get"] and "install" in words:
                runtime_packages += [w for w in words[words.index("install") + 1:]
                                     if not w.startswith("-")]
check(len(stages) == 2, f"expected a build stage and a runtime stage, got {len(stages)} FROM")
check(configure is not None, "the build stage has no `cmake -S . -B ...` step")
check(runtime_packages, "the runtime stage installs no packages")

# The build stage's configure, as written (its flags must exist and agree), in a scratch folder.
if configure:
    shutil.rmtree(WORK, ignore_errors=True)
    os.makedirs(WORK)
    args = [a if a != "." else SOURCE for a in configure]
    args[args.index("-B") + 1] = os.path.join(WORK, "build")
    proc = subprocess.run(args, cwd=SOURCE, capture_output=True, text=True)
    check(proc.returncode == 0, f"the build stage's configure failed: {proc.stderr[-800:]}")
    shutil.rmtree(WORK, ignore_errors=True)

# The runtime packages and their dependencies hold every library the CLIs load (apt's lists and
# dpkg are there on Debian; elsewhere this part is skipped, and says so).
if shutil.which("apt-cache") and shutil.which("dpkg") and runtime_packages:
    closure = set(runtime_packages)
    deps = subprocess.run(["apt-cache", "depends", "--recurse", "--no-recommends",
                           "--no-suggests", "--no-conflicts", "--no-breaks", "--no-replaces",
                           "--no-enhances", *runtime_packages], capture_output=True, text=True)
    for line in deps.stdout.splitlines():
        m = re.match(r"\s*(?:\|?(?:Pre)?Depends:\s*)?<?([a-z0-9][a-z0-9.+-]*)(?::\w+)?>?\s*$",
                     line)
        if m:
            closure.add(m.group(1))
    examples = os.path.join(BUILD, "examples")
    clis = [os.path.join(examples, f) for f in sorted(os.listdir(examples))
            if f.startswith("gimm-") and os.access(os.path.join(examples, f), os.X_OK)]
    check(clis, f"no gimm-* programs in {examples}")
    libs = set()
    for cli in clis:
        out = subprocess.run(["ldd", cli], capture_output=True, text=True).stdout
        libs |= {m.group(1) for m in re.finditer(r"=> (/\S+)", out)}
    for lib in sorted(libs):
        owner = subprocess.run(["dpkg", "-S", os.path.realpath(lib)], capture_output=True,
                               text=True)
        if owner.returncode != 0:
            owner = subprocess.run(["dpkg", "-S", lib], capture_output=True, text=True)
        package = owner.stdout.split(":")[0].strip() if owner.returncode == 0 else None
        check(package is None or package in closure,
              f"{lib} (package {package}) is loaded by the CLIs but not installed in the image")
else:
    print("container_test: no apt-cache/dpkg: the runtime packages were not checked")

print("\n".join("FAIL: " + f for f in failures) or
      f"container_test: {len(steps)} instructions, {len(stages)} stages, configure ok, "
      f"runtime packages {' '.join(runtime_packages)} cover the CLIs")
sys.exit(1 if failures else 0)
