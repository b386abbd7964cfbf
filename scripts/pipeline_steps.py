"""What the experiment scripts (scripts/ablation.py, scripts/finetune.py, scripts/scaling.py)
share: running a wmkit tool with its output in a log, hashing inputs for a manifest, writing
results atomically so a killed run never leaves a half-written file that looks finished, checking
a config's keys, and the pipeline steps (generate, ingest, tokenizer, encode, wm-train, wm-eval)
that skip or resume finished work."""
import hashlib
import os
import subprocess
import sys
import threading
import time

import yaml


_ECHO_LOCK = threading.Lock()


def echo_command(cmd):
    """Prints "+ cmd" as one whole line: experiments run tools from several threads, and print()
    writes the text and its newline separately, so two threads' lines could run into one."""
    with _ECHO_LOCK:
        sys.stdout.write("+ " + " ".join(cmd) + "\n")
        sys.stdout.flush()


def run(cmd, log, who):
    """Runs one wmkit tool, its output appended to `log`; a failure stops the script `who`."""
    echo_command(cmd)
    with open(log, "a", encoding="utf-8") as f:
        if subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT).returncode != 0:
            sys.exit(f"{who}: command failed (log: {log}): {' '.join(cmd)}")


def sha256(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def write_atomically(path, data):
    """Writes `data` (text, or bytes) to a temporary file, syncs it, then renames it to `path`."""
    tmp = path + ".tmp"
    with open(tmp, "wb") as f:
        f.write(data.encode() if isinstance(data, str) else data)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


class ConfigError(Exception):
    """A bad experiment config; its message is one line naming the file and the key."""


def load_yaml_config(path):
    try:
        with open(path, encoding="utf-8") as f:
            return yaml.safe_load(f)
    except (OSError, yaml.YAMLError) as e:
        raise ConfigError(f"{path}: cannot read the config: {e}") from e


class ConfigKeys:
    """Typed look-ups of dotted keys in a loaded config; a missing or bad key is a ConfigError."""

    POSITIVE = (lambda v: v >= 1, "an integer >= 1")
    NON_NEGATIVE = (lambda v: v >= 0, "an integer >= 0")

    def __init__(self, path, cfg):
        self.path, self.cfg = path, cfg

    def get(self, dotted, kind, check=None, what=""):
        node = self.cfg
        for part in dotted.split("."):
            if not isinstance(node, dict) or part not in node:
                raise ConfigError(f"{self.path}: key '{dotted}' is missing")
            node = node[part]
        if not isinstance(node, kind) or isinstance(node, bool) or (check and not check(node)):
            raise ConfigError(f"{self.path}: key '{dotted}': expected {what or kind.__name__}, "
                              f"got {node!r}")
        return node

    def seed_and_frames(self):
        """seed, data.size and data.policies: the keys every tabletop experiment has."""
        self.get("seed", int, *self.NON_NEGATIVE)
        self.get("data.size", int, lambda v: 64 <= v <= 256, "an integer in 64..256")
        self.get("data.policies", str)

    def existing_file(self, dotted):
        if not os.path.isfile(self.get(dotted, str)):
            raise ConfigError(f"{self.path}: key '{dotted}': no such file {self.get(dotted, str)}")


class Pipeline:
    """One experiment's output directory and the wmkit steps the experiments share. Each step is
    skipped when its output exists, and a trainer resumes (a finished run is a no-op), so a killed
    script continues where it stopped. Commands are logged to OUT/<who>.log."""

    def __init__(self, args, who, load_config):
        """args: --bin, --config, --out (start()); load_config(path) checks every key first, so a
        bad config stops before the output directory exists."""
        self.cfg, self.config_path = load_config(args.config), args.config
        self.bin, self.out, self.who = args.bin, args.out, who
        os.makedirs(self.out, exist_ok=True)
        self.log = self.path(f"{who}.log")
        self.stage_seconds = {}

    def path(self, *parts):
        return os.path.join(self.out, *parts)

    def tool(self, name, *args, log=None):
        run([os.path.join(self.bin, name), *map(str, args)], log or self.log, self.who)

    def timed(self, stage, fn, *args):
        started = time.time()
        fn(*args)
        self.stage_seconds[stage] = round(time.time() - started, 1)

    def generate(self, raw, size, policies, train_episodes, val_episodes, seed, look,
                 goal_region=None):
        """wm-gen-tabletop into `raw` (a directory under OUT) unless it is there."""
        if os.path.exists(self.path(raw, "wm_tabletop", "1.0.0", "dataset_info.json")):
            return
        region = [f"--goal-region={goal_region}"] if goal_region else []
        self.tool("wm-gen-tabletop", "--out", self.path(raw), "--size", size, "--policies",
                  policies, "--train-episodes", train_episodes, "--val-episodes", val_episodes,
                  "--seed", seed, "--look", look, *region)

    def ingest(self, raw, split, shards):
        """One split of a generated set into OUT/shards/<shards>."""
        if not os.path.exists(self.path("shards", shards, "index.json")):
            self.tool("wm-ingest", "--format", "rlds", "--input",
                      self.path(raw, "wm_tabletop", "1.0.0"), "--split", split, "--output",
                      self.path("shards", shards))

    def train_tokenizer(self, config, steps, seed, train, val):
        """OUT/tokenizer, trained on OUT/shards/<train> (validated on <val>)."""
        run_dir = self.path("tokenizer")
        resume = ["--resume"] if os.path.exists(os.path.join(run_dir, "checkpoint.wmt")) else []
        self.tool("wm-tokenize", "train", "--config", config, "--data", self.path("shards", train),
                  "--val-data", self.path("shards", val), "--out", run_dir, "--steps", steps,
                  "--seed", seed, *resume)

    def encode(self, split):
        """OUT/shards/<split> through OUT/tokenizer into OUT/tokens/<split>."""
        if not os.path.exists(self.path("tokens", split, "index.json")):
            self.tool("wm-tokenize", "encode", "--checkpoint", self.path("tokenizer"), "--data",
                      self.path("shards", split), "--out", self.path("tokens", split))

    def train_dynamics(self, run_dir, config, tokens, val_tokens, steps, seed, threads, *extra,
                       log=None):
        """wm-train into `run_dir` on OUT/tokens/<tokens>, validated on OUT/tokens/<val_tokens>."""
        resume = ["--resume"] if os.path.exists(os.path.join(run_dir, "checkpoint.wmt")) else []
        self.tool("wm-train", "--config", config, "--tokens", self.path("tokens", tokens),
                  "--val-tokens", self.path("tokens", val_tokens), "--out", run_dir, "--steps",
                  steps, "--seed", seed, "--threads", threads, *extra, *resume, log=log)

    def evaluate(self, reports, names, run_dirs, split, horizon, seed, resamples, strips, threads):
        """One wm-eval of `run_dirs` (named `names`) on OUT/shards/<split>, plain rollout, argmax,
        segmented MSE from the segmentation stream, into OUT/<reports>/<name>."""
        if all(os.path.exists(self.path(reports, n, "manifest.json")) for n in names):
            return
        self.tool("wm-eval", "--checkpoint", *run_dirs, "--name", *names, "--tokenizer",
                  self.path("tokenizer"), "--data", self.path("shards", split), "--tokens",
                  self.path("tokens", split), "--out", self.path(reports), "--horizon", horizon,
                  "--rollout", "plain", "--temperature", 0, "--seed", seed, "--resamples",
                  resamples, "--masks", "files", "--seg-config",
                  "configs/segmentation/tabletop.yaml", "--strips", strips, "--videos", 0,
                  "--threads", threads)


def run_output(cmd, log, who):
    """Runs one wmkit tool and returns its standard output; its standard error goes to `log`."""
    echo_command(cmd)
    with open(log, "a", encoding="utf-8") as f:
        p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=f, text=True)
    if p.returncode != 0:
        sys.exit(f"{who}: command failed (log: {log}): {' '.join(cmd)}")
    return p.stdout


def start(doc, experiment, who):
    """Parses an experiment script's command line (--bin, --config, --out; `doc` is its --help)
    and builds `experiment(args)`; a bad config exits with its one line, before anything runs.
    Returns (the experiment, its start time)."""
    import argparse
    ap = argparse.ArgumentParser(description=doc,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default="build/bin")
    ap.add_argument("--config", default=f"configs/{who}/tiny.yaml")
    ap.add_argument("--out", default=f"data/{who}")
    args = ap.parse_args()
    started = time.time()
    try:
        return experiment(args), started
    except ConfigError as e:
        sys.exit(f"{who}: {e}")
