"""Minimal safetensors reader/writer (numpy only), matching gimm/io/safetensors.hpp.

save_file writes float32 tensors in sorted name order, the JSON header padded with spaces to a
multiple of 8 bytes, atomically; load_file applies the C++ reader's checks and raises ValueError
naming the file and the tensor. torch tensors are accepted but torch is never imported here.
"""
import json
import os
import struct

import numpy as np

_MAX_HEADER = 100_000_000  # the reference implementation's limit
_DTYPES = {"BOOL": np.bool_, "U8": np.uint8, "I8": np.int8, "I16": np.int16, "U16": np.uint16,
           "F16": np.float16, "BF16": np.uint16, "I32": np.int32, "U32": np.uint32,
           "F32": np.float32, "F64": np.float64, "I64": np.int64, "U64": np.uint64}


def _as_numpy(value):
    if hasattr(value, "detach"):  # torch.Tensor, without importing torch
        value = value.detach().cpu().float().numpy()
    return np.array(value, dtype="<f4", order="C")  # keeps 0-d (ascontiguousarray would not)


def save_file(path, tensors, metadata=None):
    arrays = {name: _as_numpy(t) for name, t in sorted(tensors.items())}
    header, offset = {}, 0
    if metadata:
        header["__metadata__"] = {str(k): str(v) for k, v in metadata.items()}
    for name, a in arrays.items():
        if not name or name == "__metadata__":
            raise ValueError(f"{path}: bad tensor name {name!r}")
        header[name] = {"dtype": "F32", "shape": list(a.shape),
                        "data_offsets": [offset, offset + a.nbytes]}
        offset += a.nbytes
    text = json.dumps(header, separators=(",", ":"), ensure_ascii=False).encode()
    text += b" " * (-len(text) % 8)
    tmp = f"{path}.tmp.{os.getpid()}"  # atomic, like gimm's write_file_atomic
    with open(tmp, "wb") as f:
        f.write(struct.pack("<Q", len(text)) + text)
        for a in arrays.values():
            f.write(a.tobytes())
    os.replace(tmp, path)


def _no_duplicates(pairs):
    keys = [k for k, _ in pairs]
    dup = sorted({k for k in keys if keys.count(k) > 1})
    if dup:
        raise ValueError(f"duplicate key {dup[0]!r} in the header")
    return dict(pairs)


def _is_uint(v):
    return isinstance(v, int) and not isinstance(v, bool) and v >= 0


def load_file(path):
    """Returns ({name: np.ndarray}, metadata). BF16 becomes float32; other dtypes stay as-is."""
    with open(path, "rb") as f:
        raw = f.read()

    def fail(msg):
        raise ValueError(f"safetensors {path!r}: {msg}")

    if len(raw) < 8:
        fail(f"file is {len(raw)} bytes, shorter than the 8-byte header length")
    n = struct.unpack("<Q", raw[:8])[0]
    if n == 0 or n > _MAX_HEADER or n > len(raw) - 8:
        fail(f"bad header length {n} for a {len(raw)}-byte file")
    try:
        header = json.loads(raw[8:8 + n].decode("utf-8"), object_pairs_hook=_no_duplicates)
    except ValueError as e:
        fail(f"header is not valid JSON: {e}")
    if not isinstance(header, dict):
        fail("header is not a JSON object")
    data = raw[8 + n:]
    metadata = header.pop("__metadata__", {})
    if not isinstance(metadata, dict) or not all(isinstance(v, str) for v in metadata.values()):
        fail("__metadata__ is not an object of strings")
    tensors, spans = {}, []
    for name, e in header.items():
        if not isinstance(e, dict) or not {"dtype", "shape", "data_offsets"} <= e.keys():
            fail(f"tensor {name!r}: entry must be an object with dtype, shape, data_offsets")
        dtype, shape, offsets = e["dtype"], e["shape"], e["data_offsets"]
        if dtype not in _DTYPES:
            fail(f"tensor {name!r}: unknown dtype {dtype!r}")
        if not isinstance(shape, list) or not all(_is_uint(d) for d in shape):
            fail(f"tensor {name!r}: bad shape {shape!r}")
        if not (isinstance(offsets, list) and len(offsets) == 2 and all(map(_is_uint, offsets))):
            fail(f"tensor {name!r}: data_offsets must be two non-negative integers: {offsets!r}")
        begin, end = offsets
        if begin > end or end > len(data):
            fail(f"tensor {name!r}: data_offsets {offsets} outside the {len(data)}-byte data")
        dt = np.dtype(_DTYPES[dtype]).newbyteorder("<")
        if end - begin != int(np.prod(shape, dtype=object)) * dt.itemsize:
            fail(f"tensor {name!r}: {end - begin} bytes do not hold shape {shape} of {dtype}")
        a = np.frombuffer(data, dtype=dt, count=(end - begin) // dt.itemsize, offset=begin)
        if dtype == "BF16":
            a = (a.astype(np.uint32) << 16).view(np.float32)
        tensors[name] = a.reshape(shape).copy()
        spans.append((begin, end, name))
    covered, prev = 0, None
    for begin, end, name in sorted(spans):  # the spec requires an exact tiling of the data
        if begin < covered:
            fail(f"tensors {prev!r} and {name!r} overlap")
        if begin > covered:
            fail(f"data bytes [{covered}, {begin}) are not covered by any tensor")
        covered, prev = end, name
    if covered != len(data):
        fail(f"data bytes [{covered}, {len(data)}) are not covered by any tensor")
    return tensors, metadata
