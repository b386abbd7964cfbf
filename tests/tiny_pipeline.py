"""A tiny tabletop pipeline made by the built tools, for tests that need real outputs of every
stage: `wm-gen-tabletop` RLDS episodes -> `wm-ingest` shard datasets -> `wm-tokenize train` ->
`wm-tokenize encode` token datasets -> `wm-train` dynamics run, on CPU, the trainers on one thread
unless a test asks for more.

Layout under ROOT (the one tests/evaluate/test_wm_eval.py builds by hand):
raw/wm_tabletop/1.0.0, shards/{train,val}, tok, tokens/{train,val}, dyn, and the derived configs
tokenizer.yaml / dynamics.yaml when train-section overrides are given.

Each stage's command line is also available on its own (`*_argv`), so a test can run a stage
under a fault (killed, disk full, read-only) and compare with the reference output here."""
import os
import subprocess

import yaml

SRC = os.environ.get("WM_SOURCE_DIR",
                     os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
BIN = os.environ.get("WM_BIN_DIR", os.path.join(SRC, "build", "bin"))
CONFIGS = os.path.join(SRC, "configs")


def argv(name, *args):
    return [os.path.join(BIN, name), *map(str, args)]


def run_ok(command, **kwargs):
    """subprocess.run capturing text output; AssertionError with the command and stderr unless it
    exits 0."""
    p = subprocess.run(command, capture_output=True, text=True, **kwargs)
    if p.returncode != 0:
        raise AssertionError(f"{' '.join(map(str, command))}: exit {p.returncode}\n{p.stderr}")
    return p


# configs/tokenizer/tiny.yaml's model without the anchor decoder, and so without what acts on
# its anchor (the anchor's flow, the change weight: both need it).
UNANCHORED_TOKENIZER = {"model": {"anchor_decoder": False, "anchor_flow": False,
                                  "change_weight": 0}}


def derived_config(kind, out, sections):
    """configs/<kind>/tiny.yaml with the keys of `sections` ({section: {key: value}}) replaced,
    written to `out` (YAML)."""
    with open(os.path.join(CONFIGS, kind, "tiny.yaml"), encoding="utf-8") as f:
        config = yaml.safe_load(f)
    for section, keys in sections.items():
        config[section].update(keys)
    with open(out, "w", encoding="utf-8") as f:
        yaml.safe_dump(config, f)
    return out


class TinyPipeline:
    """Stages are made on first use of their output and reused after."""

    def __init__(self, root, *, train_episodes, val_episodes, tokenizer_steps, dynamics_steps,
                 size=64, max_steps=40, look="varied", tokenizer_train=None, dynamics_train=None,
                 dynamics_model=None, tokenizer_threads=1, dynamics_threads=1, validate=False):
        """look: wm-gen-tabletop --look; dynamics_model: model-section overrides;
        validate: the trainers also score the val split (--val-data, --val-tokens)."""
        self.root, self.validate = root, validate
        self.gen_args = ["--size", size, "--train-episodes", train_episodes, "--val-episodes",
                         val_episodes, "--max-steps", max_steps, "--seed", 0, "--look", look]
        self.tokenizer_steps, self.dynamics_steps = tokenizer_steps, dynamics_steps
        self.tokenizer_threads, self.dynamics_threads = tokenizer_threads, dynamics_threads
        self.tokenizer_config = os.path.join(CONFIGS, "tokenizer", "tiny.yaml")
        if tokenizer_train:
            self.tokenizer_config = derived_config("tokenizer", self.path("tokenizer.yaml"),
                                                   {"train": tokenizer_train})
        self.dynamics_config = os.path.join(CONFIGS, "dynamics", "tiny.yaml")
        overrides = {k: v for k, v in (("train", dynamics_train), ("model", dynamics_model)) if v}
        if overrides:
            self.dynamics_config = derived_config("dynamics", self.path("dynamics.yaml"),
                                                  overrides)

    def path(self, *parts):
        return os.path.join(self.root, *parts)

    # Command lines, writing to `out`.
    def ingest_argv(self, split, out, *extra):
        return argv("wm-ingest", "--format", "rlds", "--input", self.raw(), "--split", split,
                    "--output", out, "--threads", 1, "--log-level", "warn", *extra)

    def tokenizer_argv(self, out, *extra):
        val = ["--val-data", self.shards("val")] if self.validate else []
        return argv("wm-tokenize", "train", "--config", self.tokenizer_config, "--data",
                    self.shards("train"), *val, "--out", out, "--steps", self.tokenizer_steps,
                    "--threads", self.tokenizer_threads, *extra)

    def encode_argv(self, split, out):
        return argv("wm-tokenize", "encode", "--checkpoint", self.tokenizer(), "--data",
                    self.shards(split), "--out", out, "--threads", 1)

    def dynamics_argv(self, out, *extra):
        val = ["--val-tokens", self.tokens("val")] if self.validate else []
        return argv("wm-train", "--config", self.dynamics_config, "--tokens",
                    self.tokens("train"), *val, "--out", out, "--steps", self.dynamics_steps,
                    "--threads", self.dynamics_threads, *extra)

    def eval_argv(self, out, *extra, checkpoints=None):
        """wm-eval of the dynamics run (or of the runs `checkpoints`) on the val split (options
        in `extra`)."""
        return argv("wm-eval", "--checkpoint", *(checkpoints or [self.dynamics()]),
                    "--tokenizer", self.tokenizer(),
                    "--data", self.shards("val"), "--tokens", self.tokens("val"), "--out", out,
                    "--threads", 1, *extra)

    # The reference outputs.
    def _make(self, out, command):
        if not os.path.exists(out):
            run_ok(command)
        return out

    def raw(self):
        return self._make(self.path("raw", "wm_tabletop", "1.0.0"),
                          argv("wm-gen-tabletop", "--out", self.path("raw"), *self.gen_args))

    def shards(self, split):
        out = self.path("shards", split)
        return self._make(out, self.ingest_argv(split, out))

    def tokenizer(self):
        return self._make(self.path("tok"), self.tokenizer_argv(self.path("tok")))

    def tokens(self, split):
        out = self.path("tokens", split)
        return self._make(out, self.encode_argv(split, out))

    def dynamics(self):
        return self._make(self.path("dyn"), self.dynamics_argv(self.path("dyn")))
