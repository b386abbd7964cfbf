"""Fault injection for the tests in this folder: SIGKILL after a seeded random delay, a file-size
limit standing in for a full disk, and read-only output directories; byte comparison of output
trees; and the tiny pipeline settings they share (tests/tiny_pipeline.py runs the built tools)."""
import hashlib
import os
import random
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from tiny_pipeline import SRC, TinyPipeline, run_ok  # noqa: E402,F401 (run_ok: for the tests)

SEED = 20240610  # fixes which kill points are tried (as fractions of the measured writing phase)
WMSHARD = ["/usr/bin/python3", os.path.join(SRC, "scripts", "wmshard.py")]
# Trainer runs: steps, checkpoint_every, and metrics.csv's wall-clock throughput column
# (docs/tokenizer.md says frames_per_s is not reproducible; tokens_per_s is the same kind).
TOKENIZER = {"steps": 9, "every": 3, "timing": "frames_per_s"}
DYNAMICS = {"steps": 6, "every": 2, "timing": "tokens_per_s"}
EVAL_OPTIONS = ["--horizon", 2, "--rollout", "plain", "--episodes", 2, "--resamples", 50]
INGEST_OPTIONS = ["--shard-size-mb", 0.03]  # about one episode per shard: many commit points


def tiny_pipeline(root, validate=False):
    """8 + 2 episodes of 12 steps at 64x64; trainers checkpointing every few steps."""
    return TinyPipeline(
        root, train_episodes=8, val_episodes=2, max_steps=12, validate=validate,
        tokenizer_steps=TOKENIZER["steps"], dynamics_steps=DYNAMICS["steps"],
        tokenizer_train={"batch_size": 8, "checkpoint_every": TOKENIZER["every"],
                         "log_every": 2, "val_every": 6, "val_frames": 16},
        dynamics_train={"batch_size": 2, "checkpoint_every": DYNAMICS["every"],
                        "log_every": 1, "val_every": 3, "val_batches": 1})


def run(command, **kwargs):
    return subprocess.run(command, capture_output=True, text=True, **kwargs)


def kill_fractions(name, count):
    """`count` kill points as fractions of a run's writing phase, one drawn uniformly in each of
    `count` equal slices (early, ..., late), from a RNG seeded by SEED and the tool's name (so
    adding a tool does not move another's points)."""
    rng = random.Random(f"{SEED}:{name}")
    return [(i + rng.random()) / count for i in range(count)]


def watch(command, out, kill_after_first_file=None):
    """Runs `command`, polling the output directory `out` every 5 ms. With
    `kill_after_first_file` (seconds), SIGKILLs it that long after the first file (temp files
    included) appeared under `out`, so kills land in the writing phase however long the start
    takes. Returns (exit status: -9 when killed, seconds to the first file, total seconds)."""
    start = time.monotonic()
    with tempfile.TemporaryFile(mode="w+") as log:  # not a pipe: a full pipe would stall the tool
        p = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=log)
        first = None
        while p.poll() is None:
            now = time.monotonic() - start
            if first is None and any(files for _, _, files in os.walk(out)):
                first = now
            if first is not None and kill_after_first_file is not None and \
                    now >= first + kill_after_first_file:
                p.send_signal(signal.SIGKILL)
                break
            time.sleep(0.005)
        p.wait()
        total = time.monotonic() - start
        log.seek(0)
        if kill_after_first_file is None and p.returncode != 0:
            raise AssertionError(f"{' '.join(command)}: exit {p.returncode}\n{log.read()}")
    return p.returncode, total if first is None else first, total


def with_file_size_limit(limit_bytes):
    """preexec_fn: writes past `limit_bytes` in any one file fail with EFBIG (SIGXFSZ ignored, so
    the write returns an error instead of killing the process), as on a full disk."""
    def limit():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit_bytes, limit_bytes))
    return limit


def read_only_runner(executable):
    """(kwargs for subprocess.run that make a 0555 directory unwritable to the child, None) or
    (None, why not). Root ignores permission bits, so as root the child runs as `nobody`, which
    must be able to run `executable` itself: a checkout below a directory closed to other users
    (mktemp -d makes 0700 ones) is out of nobody's reach."""
    if os.geteuid() != 0:
        return {}, None
    try:
        probe = run([executable, "--version"], user=65534, group=65534, extra_groups=[])
    except (PermissionError, OSError) as e:
        return None, f"running as root and nobody cannot run {executable} ({e})"
    if probe.returncode != 0:
        return None, f"running as root and nobody cannot run {executable} --version"
    return {"user": 65534, "group": 65534, "extra_groups": []}, None


def set_tree_mode(root, dir_mode, file_mode):
    for parent, _, files in os.walk(root):
        os.chmod(parent, dir_mode)
        for f in files:
            os.chmod(os.path.join(parent, f), file_mode)


def sha256(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def is_hidden(relpath):
    return any(part.startswith(".") for part in relpath.split(os.sep))


def tree(root):
    """{relative path: SHA-256} of every visible file under `root` (hidden temp and state files,
    which readers never open, left out); {} when `root` does not exist."""
    out = {}
    for parent, _, files in os.walk(root):
        for f in files:
            rel = os.path.relpath(os.path.join(parent, f), root)
            if not is_hidden(rel):
                out[rel] = sha256(os.path.join(parent, f))
    return out


def hidden_files(root):
    found = []
    for parent, dirs, files in os.walk(root):
        found += [os.path.relpath(os.path.join(parent, n), root) for n in dirs + files]
    return sorted(f for f in found if is_hidden(f))


def copy_tree(src, dst):
    shutil.rmtree(dst, ignore_errors=True)
    shutil.copytree(src, dst)
    return dst


def csv_rows(path, drop_column=None):
    """The CSV's rows as lists of cells, `drop_column` removed; asserts every line is
    complete (newline-terminated, as many cells as the header)."""
    with open(path, encoding="utf-8") as f:
        text = f.read()
    assert text.endswith("\n"), f"{path}: last line is not terminated"
    lines = [line.split(",") for line in text.splitlines()]
    header = lines[0]
    for i, cells in enumerate(lines[1:], start=2):
        assert len(cells) == len(header), f"{path}:{i}: {len(cells)} cells, header {len(header)}"
    keep = [i for i, name in enumerate(header) if name != drop_column]
    assert drop_column is None or len(keep) == len(header) - 1, f"{path}: no {drop_column}"
    return [[cells[i] for i in keep] for cells in lines]


def is_event_file(relpath):
    """TensorBoard's rule: a file whose name contains "tfevents"."""
    return "tfevents" in os.path.basename(relpath)


def run_dir_state(run_dir, spec):
    """What must be equal between two trainer run directories: every visible file's bytes, but
    metrics.csv without its wall-clock throughput column (docs/tokenizer.md, docs/dynamics.md)
    and not the TensorBoard event files, whose events carry wall_time (docs/tensorboard.md; their
    scalars are checked against the CSV logs by tests/train/test_event_files.py)."""
    files = {name: sha for name, sha in tree(run_dir).items() if not is_event_file(name)}
    files.pop("metrics.csv", None)
    return files, csv_rows(os.path.join(run_dir, "metrics.csv"), spec["timing"])
