#!/usr/bin/python3
"""SHA-256 of what the two trainers write for a fixed config and seed, to show that a refactor
of the training code changes no byte: `trainer_digest.py [--keep DIR] [--expect DIGEST.json]`
runs the fault tests' tiny pipeline (tests/faults/fault_harness.py: tokenizer and dynamics runs
with validation and several checkpoints), prints {file: sha256} as JSON and, with --expect,
exits 1 naming each file whose digest differs from the saved one.

Normalised before hashing: metrics.csv without its wall-clock throughput column (as the
byte-identity tests do), and JSON files without "git_commit" (it names the build, "-dirty" for
an uncommitted tree) and without the SHA-256s of other files that hold one (a token dataset's
index.json, listed by itself instead). The TensorBoard event files are left out: every event
carries its wall_time."""
import argparse
import hashlib
import json
import os
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "faults"))
import fault_harness as fh  # noqa: E402

RUNS = {"tok": fh.TOKENIZER, "dyn": fh.DYNAMICS}
TOKEN_INDEXES = ["tokens/train/index.json", "tokens/val/index.json"]


def without_build_names(value):
    if isinstance(value, dict):
        return {k: without_build_names(v) for k, v in value.items()
                if k not in ("git_commit", "index_sha256")}
    if isinstance(value, list):
        return [without_build_names(v) for v in value]
    return value


def digest(path, spec):
    name = os.path.basename(path)
    if name == "metrics.csv":
        data = "\n".join(",".join(r) for r in fh.csv_rows(path, spec["timing"])).encode()
    elif name.endswith(".json"):
        with open(path, encoding="utf-8") as f:
            data = json.dumps(without_build_names(json.load(f)), sort_keys=True).encode()
    else:
        with open(path, "rb") as f:
            data = f.read()
    return hashlib.sha256(data).hexdigest()


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--keep", help="build the pipeline here (kept) instead of a temp dir")
    parser.add_argument("--expect", help="JSON of a previous run's digests to compare with")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="wmkit-digest-") as tmp:
        root = args.keep or tmp
        pipe = fh.tiny_pipeline(root, validate=True)
        pipe.dynamics()  # makes the tokenizer run and the token datasets on the way
        digests = {}
        for run, spec in RUNS.items():
            for name in sorted(os.listdir(pipe.path(run))):
                if not name.startswith(".") and not fh.is_event_file(name):
                    digests[f"{run}/{name}"] = digest(pipe.path(run, name), spec)
        for index in TOKEN_INDEXES:
            digests[index] = digest(pipe.path(index), None)
    print(json.dumps(digests, indent=2, sort_keys=True))
    if args.expect:
        with open(args.expect, encoding="utf-8") as f:
            expected = json.load(f)
        differ = sorted(k for k in expected.keys() | digests.keys()
                        if expected.get(k) != digests.get(k))
        for k in differ:
            print(f"DIFFERS: {k}: {expected.get(k)} -> {digests.get(k)}", file=sys.stderr)
        return 1 if differ else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
