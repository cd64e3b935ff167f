"""The command-line contract every gimm CLI keeps (gimm::cli::run in examples/cli_common.hpp):

- --help prints the help and --version prints "gimm-<name> <version>", on stdout, exit 0;
- a usage error (unknown flag, missing value, failed check) prints one line "error: ..." naming
  the flag on stderr, nothing on stdout, and exits 2;
- every FLOAT option refuses non-finite values (nan, inf, 1e999) and every UINT option negative
  and overflowing ones, naming the flag and the value, instead of running with NaN or 2^64-1.

The options are read from each CLI's --help, so an option added later is checked too; the ones
named in the hardening issue are also checked by name.

Run by cli_test.py (check_flags); alone: flag_contract.py BIN_DIR
"""
import json
import os
import re
import subprocess
import sys
import tempfile

CLIS = ["baseline", "carm", "centerlines", "dataset", "drr", "eval", "match", "phantom"]
# "  -h,--help   ...", "  --sid FLOAT=1000  ...", "  --isocenter FLOAT x 3  ...",
# "  --pad-mm FLOAT:FLOAT in [0 - 1000]=20  ...": the flag and the first word of its type.
OPTION_LINE = re.compile(r"^\s+(?:-\w,)?(--[\w-]+) ([A-Z]+)\b(.*)$")
NON_FINITE = ["nan", "NaN", "inf", "-inf", "1e999"]
BAD_UNSIGNED = ["-1", "-18446744073709551615", "18446744073709551616"]


def project_version():
    top = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "CMakeLists.txt")
    match = re.search(r"project\(gimm VERSION ([0-9.]+)", open(top).read())
    assert match, f"no project(gimm VERSION ...) in {top}"
    return match.group(1)


def run(bin_dir, name, *args):
    return subprocess.run([os.path.join(bin_dir, "gimm-" + name), *map(str, args)],
                          capture_output=True, text=True)


def options(help_text):
    """{flag: (TYPE, values per use)} of the options listed in a CLI11 help text."""
    out = {}
    for line in help_text.splitlines():
        m = OPTION_LINE.match(line)
        if m:
            count = re.search(r" x (\d+)\b", m.group(3).split("  ")[0])
            out[m.group(1)] = (m.group(2), int(count.group(1)) if count else 1)
    return out


def check_usage_error(check, bin_dir, name, args, *must_name):
    """Exit 2, nothing on stdout, one stderr line 'error: ...' naming every `must_name`."""
    proc = run(bin_dir, name, *args)
    what = f"gimm-{name} {' '.join(map(str, args))}"
    lines = proc.stderr.splitlines()
    check(proc.returncode == 2, f"{what}: exit {proc.returncode}, expected 2: {proc.stderr[-300:]}")
    check(proc.stdout == "", f"{what}: usage error printed on stdout: {proc.stdout[:200]!r}")
    check(len(lines) == 1 and lines[0].startswith("error: "),
          f"{what}: expected one line 'error: ...', got {proc.stderr[:400]!r}")
    for word in must_name:
        check(word in proc.stderr, f"{what}: the error does not name {word!r}: {proc.stderr!r}")
    return proc


