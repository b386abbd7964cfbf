#!/usr/bin/python3
"""End to end on tiny tabletop data: a world model trained here by the built tools (wm-gen-tabletop
--look plain -> wm-ingest -> wm-tokenize -> wm-train, the tiny preset: next-frame objective with
the copy prior) against the two copy baselines at horizon 1 on the val split, scored by wm-eval
in the same run: it is no worse than copying the last frame's tokens (copy_last_tokens), and it
beats copying the last frame's pixels (copy_last) in PSNR.

What this does not show: motion. copy_last_tokens, the tokenizer's picture of the last frame,
scores the same PSNR as the model here, so the margin over copy_last is the tokenizer's smoothing
(issue 20), not predicted motion; the strips of `make demo` show the frozen arm. The test guards
against falling below copying; a model that moves will have to earn a stronger one.

The plain look (one untextured table and light) is what makes this affordable: on the demo's
varied textures the 8x8-token tokenizer's own error (23.9 dB ceiling) is as large as the arm's
motion between frames and a CPU-sized model does not beat copy-last (README, "Known limits").
Sized for CI: about 2.5 min on 2 cores (PROCESSORS 2 in CMakeLists.txt)."""
import csv
import os
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from tiny_pipeline import TinyPipeline, run_ok  # noqa: E402

DYNAMICS_STEPS = 300
VAL_EPISODES = 16


def step1_psnr(report):
    """rollout -> {episode: PSNR at horizon step 1} from per_episode.csv (--horizon 1, so the
    per-episode mean is the step-1 value)."""
    out = {}
    with open(os.path.join(report, "per_episode.csv"), newline="", encoding="utf-8") as f:
        for row in csv.DictReader(f):
            if row["metric"] == "psnr":
                out.setdefault(row["rollout"], {})[int(row["episode"])] = float(row["value"])
    return out


def mean(values):
    return sum(values) / len(values)


class BeatsCopyLast(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory(prefix="wm-beats-copy-last-")
        # Context 2: horizon 1 starts from one real frame, so longer training windows would
        # only cost time (2.8x the steps/s of the preset's 6 frames).
        p = TinyPipeline(cls.tmp.name, train_episodes=80, val_episodes=VAL_EPISODES,
                         look="plain", tokenizer_steps=1200, dynamics_steps=DYNAMICS_STEPS,
                         dynamics_model={"context_frames": 2}, dynamics_threads=2)
        final = p.path("final")
        run_ok(p.dynamics_argv(final))
        reports = p.path("reports")
        run_ok(p.eval_argv(reports, "--horizon", 1, "--rollout", "plain", "--temperature", 0,
                           "--videos", 0, "--strips", 0, "--controllability", "off",
                           "--resamples", 100, checkpoints=[final]))
        cls.final = step1_psnr(os.path.join(reports, "final"))

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_every_val_episode_is_scored(self):
        for rollout in ("plain", "copy_last", "copy_last_tokens", "tokenizer_recon"):
            self.assertEqual(sorted(self.final[rollout]), list(range(VAL_EPISODES)), rollout)

    def test_trained_model_beats_copy_last_at_horizon_1(self):
        model, copy = self.final["plain"], self.final["copy_last"]
        gain = mean([model[e] - copy[e] for e in copy])
        better = sum(model[e] > copy[e] for e in copy)
        print(f"horizon 1 PSNR: model {mean(model.values()):.2f} dB, copy_last "
              f"{mean(copy.values()):.2f} dB, ceiling "
              f"{mean(self.final['tokenizer_recon'].values()):.2f} dB; model better on "
              f"{better} of {len(copy)} episodes")
        # Measured gains 0.49 / 0.28 / 0.51 dB (better on 14 / 13 / 14 of 16 episodes) for
        # data and training seeds 0 / 1 / 2: another CPU's float kernels change the run like
        # another seed, so the bound is the claim itself, not the margin of one run.
        self.assertGreater(gain, 0)
        self.assertGreater(better, len(copy) // 2)

    def test_trained_model_is_no_worse_than_copying_its_tokens(self):
        model, tokens = self.final["plain"], self.final["copy_last_tokens"]
        gain = mean([model[e] - tokens[e] for e in tokens])
        print(f"horizon 1 PSNR: model - copy_last_tokens = {gain:+.3f} dB")
        # The copy prior starts the model at this baseline; training must not leave it below.
        self.assertGreater(gain, -0.05)

    def test_the_tokenizer_ceiling_is_above_the_model(self):
        self.assertGreater(mean(self.final["tokenizer_recon"].values()),
                           mean(self.final["plain"].values()))


if __name__ == "__main__":
    unittest.main()
