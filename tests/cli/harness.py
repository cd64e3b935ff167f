"""Shared plumbing of the end-to-end CLI tests: run a gimm binary, collect failures, report.

    h = Harness(BIN)
    proc = h.run("gimm-drr", "--volume", path, ok=False, contains="error:")
    h.check(cond, "what went wrong")
    h.finish("cli_test")       # prints the failures and exits 1, or says all passed
"""
import os
import subprocess
import sys


class Harness:
    def __init__(self, bin_dir):
        self.bin = bin_dir
        self.failures = []

    def run(self, name, *args, ok=True, contains=None, env=None):
        """Runs BIN/name with args; records a failure when the exit status is not what `ok`
        says, or when stdout + stderr lack `contains`. Returns the CompletedProcess."""
        proc = subprocess.run([os.path.join(self.bin, name), *map(str, args)],
                              capture_output=True, text=True, env={**os.environ, **(env or {})})
        out = proc.stdout + proc.stderr
        if ok and proc.returncode != 0:
            self.failures.append(f"{name} {args}: exit {proc.returncode}: {out[-800:]}")
        if not ok and proc.returncode == 0:
            self.failures.append(f"{name} {args}: expected failure, got exit 0")
        if contains and contains not in out:
            self.failures.append(f"{name} {args}: output lacks {contains!r}: {out[-500:]}")
        return proc

    def check(self, cond, what):
        if not cond:
            self.failures.append(what)

    def finish(self, name):
        if self.failures:
            print("\n".join("FAIL: " + f for f in self.failures))
            sys.exit(1)
        print(f"{name}: all checks passed")
