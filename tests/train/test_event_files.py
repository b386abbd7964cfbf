#!/usr/bin/python3
"""wm-train's and wm-tokenize's TensorBoard event files, read with scripts/tfevents.py (TFRecord framing with masked
CRC32C and a hand-written protobuf decoder, no TensorBoard): one file_version event, then one event
per metrics.csv row with the same step and, per non-empty cell, the tag "metrics/<column>" and the
cell's value as float32 (validation columns only at validation steps). A run stopped and resumed
rewrites the same file and ends with the events of an uninterrupted run. The tokenizer's
validation images (originals over reconstructions, one PNG per validation step) decode to the
frames val.csv scored: their PSNR is val.csv's; a resumed run ends with the same images."""
import csv
import os
import subprocess
import sys
import tempfile
import time
import unittest

import cv2
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SRC = os.environ.get("WM_SOURCE_DIR", os.path.join(HERE, "..", ".."))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(SRC, "scripts"))
import test_wm_train_cli  # noqa: E402  (its tiny config)
import tfevents  # noqa: E402

sys.path.insert(0, os.path.join(SRC, "tests"))
import tiny_pipeline  # noqa: E402

BIN = os.environ.get("WM_BIN_DIR", "build/bin")
EVENTS = "events.out.tfevents.metrics"
TIMING = "metrics/tokens_per_s"  # wall-clock throughput: differs between identical runs


def expected_scalars(run_dir):
    """[(step, {tag: float32 value})] of metrics.csv, empty cells left out."""
    with open(os.path.join(run_dir, "metrics.csv"), newline="") as f:
        rows = list(csv.DictReader(f))
    return [(int(r["step"]), {"metrics/" + k: float(np.float32(v)) for k, v in r.items()
                              if k != "step" and v != ""}) for r in rows]


def logged_scalars(run_dir):
    events = tfevents.read_events(os.path.join(run_dir, EVENTS))
    assert events[0]["file_version"] == tfevents.FILE_VERSION, events[0]
    assert all(e["file_version"] is None for e in events[1:]), "one file_version event"
    now = time.time()
    assert all(now - 3600 < e["wall_time"] <= now + 1 for e in events), "wall_time in seconds"
    return [(e["step"], e["scalars"]) for e in events[1:]]


def without_timing(scalars):
    return [(step, {k: v for k, v in s.items() if k != TIMING}) for step, s in scalars]


class EventFiles(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.tokens, cls.cfg = cls.path("tokens"), cls.path("cfg.yaml")
        subprocess.run([os.path.join(BIN, "dynamics_test_tool"), "make-tokens", "--out",
                        cls.tokens, "--episodes", "6", "--steps", "8", "--grid", "4", "--codes",
                        "32"], check=True, capture_output=True)
        config = test_wm_train_cli.CONFIG.replace(
            "checkpoint_every: 30", "checkpoint_every: 3, val_every: 2, val_batches: 1")
        with open(cls.cfg, "w") as f:
            f.write(config)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    @classmethod
    def path(cls, name):
        return os.path.join(cls.tmp.name, name)

    def train(self, run_dir, *flags):
        r = subprocess.run([os.path.join(BIN, "wm-train"), "--config", self.cfg, "--tokens",
                            self.tokens, "--val-tokens", self.tokens, "--out", run_dir,
                            "--steps", "6", *flags], capture_output=True, text=True)
        self.assertEqual(r.returncode, 0, r.stderr)

    def test_events_equal_metrics_csv(self):
        run = self.path("full")
        self.train(run)
        logged, expected = logged_scalars(run), expected_scalars(run)
        self.assertEqual([s for s, _ in logged], list(range(1, 7)))
        self.assertEqual(logged, expected)
        self.assertIn("metrics/val_token_acc", logged[1][1], "validation at step 2")
        self.assertNotIn("metrics/val_token_acc", logged[0][1], "no validation at step 1")
        self.assertEqual([f for f in os.listdir(run) if "tfevents" in f], [EVENTS])

    def test_resumed_run_rewrites_the_same_file(self):
        full, resumed = self.path("full2"), self.path("resumed")
        self.train(full)
        self.train(resumed, "--stop-after", "4")  # a checkpoint at step 4, then the rest
        self.train(resumed, "--resume")
        self.assertEqual(without_timing(logged_scalars(resumed)),
                         without_timing(logged_scalars(full)))
        self.assertEqual(logged_scalars(resumed), expected_scalars(resumed))


class TokenizerImages(unittest.TestCase):
    """wm-tokenize train --val-data: events.out.tfevents.val_images."""
    SIZE, FRAMES = 64, 8  # val_frames = the sheet's 8 columns: the sheet holds every scored frame

    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.pipe = tiny_pipeline.TinyPipeline(
            cls.tmp.name, train_episodes=2, val_episodes=2, tokenizer_steps=4, dynamics_steps=1,
            max_steps=6, validate=True,
            tokenizer_train={"val_every": 2, "val_frames": cls.FRAMES, "checkpoint_every": 2})

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def images(self, run_dir):
        events = tfevents.read_events(os.path.join(run_dir, "events.out.tfevents.val_images"))
        self.assertEqual(events[0]["file_version"], tfevents.FILE_VERSION)
        return [(e["step"], e["images"]) for e in events[1:]]

    def test_one_sheet_per_validation_step_scored_as_val_csv(self):
        run = self.pipe.tokenizer()
        with open(os.path.join(run, "val.csv"), newline="") as f:
            rows = list(csv.DictReader(f))
        images = self.images(run)
        self.assertEqual([s for s, _ in images], [int(r["step"]) for r in rows])
        for (step, tags), row in zip(images, rows):
            self.assertEqual(list(tags), ["val/reconstructions"])
            image = tags["val/reconstructions"]
            self.assertEqual((image["height"], image["width"], image["colorspace"]),
                             (2 * self.SIZE, self.FRAMES * self.SIZE, 3))
            sheet = cv2.imdecode(np.frombuffer(image["png"], np.uint8), cv2.IMREAD_COLOR)
            self.assertEqual(sheet.shape, (2 * self.SIZE, self.FRAMES * self.SIZE, 3))
            top, bottom = sheet[:self.SIZE].astype(float), sheet[self.SIZE:].astype(float)
            psnr = [10 * np.log10(255.0 ** 2 / np.mean((t - b) ** 2))
                    for t, b in zip(np.split(top, self.FRAMES, 1), np.split(bottom, self.FRAMES, 1))]
            self.assertAlmostEqual(np.mean(psnr), float(row["psnr"]), places=3, msg=f"step {step}")

    def test_resumed_run_ends_with_the_same_images(self):
        full = self.pipe.tokenizer()
        resumed = self.pipe.path("tok_resumed")
        tiny_pipeline.run_ok(self.pipe.tokenizer_argv(resumed, "--stop-after", 2))
        tiny_pipeline.run_ok(self.pipe.tokenizer_argv(resumed, "--resume"))
        self.assertEqual(self.images(resumed), self.images(full))


if __name__ == "__main__":
    unittest.main()