def check_flags(check, bin_dir, tmp_dir):
    """Records a failure with check(False, what) for every broken rule; tmp_dir must exist."""
    version = project_version()
    floats, unsigned = set(), set()
    for name in CLIS:
        # --help and --version: stdout, exit 0.
        proc = run(bin_dir, name, "--help")
        check(proc.returncode == 0 and f"Usage: gimm-{name}" in proc.stdout and
              "--version" in proc.stdout and proc.stderr == "",
              f"gimm-{name} --help: exit {proc.returncode}, stdout {proc.stdout[:200]!r}, "
              f"stderr {proc.stderr[:200]!r}")
        opts = options(proc.stdout)
        proc = run(bin_dir, name, "--version")
        check(proc.returncode == 0 and proc.stdout == f"gimm-{name} {version}\n",
              f"gimm-{name} --version: exit {proc.returncode}, stdout {proc.stdout!r}, expected "
              f"'gimm-{name} {version}'; stderr {proc.stderr[:300]!r}")

        # Usage errors: one line naming the flag, exit 2, no help text.
        check_usage_error(check, bin_dir, name, ["--no-such-flag", "1"], "--no-such-flag")
        # A mistyped required flag: the unknown spelling is named, not the missing option.
        check_usage_error(check, bin_dir, name, ["--volum", "x"], "--volum")

        # Every FLOAT option refuses non-finite values; every UINT option negative and
        # overflowing ones. The other values of a multi-value option are fine (0).
        for flag, (kind, count) in opts.items():
            bad = NON_FINITE if kind == "FLOAT" else BAD_UNSIGNED if kind == "UINT" else []
            (floats if kind == "FLOAT" else unsigned if kind == "UINT" else set()).add(
                f"gimm-{name} {flag}")
            for value in bad:
                check_usage_error(check, bin_dir, name, [flag, value] + ["0"] * (count - 1),
                                  flag, value)

    # The help parsing found the options of the hardening issue (else the loop above proves
    # nothing), and those fail by name as well, given every required option, so that the value
    # is the only thing wrong: before, the run went on with NaN or 2^64-1 (phantom wrote patient
    # 18446744073709551615, drr rendered with the default step).
    nothing = os.path.join(tmp_dir, "flag_contract_missing")  # never created
    this_file = os.path.abspath(__file__)
    required = {
        "drr": ["--volume", this_file, "--primary", 0, "--secondary", 0, "--out",
                os.path.join(tmp_dir, "drr_never")],
        "centerlines": ["--label", this_file, "--out", os.path.join(tmp_dir, "never.json")],
        "phantom": ["--out", os.path.join(tmp_dir, "phantom_never")],
        "dataset": ["--input", nothing, "--out", os.path.join(tmp_dir, "dataset_never")],
        "baseline": ["--dataset", nothing, "--method", "oracle", "--out",
                     os.path.join(tmp_dir, "baseline_never")],
        "match": ["--dataset", tmp_dir, "--method", "oracle", "--out",
                  os.path.join(tmp_dir, "match_never")],
        "eval": ["--dataset", nothing, "--predictions", nothing],
        "carm": ["--secondary", 0],
    }
    named = {("drr", "--step", "nan"), ("drr", "--pad-mm", "nan"), ("drr", "--sid", "inf"),
             ("centerlines", "--min-spur", "nan"), ("centerlines", "--tolerance", "nan"),
             ("phantom", "--noise", "nan"), ("dataset", "--warn-dropped", "nan"),
             ("baseline", "--sigma", "nan"), ("match", "--tau", "nan"),
             ("match", "--delta", "inf"), ("carm", "--primary", "-inf"),
             ("eval", "--worst", "-1"), ("phantom", "--seed", "-1"), ("dataset", "--seed", "-1"),
             ("baseline", "--seed", "-1"), ("match", "--seed", "-1"),
             ("match", "--max-points", "-1"), ("baseline", "--max-points", "-1")}
    for name, flag, value in sorted(named):
        kinds = floats if value != "-1" else unsigned
        check(f"gimm-{name} {flag}" in kinds,
              f"gimm-{name} --help: {flag} not found as a {'FLOAT' if value != '-1' else 'UINT'} "
              "option")
        args = required[name] + [flag, value] + (["--seed", 1] if name == "phantom" and
                                                  flag != "--seed" else [])
        check_usage_error(check, bin_dir, name, args, flag, value)
    check(len(floats) >= 30 and len(unsigned) >= 7,
          f"found only {len(floats)} FLOAT and {len(unsigned)} UINT options in the help texts")
    left = [f for f in os.listdir(tmp_dir) if "never" in f]
    check(not left, f"runs refused at parse time left files behind: {left}")

    # Missing values, missing required options and failed checks: same contract.
    check_usage_error(check, bin_dir, "carm", ["--primary"], "--primary")
    check_usage_error(check, bin_dir, "carm", ["--isocenter", "1", "2"], "--isocenter")
    check_usage_error(check, bin_dir, "carm", ["--model", "fisheye"], "--model", "fisheye")
    check_usage_error(check, bin_dir, "carm", ["--rows", "many"], "--rows", "many")
    check_usage_error(check, bin_dir, "drr", [], "--")  # --volume/--primary/... is required
    check_usage_error(check, bin_dir, "phantom", ["--out", "x"], "--seed")
    check_usage_error(check, bin_dir, "dataset", ["merge"], "--out")
    check_usage_error(check, bin_dir, "eval", ["--top-k", "-1"], "--top-k", "-1")
    proc = run(bin_dir, "dataset", "merge", "--help")
    check(proc.returncode == 0 and "merge" in proc.stdout and "--out" in proc.stdout,
          f"gimm-dataset merge --help: exit {proc.returncode}: {proc.stdout[:200]!r}")

    # Mistakes found after parsing (flags that conflict or go together, values the library
    # refuses, an output naming an input): the same contract. Before, 15 of 24 such mistakes
    # exited 1 and several named no flag ("CArm: detector size" for --rows -5).
    later_dir = os.path.join(tmp_dir, "later")
    os.makedirs(later_dir)
    never = os.path.join(later_dir, "never")
    drr_dataset = os.path.join(tmp_dir, "drr_dataset")  # a /1 dataset made without formation
    os.makedirs(os.path.join(drr_dataset, "patients"))
    with open(os.path.join(drr_dataset, "manifest.json"), "w") as f:
        json.dump({"format": "gimm-dataset/1", "parameters": {}, "patients": []}, f)
    angles = ["--primary", 0, "--secondary", 0]
    later = [
        ("carm", angles + ["--rows", "-5"], ["--rows", "-5"]),
        ("carm", angles + ["--sod", "1200"], ["--sod", "1200"]),
        ("carm", ["--secondary", 0], ["--primary"]),
        ("carm", ["--reference", this_file], ["--reference", "--dicom"]),
        ("dataset", ["--phantom", 0, "--out", never], ["--phantom", "got 0"]),
        ("dataset", ["--phantom", 1, "--shard", "abc", "--out", never], ["--shard", "abc"]),
        ("dataset", ["--phantom", 1, "--primary", 3, "--out", never], ["--primary"]),
        ("dataset", ["--phantom", 1, "--input", nothing, "--out", never], ["--input", "--phantom"]),
        ("dataset", ["--phantom", 1, "--rows", 0, "--out", never], ["--rows", "got 0"]),
        ("dataset", ["--input", later_dir, "--tree", "rich", "--out", never], ["--tree"]),
        ("dataset", ["--phantom", 1, "--style", "xray", "--out", never], ["--style", "xray"]),
        ("match", ["--dataset", drr_dataset, "--images", "formed", "--out", never],
         ["--images", "no formed views"]),
        ("drr", ["--volume", this_file, "--label", this_file, "--out", never] + angles,
         ["--label", "--system"]),
        ("drr", ["--volume", this_file, "--out", os.path.join(never, "x")] + angles, ["--out"]),
        ("drr", ["--volume", this_file, "--out", this_file[:-3]] + angles + ["--pixel", 0],
         ["--pixel", "got 0"]),
        ("eval", ["--tree", this_file], ["--tree", "--centerlines"]),
        ("eval", ["--compare", later_dir, "--dataset", later_dir], ["--compare", "--dataset"]),
        ("eval", ["--truth", this_file, "--matches", this_file, "--radius", -1], ["--radius"]),
        ("eval", ["--compare", later_dir, "--out", later_dir], ["--out", "--compare"]),
        ("baseline", ["--dataset", later_dir, "--method", "oracle", "--out", later_dir],
         ["--out", "--dataset"]),
        ("match", ["--dataset", later_dir, "--method", "geometric", "--weights", this_file,
                   "--out", never], ["--weights"]),
        ("match", ["--class-a", 12], ["--class-a", "12"]),
        ("match", ["--dicom-a", this_file], ["--dicom-b"]),
        ("match", ["--dataset", later_dir, "--tolerance", 0, "--method", "geometric",
                   "--out", never], ["--tolerance", "got 0"]),
        ("centerlines", ["--label", this_file, "--out", this_file], ["--out", "--label"]),
        # Values past their checks that made a camera beyond 1e9 (exit 1, no flag named).
        ("carm", angles + ["--pixel", "1e-300"], ["--pixel", "pixel size"]),
        ("carm", angles + ["--principal-point", "1e300", "1e300"], ["principal point"]),
        ("carm", angles + ["--sid", "2e9", "--sod", "1e9"], ["--sod", "1e+09"]),
        ("carm", angles + ["--isocenter", "1e12", "0", "0"], ["--isocenter", "isocentre"]),
        # An empty value for a number (CLI11 read it as 0, past the flag's own range check).
        ("centerlines", ["--label", this_file, "--out", never, "--tolerance", ""],
         ["--tolerance", "empty"]),
        ("phantom", ["--seed", "", "--out", never], ["--seed", "empty"]),
        ("eval", ["--top-k", ""], ["--top-k", "empty"]),
        ("drr", ["--volume", this_file, "--out", later_dir + "/"] + angles, ["--out", "prefix"]),
        ("drr", ["--volume", this_file, "--out", ""] + angles, ["--out", "empty"]),
        ("match", ["--dataset", later_dir, "--out", ""], ["--out", "empty"]),
        # Flags that the chosen mode or method would have ignored.
        ("carm", ["--routine", "--primary", 10, "--secondary", 5], ["--routine", "--primary"]),
        ("carm", ["--pair", this_file, this_file, "--primary", 10], ["--pair", "--primary"]),
        ("drr", ["--volume", this_file, "--out", never, "--step", 0.5] + angles,
         ["--step", "siddon"]),
        ("centerlines", ["--label", this_file, "--out", never, "--tolerance", 2],
         ["--tolerance", "--truth"]),
        ("baseline", ["--dataset", later_dir, "--method", "epipolar", "--sigma", 3, "--out",
                      never], ["--sigma", "epipolar"]),
        ("eval", ["--tree", this_file, "--centerlines", this_file, "--top-k", 5], ["--top-k"]),
        ("eval", ["--truth", this_file, "--matches", this_file, "--split", "test"], ["--split"]),
        ("eval", ["--dataset", later_dir, "--predictions", later_dir, "--name", "a\nb"],
         ["--name", "position 1"]),
        ("phantom", ["--seed", 1, "--noise", "1e308", "--out", never], ["--noise", "[0, 1000]"]),
        ("dataset", ["--phantom", 1, "--shard", "0/2", "--export", "reference", "--out", never],
         ["--export", "--shard 0/2"]),
        ("dataset", ["--input", later_dir, "--phantom-size", "chest", "--out", never],
         ["--phantom-size"]),
        ("dataset", ["--input", later_dir, "--timings", os.path.join(later_dir, "t.jsonl"),
                     "--out", never], ["--timings", "--input"]),
        # gimm-match values refused late or never (exit 1 or ignored).
        ("match", ["--threshold", 1], ["--threshold", "[0, 1)"]),
        ("match", ["--isocenter-a", "1e12", 0, 0], ["--isocenter-a", "1e12"]),
        ("match", ["--pixel-b", "1e-9"], ["--pixel-b", "1e-9"]),
        ("match", ["--method", "geometric", "--image-a", this_file, "--image-b", this_file,
                   "--weights", this_file], ["--weights", "geometric"]),
        ("match", ["--input-size", 1], ["--input-size", "got 1"]),
        ("match", ["--camera-error-deg", "1e300"], ["--camera-error-deg"]),
        ("match", ["--image-a", this_file, "--image-b", this_file, "--camera-a", this_file],
         ["--camera-a", "--camera-b"]),
        ("match", ["--image-a", this_file, "--image-b", this_file, "--gate", "none", "--snap"],
         ["--gate none", "--snap"]),
        ("match", ["--image-a", this_file, "--image-b", this_file, "--gate", "hard", "--tau", 3],
         ["--tau"]),
    ]
    for name, args, words in later:
        proc = check_usage_error(check, bin_dir, name, args, *words)
        check(len(proc.stderr) < 400, f"gimm-{name} {args}: a long message: {proc.stderr!r}")
    check(os.listdir(later_dir) == [], f"refused runs left {os.listdir(later_dir)}")

    # Finite negatives and exponents still work.
    proc = run(bin_dir, "carm", "--primary", "-30.5", "--secondary", "-2e1", "--sid", "1.1e3")
    check(proc.returncode == 0 and '"primary_deg": -30.5' in proc.stdout,
          f"gimm-carm with finite negative angles: exit {proc.returncode}: {proc.stderr[-300:]}")


if __name__ == "__main__":
    failures = []
    with tempfile.TemporaryDirectory() as tmp:
        check_flags(lambda cond, what: cond or failures.append(what), sys.argv[1], tmp)
    print("\n".join("FAIL: " + f for f in failures) or "flag_contract: all checks passed")
    sys.exit(1 if failures else 0)
