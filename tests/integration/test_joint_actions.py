#!/usr/bin/python3
"""Actions of any width end to end (issue 23) on the real Unitree G1 LeRobot sample (26-dim
joint_position actions): wm-ingest -> wm-tokenize train (a few steps) -> encode -> wm-train (a
few steps) -> wm-eval. The token index, checkpoint and report keep the 26 dims; a retracing
rollout is refused in one line naming the dataset and its action space. About 20 s on 2 cores,
most of it decoding the AV1 video; skipped (exit 0) when the sample is absent
($WM_SHARED_DIR/samples/lerobot/unitree_g1_v21, default ../shared next to the source tree)."""
import csv
import json
import os
import subprocess
import sys
import tempfile
import unittest

import jsonschema

SRC = os.environ.get("WM_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
sys.path.insert(0, os.path.join(SRC, "tests"))
from tiny_pipeline import CONFIGS, argv, run_ok  # noqa: E402

SHARED = os.environ.get("WM_SHARED_DIR", os.path.join(SRC, "..", "shared"))
SAMPLE = os.path.join(SHARED, "samples", "lerobot", "unitree_g1_v21")


def schema(name):
    with open(os.path.join(SRC, "schemas", name + ".schema.json"), encoding="utf-8") as f:
        return json.load(f)


def load(path):
    with open(path, encoding="utf-8") as f:
        return json.load(f)


@unittest.skipUnless(os.path.isfile(os.path.join(SAMPLE, "meta", "info.json")),
                     f"no G1 sample at {SAMPLE}")
class JointActionsEndToEnd(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory(prefix="wm-g1-")
        d = lambda name: os.path.join(cls.tmp.name, name)  # noqa: E731
        cls.shards, cls.tok, cls.tokens, cls.dyn = d("shards"), d("tok"), d("tokens"), d("dyn")
        run_ok(argv("wm-ingest", "--format", "lerobot", "--input", SAMPLE, "--output", cls.shards,
                    "--resize", "64x64", "--threads", 1))
        run_ok(argv("wm-tokenize", "train", "--config", os.path.join(CONFIGS, "tokenizer",
                                                                    "tiny.yaml"),
                    "--data", cls.shards, "--out", cls.tok, "--steps", 5, "--threads", 1))
        run_ok(argv("wm-tokenize", "encode", "--checkpoint", cls.tok, "--data", cls.shards,
                    "--out", cls.tokens, "--threads", 1))
        run_ok(argv("wm-train", "--config", os.path.join(CONFIGS, "dynamics", "tiny.yaml"),
                    "--tokens", cls.tokens, "--out", cls.dyn, "--steps", 4, "--threads", 1))
        cls.eval_args = ["--checkpoint", cls.dyn, "--tokenizer", cls.tok, "--data", cls.shards,
                         "--tokens", cls.tokens, "--episodes", 1, "--horizon", 2, "--threads", 1]

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_token_index_keeps_the_width(self):
        index = load(os.path.join(self.tokens, "index.json"))
        self.assertEqual((index["format_version"], index["action_dim"], index["action_space"]),
                         (2, 26, "joint_position"))
        self.assertEqual(index["parts"][0]["sections"]["actions"]["shape"][1], 26)
        jsonschema.validate(index, schema("token-index"))
        r = subprocess.run(["/usr/bin/python3", os.path.join(SRC, "scripts", "wmshard.py"),
                            "--tokens", self.tokens, "--verify"], capture_output=True, text=True)
        self.assertEqual(r.stdout.strip(), "OK 3 episodes", r.stderr)

    def test_checkpoint_records_the_width(self):
        manifest = load(os.path.join(self.dyn, "checkpoint.json"))
        self.assertEqual(manifest["config"]["model"]["action_dim"], 26)
        self.assertEqual(len(manifest["action_norms"]["unitree_g1_v21"]["mean"]), 26)
        jsonschema.validate(manifest, schema("dynamics-checkpoint"))

    def test_eval_rolls_out_at_the_width_and_skips_retrace(self):
        out = os.path.join(self.tmp.name, "report")
        run_ok(argv("wm-eval", *self.eval_args, "--out", out))
        with open(os.path.join(out, "dyn", "contexts.csv"), encoding="utf-8") as f:
            rows = list(csv.DictReader(f))
        self.assertEqual(list(rows[0])[-1], "a25")
        self.assertEqual({r["rollout"] for r in rows}, {"plain"})  # --rollout auto: no retrace
        with open(os.path.join(out, "dyn", "summary.csv"), encoding="utf-8") as f:
            self.assertIn("dyn,plain,delta_tpsnr,", f.read())  # actions perturbed at width 26

    def test_retrace_is_a_one_line_error(self):
        r = subprocess.run(argv("wm-eval", *self.eval_args, "--out",
                                os.path.join(self.tmp.name, "retrace"), "--rollout", "retrace"),
                           capture_output=True, text=True)
        self.assertEqual(r.returncode, 1)
        self.assertEqual(r.stderr.count("\n"), 1, r.stderr)
        self.assertIn("dataset 'unitree_g1_v21' has joint_position actions", r.stderr)


if __name__ == "__main__":
    unittest.main()
