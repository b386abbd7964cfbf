#!/usr/bin/python3
"""wm-eval --policy with a motion checkpoint (wm-motion train) and a success classifier
(wm-success train, --success-model) end to end on a tiny generated tabletop pipeline (every model
trained for a few steps here):

- the same run twice gives the same bytes (wm_episodes.csv, wm_values.csv, wpe.csv, strips);
- closed loop: the policy sees the real first frame at step 0 and, at step t > 0, exactly the
  imagined frame the strip shows; two policies with opposite actions get different success
  scores from the same starts;
- every step's success score is the classifier's probability: in [0, 1], an episode ends as a
  success exactly at its first step above 0.5;
- wpe.csv rows and wpe_summary.json validate against their schemas; the manifest names the
  motion model and the success classifier by hash; the success run's checkpoint.json validates
  against schemas/success-checkpoint.schema.json and agrees with its archive; `wm-success score`
  rows against schemas/success-scores-row.schema.json;
- a motion checkpoint without --success-model, or with a --success-model that is not a success
  classifier, exits 1 with one line that says so, and leaves no finished-looking report."""
import hashlib
import json
import os
import subprocess
import sys
import tempfile
import unittest

import cv2
import jsonschema
import numpy as np
import yaml

SRC = os.environ.get("WM_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
BIN = os.environ.get("WM_BIN_DIR", os.path.join(SRC, "build", "bin"))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
# The token model's closed-loop test: its tools, readers, strip geometry and recording policies.
from test_wm_eval_policy import (EPISODES, FINISHED, HORIZON, ClosedLoopCase, ok,  # noqa: E402
                                 read_json, read_rows, recorders, strip_cell, wmshard,
                                 write_truth)


def run(name, *args):
    return subprocess.run([os.path.join(BIN, name), *map(str, args)], capture_output=True,
                          text=True)


def sha256(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


class WmEvalPolicyMotion(ClosedLoopCase, unittest.TestCase):
    CHECKPOINT = "motion"

    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        path = cls.path
        # The expert reaches the goal in most episodes: success frames for the classifier.
        ok("wm-gen-tabletop", "--out", path("raw"), "--size", 64, "--train-episodes", 8,
           "--val-episodes", EPISODES, "--max-steps", 40, "--seed", 0, "--look", "plain",
           "--policies", "expert")
        for split in ("train", "val"):
            ok("wm-ingest", "--format", "rlds", "--input", path("raw", "wm_tabletop", "1.0.0"),
               "--split", split, "--output", path("shards", split), "--threads", 1)
        # wm-eval takes its starts from a token dataset, whatever the model.
        ok("wm-tokenize", "train", "--config", os.path.join(SRC, "configs", "tokenizer",
                                                            "tiny.yaml"),
           "--data", path("shards", "train"), "--out", path("tok"), "--steps", 5, "--threads", 1)
        ok("wm-tokenize", "encode", "--checkpoint", path("tok"), "--data", path("shards", "val"),
           "--out", path("tokens", "val"), "--threads", 1)
        ok("wm-motion", "train", "--config", os.path.join(SRC, "configs", "motion", "tiny.yaml"),
           "--data", path("shards", "train"), "--out", path("motion"), "--steps", 20,
           "--threads", 1)
        ok("wm-success", "train", "--config", os.path.join(SRC, "configs", "success", "tiny.yaml"),
           "--data", path("shards", "train"), "--val-data", path("shards", "val"),
           "--out", path("success"), "--steps", 40, "--threads", 1)
        cls.truth = write_truth(path("policy_values.json"))
        for out in ("run", "rerun"):
            ok("wm-eval", *cls.args(path(out), recorders(path(out + "_seen")),
                                    "--success-model", path("success")))
        cls.report = path("run", "motion")

    def test_policy_sees_real_start_then_imagined_frames(self):
        shards = wmshard.Dataset(self.path("shards", "val"))
        tokens = wmshard.TokenDataset(self.path("tokens", "val"))
        episodes = {int(r["episode"]): r for r in read_rows(
            os.path.join(self.report, "wm_episodes.csv")) if r["policy"] == "plus"}
        for k in range(EPISODES):
            _, _, blobs = shards.episode(tokens.index["episodes"][k]["source_episode"])
            real = cv2.cvtColor(cv2.imdecode(np.frombuffer(blobs["image"][0], np.uint8),
                                             cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)
            seen = self.path("run_seen", "plus")
            np.testing.assert_array_equal(np.load(os.path.join(seen, f"{k}_0.npy")), real)
            strip = cv2.imread(os.path.join(self.report, "strips", f"episode_{k}.png"))
            steps = int(episodes[k]["steps"])
            for t in range(1, steps):  # strip rows: real (logged), minus, plus (name order)
                shown = np.load(os.path.join(seen, f"{k}_{t}.npy"))
                np.testing.assert_array_equal(shown, strip_cell(strip, 2, t), f"{k} step {t}")
                if t == 1:  # the motion model moved something: not the real frame again
                    self.assertGreater(np.abs(shown.astype(int) - real).max(), 0)

    def test_success_scores_are_the_classifiers_probabilities(self):
        rows = read_rows(os.path.join(self.report, "wm_episodes.csv"))
        self.assertEqual(len(rows), 2 * EPISODES)
        scores = {}
        for r in rows:
            steps, peak = int(r["steps"]), float(r["max_reward"])
            self.assertTrue(0 <= peak <= 1, r)
            self.assertGreaterEqual(float(r["return"]), peak)
            self.assertLessEqual(float(r["return"]), steps)
            if r["success"] == "1":
                self.assertEqual(r["end"], "success")
                self.assertGreater(peak, 0.5)
            else:
                self.assertEqual((r["end"], steps), ("horizon", HORIZON))
                self.assertLessEqual(peak, 0.5)
            scores[(r["policy"], r["episode"])] = r["return"]
        for k in range(EPISODES):  # the actions reach the model
            self.assertNotEqual(scores[("plus", str(k))], scores[("minus", str(k))])

    def test_wpe_outputs_validate_and_name_both_models(self):
        with open(os.path.join(SRC, "schemas", "wpe-summary.schema.json"), encoding="utf-8") as f:
            jsonschema.validate(read_json(os.path.join(self.report, "wpe_summary.json")),
                                json.load(f))
        with open(os.path.join(SRC, "schemas", "wpe-row.schema.json"), encoding="utf-8") as f:
            row_schema = json.load(f)
        rows = read_rows(os.path.join(self.report, "wpe.csv"))
        self.assertEqual([r["policy"] for r in rows], ["plus", "minus"])
        for row in rows:
            typed = {k: (v == "true" if k == "in_distribution" else
                         v if k == "policy" else int(v) if k.endswith("episodes") else
                         None if v == "" else float(v)) for k, v in row.items()}
            jsonschema.validate(typed, row_schema)
        manifest = read_json(os.path.join(self.report, "manifest.json"))
        with open(os.path.join(SRC, "schemas", "report-manifest.schema.json"),
                  encoding="utf-8") as f:
            jsonschema.validate(manifest, json.load(f))
        success_sha = sha256(self.path("success", "checkpoint.wmt"))
        self.assertEqual(manifest["checkpoint"]["model_kind"], "motion")
        self.assertEqual(manifest["checkpoint"]["sha256"], sha256(self.path("motion",
                                                                            "checkpoint.wmt")))
        self.assertEqual(manifest["checkpoint"]["success_model"]["sha256"], success_sha)
        self.assertEqual(manifest["config"]["policy_eval"]["success_model_sha256"], success_sha)
        summary = read_json(os.path.join(self.report, "wpe_summary.json"))
        self.assertEqual(summary["provenance"]["inputs"]["success_model_sha256"], success_sha)
        self.assertEqual(summary["provenance"]["libraries"]["blas"],
                         manifest["libraries"]["blas"])  # the closed loop's values ran on it too

    def test_success_checkpoint_manifest_validates(self):
        """checkpoint.json of the success run against schemas/success-checkpoint.schema.json,
        its archive's meta and the config actually trained (tiny.yaml with --steps 40)."""
        manifest = read_json(self.path("success", "checkpoint.json"))
        with open(os.path.join(SRC, "schemas", "success-checkpoint.schema.json"),
                  encoding="utf-8") as f:
            v = jsonschema.Draft202012Validator(json.load(f))
        v.validate(manifest)
        with open(os.path.join(SRC, "configs", "success", "tiny.yaml"), encoding="utf-8") as f:
            expected = yaml.safe_load(f)
        expected["train"]["steps"] = 40
        self.assertEqual(manifest["config"], expected)
        self.assertEqual(manifest["checkpoint"]["sha256"],
                         sha256(self.path("success", "checkpoint.wmt")))
        data = manifest["data"][0]
        self.assertEqual(data["success_frames"] + data["other_frames"], data["num_steps"])
        for bad in ({"model_kind": "motion"}, {"step": 0}, {"action_dim": 7}):
            self.assertFalse(v.is_valid({**manifest, **bad}), bad)
        with open(self.path("success", "checkpoint.wmt"), "rb") as f:
            blob = f.read()
        n = int.from_bytes(blob[8:16], "little")
        meta = json.loads(blob[16:16 + n].decode("utf-8"))["meta"]
        for key in ("model_kind", "step", "config", "config_hash", "data"):
            self.assertEqual(meta[key], manifest[key] if key != "data" else manifest["data"][0],
                             key)

    def test_success_scores_of_real_episodes_validate(self):
        """wm-success score on the val episodes: one schema-valid row per episode."""
        out = self.path("scores.csv")
        ok("wm-success", "score", "--checkpoint", self.path("success"), "--data",
           self.path("shards", "val"), "--out", out)
        with open(os.path.join(SRC, "schemas", "success-scores-row.schema.json"),
                  encoding="utf-8") as f:
            row_schema = json.load(f)
        rows = read_rows(out)
        self.assertEqual([int(r["episode"]) for r in rows], list(range(EPISODES)))
        for r in rows:
            typed = {k: v if k == "policy_id" else float(v) if k == "max_probability" else int(v)
                     for k, v in r.items()}
            jsonschema.validate(typed, row_schema)
            self.assertEqual(typed["predicted_success"], int(typed["first_success_step"] >= 0))
            self.assertEqual(r["policy_id"], "expert")

    def test_missing_or_wrong_success_model_is_one_clear_error(self):
        cases = [([], "needs --success-model"),
                 (["--success-model", self.path("motion")], "not a success classifier")]
        for extra, problem in cases:
            with self.subTest(problem=problem):
                out = self.path("bad_" + str(len(extra)))
                p = run("wm-eval", *self.args(out, recorders(self.path("bad_seen")), *extra))
                self.assertEqual(p.returncode, 1, p.stderr)
                self.assertIn(problem, p.stderr)
                self.assertEqual(len(p.stderr.strip().splitlines()), 1, p.stderr)
                for f in FINISHED:
                    self.assertFalse(os.path.exists(os.path.join(out, "motion", f)), f)


if __name__ == "__main__":
    unittest.main()
