#!/usr/bin/python3
"""`make ablation` on a reduced configuration (a few training steps, 2 episodes per split): the
full chain writes ablation.csv with every column, finite values inside their intervals for the
pixel metrics, the findings table and the plot; every variant's rollouts were given the plain
window and WHALE's retrace action (eq. 6) exactly as computed here by hand; a rerun skips every
finished stage and gives the same ablation.csv bytes."""
import csv
import math
import os
import subprocess
import sys
import tempfile
import unittest

import numpy as np
import yaml

SRC = os.environ.get("WM_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
BIN = os.environ.get("WM_BIN_DIR", os.path.join(SRC, "build", "bin"))
SCRIPT = os.path.join(SRC, "scripts", "ablation.py")
METRICS = ["fvd_style", "psnr", "ssim", "lpips_style", "mse_arm", "mse_object",
           "mse_background", "value_gap", "spearman"]
EPISODES = 2
sys.path.insert(0, os.path.join(SRC, "scripts"))
import wmshard  # noqa: E402  (the independent Python reader of token datasets)


def retrace_action(actions):
    """WHALE eq. 6 by hand: dims 0-5 summed in float32 in order, dim 6 of the last action."""
    out = np.zeros(7, np.float32)
    for a in actions:
        out[:6] = (out[:6] + a[:6]).astype(np.float32)
    out[6] = actions[-1][6]
    return out


def expected_context(actions, t, context, rollout):
    """(frame, action) slots predicting frame t+1: the plain window t-C+1..t, or once it has
    passed frame 0 (t >= C), frame 0 with the retrace of a_0..a_{t-C+1} then frames t-C+2..t."""
    if rollout == "retrace" and t >= context:
        return [(0, retrace_action(actions[:t - context + 2]))] + [
            (f, actions[f]) for f in range(t - context + 2, t + 1)]
    return [(f, actions[f]) for f in range(max(0, t - context + 1), t + 1)]


def reduced_config(path):
    with open(os.path.join(SRC, "configs", "ablation", "tiny.yaml"), encoding="utf-8") as f:
        cfg = yaml.safe_load(f)
    cfg["data"].update(train_episodes=4, eval_episodes=EPISODES)
    cfg["tokenizer"]["steps"] = 5
    cfg["dynamics"].update(steps=3, threads=1)
    cfg["eval"].update(horizon=8, resamples=50)  # 8 > the 6-frame context: retracing differs
    with open(path, "w", encoding="utf-8") as f:
        yaml.safe_dump(cfg, f)


class AblationTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.out = os.path.join(cls.tmp.name, "ablation")
        cls.config = os.path.join(cls.tmp.name, "reduced.yaml")
        reduced_config(cls.config)
        cls.first = cls.run_ablation()
        with open(os.path.join(cls.out, "ablation.csv"), "rb") as f:
            cls.csv_bytes = f.read()
        cls.rows = list(csv.DictReader(cls.csv_bytes.decode().splitlines()))

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    @classmethod
    def run_ablation(cls):
        p = subprocess.run(["/usr/bin/python3", SCRIPT, "--bin", BIN, "--config", cls.config,
                            "--out", cls.out], cwd=SRC, capture_output=True, text=True)
        assert p.returncode == 0, p.stdout + p.stderr
        return p.stdout

    def test_every_variant_split_and_rollout_has_a_row_with_every_column(self):
        header = ["variant", "split", "rollout", "n_episodes"]
        for m in METRICS:
            header += [m, m + "_ci_low", m + "_ci_high"]
        self.assertEqual(list(self.rows[0].keys()), header)
        keys = {(r["variant"], r["split"], r["rollout"]) for r in self.rows}
        for v in ["policy", "no_policy"]:
            for s in ["seen", "unseen"]:
                for r in ["plain", "retrace", "copy_last", "tokenizer_recon"]:
                    self.assertIn((v, s, r), keys)
        self.assertEqual(len(self.rows), 16)

    def test_pixel_metrics_are_finite_and_inside_their_intervals(self):
        for row in self.rows:
            self.assertEqual(int(row["n_episodes"]), EPISODES)
            for m in ["psnr", "ssim", "lpips_style", "mse_arm", "mse_background"]:
                mean, lo, hi = (float(row[m + s]) for s in ["", "_ci_low", "_ci_high"])
                self.assertTrue(all(map(math.isfinite, (mean, lo, hi))), (row, m))
                self.assertLessEqual(lo, mean + 1e-12)
                self.assertLessEqual(mean, hi + 1e-12)
            self.assertTrue(math.isfinite(float(row["fvd_style"])))
            self.assertEqual(row["fvd_style_ci_low"], "")  # one value per clip set, no interval

    def test_retracing_differs_from_plain_past_the_context(self):
        by_key = {(r["variant"], r["split"], r["rollout"]): r for r in self.rows}
        for v in ["policy", "no_policy"]:
            plain, retrace = by_key[(v, "seen", "plain")], by_key[(v, "seen", "retrace")]
            self.assertNotEqual(plain["psnr"], retrace["psnr"])

    def test_each_variants_contexts_equal_hand_computed_plain_and_retrace(self):
        with open(os.path.join(SRC, "configs", "dynamics", "tiny.yaml"), encoding="utf-8") as f:
            context = yaml.safe_load(f)["model"]["context_frames"] - 1  # wm-eval's default
        retraced = 0
        for split in ["seen", "unseen"]:
            tokens = wmshard.TokenDataset(os.path.join(self.out, "tokens", split))
            for variant in ["policy", "no_policy"]:
                path = os.path.join(self.out, "reports", split, variant, "contexts.csv")
                with open(path, encoding="utf-8") as f:
                    rows = list(csv.DictReader(f))
                for rollout in ["plain", "retrace"]:
                    for k in range(EPISODES):
                        actions = np.asarray(tokens.episode(k)["actions"], np.float32)
                        mine = [r for r in rows if r["rollout"] == rollout and int(r["episode"]) == k]
                        steps = sorted({int(r["step"]) for r in mine})
                        self.assertEqual(steps, list(range(1, len(steps) + 1)), path)
                        for step in steps:
                            got = [(int(r["frame"]), np.float32([r[f"a{d}"] for d in range(7)]))
                                   for r in mine if int(r["step"]) == step]
                            want = expected_context(actions, step - 1, context, rollout)
                            what = f"{path}: {rollout} episode {k} step {step}"
                            self.assertEqual([g[0] for g in got], [w[0] for w in want], what)
                            for (_, a), (_, b) in zip(got, want):
                                np.testing.assert_array_equal(a, b, what)
                            retraced += rollout == "retrace" and step - 1 >= context
        self.assertGreater(retraced, 0, "no step past the context: retracing was not exercised")

    def test_findings_name_every_direction(self):
        with open(os.path.join(self.out, "ablation.md"), encoding="utf-8") as f:
            text = f.read()
        self.assertEqual(text.count("| retracing lowers fvd_style |"), 4)
        self.assertEqual(text.count("| retracing lowers value_gap |"), 4)
        self.assertEqual(text.count("| policy conditioning lowers value_gap |"), 4)
        self.assertGreater(os.path.getsize(os.path.join(self.out, "ablation_horizon.png")), 1000)

    def test_rerun_skips_finished_work_and_gives_the_same_bytes(self):
        second = self.run_ablation()
        commands = [line for line in second.splitlines() if line.startswith("+ ")]
        for tool in ["wm-gen-tabletop", "wm-ingest", "wm-eval"]:  # their outputs exist
            self.assertFalse([c for c in commands if f"/{tool} " in c], tool)
        trains = [c for c in commands if "/wm-train " in c or "/wm-tokenize train " in c]
        self.assertEqual(len(trains), 3)
        self.assertTrue(all("--resume" in c for c in trains), trains)  # finished: no-ops
        with open(os.path.join(self.out, "ablation.csv"), "rb") as f:
            self.assertEqual(f.read(), self.csv_bytes)


if __name__ == "__main__":
    unittest.main()
