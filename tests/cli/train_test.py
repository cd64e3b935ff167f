#!/usr/bin/env python3
"""tools/train/train.py end to end on a tiny dataset: two CPU ranks (DistributedDataParallel over
gloo, launched by hand as docs/training.md says) train a few steps and stop together; a run stopped half way and resumed
ends with the same weights as an uninterrupted one. Exits 77 (skipped) without PyTorch.

    train_test.py EXAMPLES_DIR TMP_DIR
"""
import json
import os
import shutil
import socket
import subprocess
import sys

try:
    import torch  # noqa: F401
except ImportError:
    print("train_test: PyTorch is not installed (scripts/install-deps.sh train); skipped")
    sys.exit(77)

EXAMPLES, TMP = sys.argv[1], sys.argv[2]
TRAIN = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tools", "train",
                     "train.py")
sys.path.insert(0, os.path.dirname(TRAIN))
from safetensors_io import load_file  # noqa: E402

shutil.rmtree(TMP, ignore_errors=True)
os.makedirs(TMP)
data = os.path.join(TMP, "data")
subprocess.run([os.path.join(EXAMPLES, "gimm-dataset"), "--phantom", "3", "--style", "drr",
                "--rows", "64", "--cols", "64", "--pixel", "4", "--out", data, "--quiet"],
               check=True, stdout=subprocess.DEVNULL)
COMMON = ["--dataset", data, "--size", "64", "--batch", "1", "--widths", "8", "16", "32",
          "--steps", "6", "--warmup", "2", "--val-pairs", "3", "--log-every", "1",
          "--threads", "1"]


def train(run, *extra, env=None):
    return subprocess.Popen([sys.executable, TRAIN, *COMMON, "--run", os.path.join(TMP, run),
                             *extra], env={**os.environ, **(env or {})},
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def finish(proc, what):
    out, _ = proc.communicate(timeout=600)
    if proc.returncode != 0:
        print(out)
        sys.exit(f"train_test: {what} exited {proc.returncode}")
    return out


# Two ranks, launched by hand.
with socket.socket() as s:
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
ranks = [train("ranks", env={"WORLD_SIZE": "2", "RANK": str(r), "LOCAL_RANK": str(r),
                             "MASTER_ADDR": "127.0.0.1", "MASTER_PORT": str(port)})
         for r in range(2)]
outs = [finish(p, f"rank {r}") for r, p in enumerate(ranks)]
assert "stopped at step 6" in outs[0], outs[0]
assert "2 ranks" in outs[0] or "x 2 ranks" in outs[0], outs[0]
assert os.path.exists(os.path.join(TMP, "ranks", "checkpoint.pt"))

# Stopped at step 3 and resumed = straight through to step 6.
finish(train("straight"), "straight run")
finish(train("resumed", "--stop-at", "3"), "first half")
# A sitting killed after its checkpoint logged steps the checkpoint does not hold.
log_path = os.path.join(TMP, "resumed", "log.jsonl")
with open(log_path, "a") as f:
    f.write(json.dumps({"step": 4, "loss": 9.0}) + "\n" + json.dumps({"val": {"step": 5}}) + "\n")
out = finish(subprocess.Popen([sys.executable, TRAIN, "--dataset", data, "--run",
                               os.path.join(TMP, "resumed"), "--resume", "--threads", "1"],
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True),
             "resumed half")
assert "stopped at step 6" in out, out
with open(log_path) as f:
    steps = [json.loads(ln).get("step") for ln in f if "val" not in json.loads(ln)]
assert steps == [1, 2, 3, 4, 5, 6], f"log steps after resume: {steps}"
a, _ = load_file(os.path.join(TMP, "straight", "last.safetensors"))
b, _ = load_file(os.path.join(TMP, "resumed", "last.safetensors"))
assert a.keys() == b.keys()
worst = max(float(abs(a[k] - b[k]).max()) for k in a)
assert worst == 0.0, f"resumed weights differ from the straight run by {worst}"

# --init: a fine-tune starts from another run's model, with its own schedule.
init_ckpt = os.path.join(TMP, "straight", "checkpoint.pt")
out = finish(train("finetune", "--init", init_ckpt, "--steps", "2", "--stop-at", "1", "--lr",
                   "0"), "fine-tune")
assert "stopped at step 1" in out, out
c, _ = load_file(os.path.join(TMP, "finetune", "last.safetensors"))
# (BatchNorm's running statistics move in any training step; the learned parameters may not.)
worst = max(float(abs(a[k] - c[k]).max()) for k in a if "running_" not in k)
assert worst == 0.0, f"a fine-tune at lr 0 moved the --init weights by {worst}"
# A model option that differs from the checkpoint's is named, and nothing is trained.
bad = train("bad_init", "--init", init_ckpt, "--no-film")
out, _ = bad.communicate(timeout=600)
assert bad.returncode != 0 and "no_film=False" in out and init_ckpt in out, out
missing = train("bad_init", "--init", os.path.join(TMP, "nothing.pt"))
out, _ = missing.communicate(timeout=600)
assert missing.returncode != 0 and "nothing.pt does not exist" in out, out

# --device cuda without a GPU: refused by name before any work (auto falls back to the CPU).
if not torch.cuda.is_available():
    gpu = train("no_gpu", "--device", "cuda")
    out, _ = gpu.communicate(timeout=600)
    assert gpu.returncode != 0 and "--device cuda" in out and "no CUDA GPU" in out, out
    assert not os.path.exists(os.path.join(TMP, "no_gpu", "checkpoint.pt"))

# The config check refuses a key it does not know, as the C++ reader does (nn/matcher_file.hpp).
from gimm_model import DEFAULT_CONFIG, validate_config  # noqa: E402
try:
    validate_config({**DEFAULT_CONFIG, "treshold": 0.3})
    raise AssertionError("validate_config accepted the unknown key 'treshold'")
except ValueError as e:
    assert "unknown key 'treshold'" in str(e), e
validate_config({**DEFAULT_CONFIG, "input_size": 256, "gate": {"mode": "hard"}})

# On-the-fly pairs (rendered_pairs.py through the gimm module): trains, validates on the dataset's
# val split, and two runs with one seed give the same weights.
try:
    import gimm  # noqa: F401
    rendered = True
except ImportError:
    rendered = False
    print("train_test: the gimm module is not importable (PYTHONPATH): --rendered not tested")
if rendered:
    outs = [finish(train(f"rendered{n}", "--rendered", "2", "--steps", "3"), "--rendered run")
            for n in range(2)]
    assert "2 phantoms rendered on the fly" in outs[0] and "stopped at step 3" in outs[0], outs[0]
    r0, _ = load_file(os.path.join(TMP, "rendered0", "last.safetensors"))
    r1, _ = load_file(os.path.join(TMP, "rendered1", "last.safetensors"))
    assert max(float(abs(r0[k] - r1[k]).max()) for k in r0) == 0.0, "--rendered not deterministic"
    assert max(float(abs(r0[k] - a[k]).max()) for k in r0) > 0, "--rendered trained on the dataset"
    # The vessel-enhanced input: trained through gimm.network_image, recorded in the weights, and
    # read back by the C++ engine.
    out = finish(train("vesselness", "--input", "vesselness", "--steps", "2"), "--input run")
    assert '"input": "vesselness"' in out and "stopped at step 2" in out, out
    weights = os.path.join(TMP, "vesselness", "last.safetensors")
    assert gimm.Matcher(weights).input == "vesselness"
print("train_test: 2 ranks stop together; resume is exact; --init starts from its weights"
      + ("; --rendered trains deterministically" if rendered else ""))
