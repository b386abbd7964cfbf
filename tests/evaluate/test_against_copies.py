#!/usr/bin/python3
"""End to end on tiny tabletop data: a world model trained here by the built tools (wm-gen-tabletop
--look plain -> wm-ingest -> wm-tokenize -> wm-train, the tiny presets: the anchor-decoder
tokenizer, the next-frame objective with the copy prior) against the copy baselines on the val
split, scored by wm-eval in the same run:
  - the tokenizer keeps what the task is about (issue 20, goal 1, small version): over 8 steps
    decoded with the real first frame as anchor, tokenizer_recon's arm- and object-region MSE are
    well below copy_last's (the anchor keeps the block that 8x8 codes cannot draw);
  - at horizon 1 the model is no worse than copying the last frame's tokens (copy_last_tokens)
    or its pixels (copy_last), and below the tokenizer's ceiling.

What this does not show: motion. With the anchor decoder copy_last_tokens decodes to nearly
copy_last itself, and the model scores the same as both: it still copies (issue 20, goal 2);
the strips of `make demo` show it. The margin over copy_last that an earlier test asserted came
from the old tokenizer's smoothing, not from motion, and is gone.
Sized for CI: about 2.1 min on 2 cores (PROCESSORS 2 in CMakeLists.txt)."""
import csv
import os
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from tiny_pipeline import CONFIGS, SRC, TinyPipeline, argv, run_ok  # noqa: E402

# The copy prior starts the model at copy_last_tokens and 300 steps left it there to the last
# decimal (+0.000 dB at horizon 1). What is asserted is that training does not push it below:
# 100 steps (the warm-up and 50 at the peak rate) check that at a third of the time.
DYNAMICS_STEPS = 100
VAL_EPISODES = 16
DECODED_EPISODES = 4  # cross-checked against wm-tokenize decode


def step1_psnr(report):
    """rollout -> {episode: PSNR at horizon step 1} from per_episode.csv (--horizon 1, so the
    per-episode mean is the step-1 value)."""
    out = {}
    with open(os.path.join(report, "per_episode.csv"), newline="", encoding="utf-8") as f:
        for row in csv.DictReader(f):
            if row["metric"] == "psnr":
                out.setdefault(row["rollout"], {})[int(row["episode"])] = float(row["value"])
    return out


def decoded_step1_psnr(p, episodes):
    """{rollout: {episode: PSNR at step 1}} for tokenizer_recon and copy_last_tokens, from
    `wm-tokenize decode --originals` (every frame decoded with the first original as anchor, its
    own code path) and the real frames read with wmshard.py: what wm-eval must report."""
    sys.path.insert(0, os.path.join(SRC, "scripts"))
    import cv2
    import numpy as np
    import wmshard
    tokens, shards = wmshard.TokenDataset(p.tokens("val")), wmshard.Dataset(p.shards("val"))
    out = {"tokenizer_recon": {}, "copy_last_tokens": {}}
    for k in range(episodes):
        d = p.path("decoded", str(k))
        run_ok(argv("wm-tokenize", "decode", "--checkpoint", p.tokenizer(), "--tokens",
                    p.tokens("val"), "--originals", p.shards("val"), "--episode", k, "--out", d))
        frame = lambda t: cv2.imread(os.path.join(d, f"frame_{t:04d}.png")).astype(np.float64)
        source = tokens.index["episodes"][k]["source_episode"]
        real = cv2.imdecode(np.frombuffer(shards.episode(source)[2]["image"][1], np.uint8),
                            cv2.IMREAD_COLOR).astype(np.float64)  # 64x64: no resize
        for rollout, t in (("tokenizer_recon", 1), ("copy_last_tokens", 0)):
            mse = ((real - frame(t)) ** 2).mean()
            out[rollout][k] = 10 * np.log10(255.0 ** 2 / mse)
    return out


def summary_means(report):
    """{(rollout, metric): mean} from summary.csv (metrics without a value left out)."""
    with open(os.path.join(report, "summary.csv"), newline="", encoding="utf-8") as f:
        return {(r["rollout"], r["metric"]): float(r["mean"]) for r in csv.DictReader(f)
                if r["mean"]}


def mean(values):
    return sum(values) / len(values)


class AgainstCopies(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory(prefix="wm-beats-copy-last-")
        # Context 2: horizon 1 starts from one real frame, so longer training windows would
        # only cost time (2.8x the steps/s of the preset's 6 frames).
        p = TinyPipeline(cls.tmp.name, train_episodes=80, val_episodes=VAL_EPISODES,
                         look="plain", tokenizer_steps=1200, dynamics_steps=DYNAMICS_STEPS,
                         dynamics_model={"context_frames": 2}, tokenizer_threads=2,
                         dynamics_threads=2)
        final = p.path("final")
        run_ok(p.dynamics_argv(final))
        reports = p.path("reports")
        run_ok(p.eval_argv(reports, "--horizon", 1, "--rollout", "plain", "--temperature", 0,
                           "--videos", 0, "--strips", 0, "--controllability", "off",
                           "--resamples", 100, checkpoints=[final]))
        cls.final = step1_psnr(os.path.join(reports, "final"))
        regions = p.path("regions")
        run_ok(p.eval_argv(regions, "--horizon", 8, "--rollout", "plain", "--temperature", 0,
                           "--videos", 0, "--strips", 0, "--controllability", "off",
                           "--resamples", 100, "--masks", "files", "--seg-config",
                           os.path.join(CONFIGS, "segmentation", "tabletop.yaml"),
                           checkpoints=[final]))
        cls.regions = summary_means(os.path.join(regions, "final"))
        cls.decoded = decoded_step1_psnr(p, DECODED_EPISODES)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_every_val_episode_is_scored(self):
        for rollout in ("plain", "copy_last", "copy_last_tokens", "tokenizer_recon"):
            self.assertEqual(sorted(self.final[rollout]), list(range(VAL_EPISODES)), rollout)

    def test_wm_eval_decodes_with_the_first_frame_as_anchor(self):
        for rollout, decoded in self.decoded.items():
            for k, psnr in decoded.items():
                self.assertAlmostEqual(self.final[rollout][k], psnr, delta=1e-3,
                                       msg=f"{rollout} episode {k}")

    def test_tokenizer_keeps_the_arm_and_the_block(self):
        ratio = {region: self.regions["tokenizer_recon", region] /
                 self.regions["copy_last", region] for region in ("mse_arm", "mse_object")}
        print(f"8 steps, tokenizer_recon / copy_last region MSE: arm {ratio['mse_arm']:.2f}, "
              f"block {ratio['mse_object']:.2f}")
        # Measured here 0.30 / 0.61 (80 episodes, 1200 tokenizer steps on 2 threads); in the
        # demo 0.36 / 0.54 and 0.22 / 0.45 for two initialisations. Without the anchor the same
        # 8x8 tokens give about 0.22 / 2.6 (the block erased); at anchor dropout 0 the codes
        # collapse (0.96 / 1.0). The bounds leave room for another CPU's rounding, which acts
        # like another seed.
        self.assertLess(ratio["mse_arm"], 0.5)
        self.assertLess(ratio["mse_object"], 0.9)

    def test_trained_model_is_no_worse_than_copy_last(self):
        model, copy = self.final["plain"], self.final["copy_last"]
        gain = mean([model[e] - copy[e] for e in copy])
        print(f"horizon 1 PSNR: model {mean(model.values()):.2f} dB, copy_last "
              f"{mean(copy.values()):.2f} dB, ceiling "
              f"{mean(self.final['tokenizer_recon'].values()):.2f} dB")
        self.assertGreater(gain, -0.05)

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
