"""Shared plumbing of the end-to-end CLI tests: run a gimm binary, collect failures, report.

    h = Harness(BIN)
    proc = h.run("gimm-drr", "--volume", path, ok=False, contains="error:")
    h.check(cond, "what went wrong")
    h.run_on_full_disk("gimm-phantom", "--out", d, limit=100_000, watch=parent)
    h.finish("cli_test")       # prints the failures and exits 1, or says all passed
"""
import hashlib
import os
import resource
import signal
import subprocess
import sys


def tree_snapshot(root):
    """Every folder and file under `root` (itself included), files with a hash of their bytes:
    equal snapshots mean that nothing was added, removed or changed there."""
    out = {}
    for d, _, files in os.walk(root):
        out[os.path.relpath(d, root) + "/"] = "folder"
        for f in files:
            with open(os.path.join(d, f), "rb") as data:
                out[os.path.relpath(os.path.join(d, f), root)] = hashlib.sha1(data.read()).hexdigest()
    return out


def limit_file_size(limit):
    """A preexec_fn for subprocess: every file the child writes may grow to `limit` bytes only
    (RLIMIT_FSIZE); a write past that fails with EFBIG, as on a full disk (SIGXFSZ, which would
    kill the child instead, is ignored). No root or special filesystem needed."""
    def apply():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    return apply


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

    def run_on_full_disk(self, name, *args, limit, watch):
        """Runs BIN/name with args on a simulated full disk (limit_file_size(limit)). Records a
        failure unless the command fails (exit != 0) with one "error: ..." naming a path under
        `watch` and the reason (EFBIG's "File too large"), and leaves `watch` as it was: no output,
        temporary or folder of its own, and every file there before unchanged (all or nothing).
        Returns the CompletedProcess."""
        before = tree_snapshot(watch)
        proc = subprocess.run([os.path.join(self.bin, name), *map(str, args)], capture_output=True,
                              text=True, preexec_fn=limit_file_size(limit))
        what = f"{name} {' '.join(map(str, args))} (files limited to {limit} bytes)"
        error = [ln for ln in proc.stderr.splitlines() if ln.startswith("error: ")]
        self.check(proc.returncode != 0, f"{what}: exit 0 on a full disk")
        self.check(len(error) == 1 and watch in error[0] and "File too large" in error[0],
                   f"{what}: want one error naming a path under {watch} and the reason, got "
                   f"{proc.stderr[-600:]!r}")
        after = tree_snapshot(watch)
        changed = sorted(k for k in set(before) | set(after) if before.get(k) != after.get(k))
        self.check(not changed, f"{what}: left {watch} changed: {changed[:8]}")
        return proc

    def check(self, cond, what):
        if not cond:
            self.failures.append(what)

    def finish(self, name):
        if self.failures:
            print("\n".join("FAIL: " + f for f in self.failures))
            sys.exit(1)
        print(f"{name}: all checks passed")


def read_png_gray(path):
    """A grey 8- or 16-bit non-interlaced PNG as a numpy array (no imaging library needed)."""
    import struct
    import zlib

    import numpy as np
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", f"{path}: not a PNG"
    pos, idat, header = 8, b"", None
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    width, height, depth, colour, _, _, interlace = header
    assert colour == 0 and interlace == 0 and depth in (8, 16), f"{path}: {header}"
    bpp = depth // 8
    raw = zlib.decompress(idat)
    stride = width * bpp
    rows, prev = [], bytearray(stride)
    for r in range(height):
        kind, line = raw[r * (stride + 1)], bytearray(raw[r * (stride + 1) + 1:(r + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b, c = prev[i], prev[i - bpp] if i >= bpp else 0
            if kind == 1:
                line[i] = (line[i] + a) & 255
            elif kind == 2:
                line[i] = (line[i] + b) & 255
            elif kind == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif kind == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(bytes(line))
        prev = line
    out = np.frombuffer(b"".join(rows), dtype=">u2" if bpp == 2 else np.uint8)
    return out.reshape(height, width).astype(np.int64)
