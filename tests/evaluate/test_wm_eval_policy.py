#!/usr/bin/python3
"""wm-eval --policy (closed-loop policy evaluation in the world model) end to end on a tiny
generated tabletop pipeline (tokenizer and dynamics model trained for a few steps here):

- the same run twice gives the same bytes (wm_episodes.csv, wm_values.csv, wpe.csv, strips);
- the policy is reset with the simulator's seed rule and sees, at step 0, the real first frame
  and at step t > 0 exactly the imagined frame the strip shows in its row (the decoded frame);
- its (clamped) actions reach the model: two policies with opposite actions get different reward
  predictions from the same starts;
- wpe.csv / wpe_summary.json validate against their schemas and pair the right true values;
- a crashing, hanging or malformed policy exits 1 naming policy, episode and step, and removes
  the report's finished-looking files (left by an earlier good run)."""
import csv
import filecmp
import json
import os
import shutil
import subprocess
import sys
import tempfile
import unittest

import cv2
import jsonschema
import numpy as np

SRC = os.environ.get("WM_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
BIN = os.environ.get("WM_BIN_DIR", os.path.join(SRC, "build", "bin"))
sys.path.insert(0, os.path.join(SRC, "scripts"))
import wmshard  # noqa: E402
sys.path.insert(0, os.path.join(SRC, "tests"))
from tiny_pipeline import UNANCHORED_TOKENIZER, derived_config  # noqa: E402

HORIZON, EPISODES, SIZE = 4, 2, 64
RECORDER = os.path.join(SRC, "tests", "evaluate", "recording_policy.py")
ECHO = os.path.join(SRC, "tests", "policy", "echo_policy.py")
FINISHED = ["manifest.json", "wm_values.csv", "wm_episodes.csv", "wpe.csv", "wpe_summary.json"]
# evaluate/episode_strip.h geometry: label column, header row, gap; 64 px frames drawn 3x.
STRIP_LABEL, STRIP_HEADER, STRIP_GAP, STRIP_SCALE = 144, 24, 2, 3


def ok(name, *args):
    p = subprocess.run([os.path.join(BIN, name), *map(str, args)], capture_output=True, text=True)
    if p.returncode != 0:
        raise AssertionError(f"{name} {' '.join(map(str, args))}: exit {p.returncode}\n{p.stderr}")
    return p


def mix_bits(x):
    """core/mix_bits.h (SplitMix64's finalizer) in 64-bit arithmetic."""
    m = (1 << 64) - 1
    x = (x + 0x9E3779B97F4A7C15) & m
    x = ((x ^ (x >> 30)) * 0xBF58476D1CE4E5B9) & m
    x = ((x ^ (x >> 27)) * 0x94D049BB133111EB) & m
    return x ^ (x >> 31)


def read_rows(path):
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def read_json(path):
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def strip_cell(strip, row, column):
    """Frame (row, column) of a strip, back at 64 px, RGB."""
    cell = SIZE * STRIP_SCALE
    y, x = STRIP_HEADER + row * (cell + STRIP_GAP), STRIP_LABEL + column * (cell + STRIP_GAP)
    return cv2.cvtColor(strip[y:y + cell:STRIP_SCALE, x:x + cell:STRIP_SCALE], cv2.COLOR_BGR2RGB)


def recorders(seen):
    """Two recording policies with opposite constant actions, writing what they see to seen/."""
    plus = ",".join(["0.04"] * 6 + ["1"])
    minus = ",".join(["-0.04"] * 6 + ["0"])
    return ["--policy", f"plus={RECORDER} --out {seen}/plus --action={plus}",
            "--policy", f"minus={RECORDER} --out {seen}/minus --action={minus}",
            "--in-distribution", "plus"]


def write_truth(path):
    """Made-up true values of the two recorders (a policy_values.json); returns `path`."""
    with open(path, "w", encoding="utf-8") as f:
        json.dump({"format": "wmkit-policy-values", "policies": [
            {"policy": "minus", "in_distribution": False, "episodes": 10, "true_value": 0.2,
             "ci_low": 0.05, "ci_high": 0.5},
            {"policy": "plus", "in_distribution": True, "episodes": 10, "true_value": 0.7,
             "ci_low": 0.4, "ci_high": 0.9}]}, f)
    return path


class ClosedLoopCase:
    """What the token and the motion closed-loop tests share: their temporary tree, wm-eval's
    arguments for the checkpoint directory CHECKPOINT, and the rerun's identical bytes. A mixin,
    so that importing it does not collect its tests twice."""
    CHECKPOINT = None

    @classmethod
    def path(cls, *parts):
        return os.path.join(cls.tmp.name, *parts)

    @classmethod
    def args(cls, out, policies, *extra):
        path = cls.path
        return ["--checkpoint", path(cls.CHECKPOINT), "--tokenizer", path("tok"), "--data",
                path("shards", "val"), "--tokens", path("tokens", "val"), "--out", out,
                "--threads", 1, "--episodes", EPISODES, "--policy-horizon", HORIZON,
                "--strips", EPISODES, "--true-values", cls.truth, *policies, *extra]

    def test_rerun_gives_identical_bytes(self):
        files = ["wm_episodes.csv", "wm_values.csv", "wpe.csv"] + [
            os.path.join("strips", f"episode_{k}.png") for k in range(EPISODES)]
        rerun = self.path("rerun", self.CHECKPOINT)
        for f in files:
            self.assertTrue(filecmp.cmp(os.path.join(self.report, f), os.path.join(rerun, f),
                                        shallow=False), f)


class WmEvalPolicy(ClosedLoopCase, unittest.TestCase):
    CHECKPOINT = "dyn"

    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        path = cls.path
        ok("wm-gen-tabletop", "--out", path("raw"), "--size", SIZE, "--train-episodes", 8,
           "--val-episodes", EPISODES, "--max-steps", 12, "--seed", 0, "--look", "plain")
        for split in ("train", "val"):
            ok("wm-ingest", "--format", "rlds", "--input", path("raw", "wm_tabletop", "1.0.0"),
               "--split", split, "--output", path("shards", split), "--threads", 1)
        # Without the anchor decoder: a barely trained anchored tokenizer decodes nearly any
        # tokens to its anchor, and the frames of different policies would look alike.
        config = derived_config("tokenizer", path("tokenizer.yaml"), UNANCHORED_TOKENIZER)
        ok("wm-tokenize", "train", "--config", config, "--data", path("shards", "train"),
           "--out", path("tok"), "--steps", 20, "--threads", 1)
        for split in ("train", "val"):
            ok("wm-tokenize", "encode", "--checkpoint", path("tok"), "--data",
               path("shards", split), "--out", path("tokens", split), "--threads", 1)
        ok("wm-train", "--config", os.path.join(SRC, "configs", "dynamics", "tiny.yaml"),
           "--tokens", path("tokens", "train"), "--out", path("dyn"), "--steps", 10,
           "--threads", 1)
        cls.truth = write_truth(path("policy_values.json"))
        for out in ("run", "rerun"):
            ok("wm-eval", *cls.args(path(out), recorders(path(out + "_seen"))))
        cls.report = path("run", "dyn")

    def test_policy_sees_real_start_then_decoded_imagined_frames(self):
        shards = wmshard.Dataset(self.path("shards", "val"))
        tokens = wmshard.TokenDataset(self.path("tokens", "val"))
        episodes = {int(r["episode"]): r for r in read_rows(
            os.path.join(self.report, "wm_episodes.csv")) if r["policy"] == "plus"}
        for k in range(EPISODES):
            meta = tokens.index["episodes"][k]
            _, _, blobs = shards.episode(meta["source_episode"])
            real = cv2.cvtColor(cv2.imdecode(np.frombuffer(blobs["image"][0], np.uint8),
                                             cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)
            strip = cv2.imread(os.path.join(self.report, "strips", f"episode_{k}.png"))
            seen = self.path("run_seen", "plus")
            np.testing.assert_array_equal(np.load(os.path.join(seen, f"{k}_0.npy")), real)
            steps = int(episodes[k]["steps"])
            self.assertGreaterEqual(steps, 2)  # at least one imagined frame shown
            for t in range(1, steps):  # strip rows: real (logged), minus, plus (name order)
                np.testing.assert_array_equal(np.load(os.path.join(seen, f"{k}_{t}.npy")),
                                              strip_cell(strip, 2, t), f"episode {k} step {t}")
            self.assertFalse(os.path.exists(os.path.join(seen, f"{k}_{steps}.npy")))

    def test_policy_is_reset_with_the_simulators_seed(self):
        tokens = wmshard.TokenDataset(self.path("tokens", "val"))
        with open(self.path("run_seen", "plus", "resets.txt"), encoding="utf-8") as f:
            resets = [line.split(" ", 2) for line in f.read().splitlines()]
        self.assertEqual(len(resets), EPISODES)
        for episode, seed, instruction in resets:
            meta = tokens.index["episodes"][int(episode)]
            self.assertEqual(int(seed), mix_bits(meta["episode_seed"] ^ 0x706F6C696379) >> 1)
            self.assertEqual(instruction, meta["language_instruction"])

    def test_actions_reach_the_model(self):
        rows = read_rows(os.path.join(self.report, "wm_episodes.csv"))
        returns = {(r["policy"], r["episode"]): r["return"] for r in rows}
        for k in range(EPISODES):
            self.assertNotEqual(returns[("plus", str(k))], returns[("minus", str(k))])

    def test_wpe_outputs(self):
        summary = read_json(os.path.join(self.report, "wpe_summary.json"))
        with open(os.path.join(SRC, "schemas", "wpe-summary.schema.json"), encoding="utf-8") as f:
            jsonschema.validate(summary, json.load(f))
        self.assertEqual(summary["policies"], ["plus", "minus"])
        self.assertEqual(summary["num_in_distribution"], 1)
        rows = read_rows(os.path.join(self.report, "wpe.csv"))
        values = {r["policy"]: r for r in read_rows(os.path.join(self.report, "wm_values.csv"))}
        for r in rows:
            self.assertEqual(float(r["wm_value"]), float(values[r["policy"]]["wm_value"]))
            self.assertAlmostEqual(float(r["gap"]), float(r["wm_value"]) - float(r["true_value"]))
        self.assertEqual([r["true_value"] for r in rows], ["0.7", "0.2"])
        self.assertEqual([r["wm_episodes"] for r in rows], [str(EPISODES)] * 2)
        manifest = read_json(os.path.join(self.report, "manifest.json"))
        self.assertEqual(manifest["config"]["policy_eval"]["horizon"], HORIZON)

    def test_failing_policy_names_policy_episode_step_and_leaves_no_report(self):
        cases = [("crash", [], "exited with status 3"),
                 ("hang", ["--policy-timeout", 1], "did not answer within 1 s"),
                 ("malformed", [], "not JSON")]
        for bad, extra, problem in cases:
            with self.subTest(bad=bad):
                out = self.path("bad_" + bad)
                shutil.copytree(self.path("run"), out)  # an earlier good report
                p = subprocess.run(
                    [os.path.join(BIN, "wm-eval"), *map(str, self.args(
                        out, ["--policy", f"bad={ECHO} --bad {bad} --at 2", *extra]))],
                    capture_output=True, text=True)
                self.assertEqual(p.returncode, 1, p.stderr)
                self.assertIn("policy 'bad', episode 0, step 2", p.stderr)
                self.assertIn(problem, p.stderr)
                for f in FINISHED:
                    self.assertFalse(os.path.exists(os.path.join(out, "dyn", f)), f)


if __name__ == "__main__":
    unittest.main()
