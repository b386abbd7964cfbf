#!/usr/bin/python3
"""A full disk (RLIMIT_FSIZE: writes past the limit fail with EFBIG, as with ENOSPC) and a
read-only output directory, for wm-ingest, wm-tokenize train / encode, wm-train and wm-eval.
Each must exit 1 with an error naming the file or directory it could not write, leave no output
that a reader accepts as complete, and leave what was already there (finished shards, the last
checkpoint, an earlier report) byte-identical; after the fault, the ordinary rerun / --resume
reaches the uninterrupted run's bytes. As root, which ignores permission bits, the read-only runs
switch to the user nobody (skipped where that is impossible)."""
import json
import os
import sys
import tempfile
import unittest

import cv2

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import fault_harness as fh  # noqa: E402
from fault_harness import DYNAMICS, EVAL_OPTIONS, INGEST_OPTIONS, TOKENIZER, WMSHARD  # noqa: E402
from tiny_pipeline import argv  # noqa: E402


class DiskFullAndReadOnly(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory(prefix="wmkit-faults-")
        os.chmod(cls.tmp.name, 0o755)  # the read-only runs may be another user
        cls.pipe = fh.tiny_pipeline(cls.tmp.name)
        cls.pipe.shards("val")
        cls.made = {}

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def assert_fails_naming(self, p, name):
        """Exit 1, and the error (the last stderr line) names `name`."""
        self.assertEqual(p.returncode, 1, p.stderr)
        lines = p.stderr.strip().splitlines()
        self.assertTrue(lines and name in lines[-1], f"no '{name}' in the error:\n{p.stderr}")

    def made_once(self, name, command):
        """`command(path)` run once into a fixed path (cached for the other tests)."""
        if name not in self.made:
            self.made[name] = self.pipe.path("made", name)
            fh.run_ok(command(self.made[name]))
        return self.made[name]

    def partial_run(self, kind, out):
        """A trainer run stopped (--stop-after) at its first checkpoint, copied to `out`."""
        spec, command = {"tokenizer": (TOKENIZER, self.pipe.tokenizer_argv),
                         "dynamics": (DYNAMICS, self.pipe.dynamics_argv)}[kind]
        made = self.made_once(kind, lambda path: command(path, "--stop-after", spec["every"]))
        return fh.copy_tree(made, out), command

    def previous_report(self, out):
        """A complete wm-eval REPORT_DIR (report `dyn`), copied to `out`."""
        made = self.made_once("report", lambda path: self.pipe.eval_argv(path, *EVAL_OPTIONS))
        return fh.copy_tree(made, out)

    # Disk full.

    def test_wm_ingest_disk_full_keeps_finished_shards(self):
        ref = self.pipe.path("ingest-ref")
        fh.run_ok(self.pipe.ingest_argv("train", ref, *INGEST_OPTIONS))
        out = self.pipe.path("ingest-full")
        command = self.pipe.ingest_argv("train", out, *INGEST_OPTIONS)
        # Three episodes in, killed by the ingest's own fault hook (pipeline.cc), as a crash.
        p = fh.run(command, env=dict(os.environ, WMKIT_FAULT_KILL_AFTER="3"))
        self.assertEqual(p.returncode, -9, p.stderr)
        finished = fh.tree(out)
        self.assertTrue(finished, "finished shards to keep")
        smallest = min(os.path.getsize(os.path.join(ref, f)) for f in fh.tree(ref))
        p = fh.run(command, preexec_fn=fh.with_file_size_limit(smallest // 2))
        self.assert_fails_naming(p, ".wms")
        self.assertEqual(fh.tree(out), finished)
        self.assertEqual(fh.run(argv("wm-shard", "verify", out)).returncode, 1)
        fh.run_ok(command)
        self.assertEqual(fh.tree(out), fh.tree(ref))

    def test_wm_tokenize_encode_disk_full_writes_no_token_dataset(self):
        out = self.pipe.path("encode-full")
        command = self.pipe.encode_argv("train", out)
        p = fh.run(command, preexec_fn=fh.with_file_size_limit(4096))
        self.assert_fails_naming(p, "part-00000.wmtok")
        self.assertEqual(fh.tree(out), {})
        self.assertEqual(fh.run([*WMSHARD, "--tokens", out, "--verify"]).returncode, 1)
        fh.run_ok(command)
        self.assertEqual(fh.tree(out), fh.tree(self.pipe.tokens("train")))

    def assert_trainer_keeps_checkpoint_when_disk_full(self, kind, ref, spec, limit):
        out, command = self.partial_run(kind, self.pipe.path(f"{kind}-full"))
        before = fh.tree(out)
        p = fh.run(command(out, "--resume"), preexec_fn=fh.with_file_size_limit(limit))
        self.assert_fails_naming(p, "checkpoint.wmt")
        after = fh.tree(out)
        for f in ("checkpoint.wmt", "checkpoint.json"):
            self.assertEqual(after[f], before[f], f)
        self.assertEqual(fh.hidden_files(out), [], "temp files removed after the failed write")
        fh.run_ok(command(out, "--resume"))
        self.assertEqual(fh.run_dir_state(out, spec), fh.run_dir_state(ref, spec))

    def test_wm_tokenize_train_disk_full_keeps_last_checkpoint(self):
        self.assert_trainer_keeps_checkpoint_when_disk_full(
            "tokenizer", self.pipe.tokenizer(), TOKENIZER, 1 << 20)  # checkpoint: ~2.7 MB

    def test_wm_train_disk_full_keeps_last_checkpoint(self):
        self.assert_trainer_keeps_checkpoint_when_disk_full(
            "dynamics", self.pipe.dynamics(), DYNAMICS, 4 << 20)  # checkpoint: ~18 MB

    def assert_report_refused(self, report, out):
        p = fh.run(argv("wm-report", "compare", report, "--out", out + "-compare.csv"))
        self.assertEqual(p.returncode, 1, f"wm-report accepted {report}")
        self.assertIn(report, p.stderr)

    def test_wm_eval_disk_full_writes_no_report(self):
        """Videos (~30 KB each) do not fit: wm-eval must say so, not report success."""
        out = self.pipe.path("eval-full")
        p = fh.run(self.pipe.eval_argv(out, *EVAL_OPTIONS),
                   preexec_fn=fh.with_file_size_limit(8192))
        self.assert_fails_naming(p, "episode_0.mp4")
        self.assertEqual(fh.tree(out), {})
        self.assert_report_refused(os.path.join(out, "dyn"), out)

    def test_wm_eval_disk_full_never_leaves_a_mixed_report(self):
        """A re-evaluation (another seed) into an existing report, where summary.csv fits and
        per_step.csv does not: the previous report stays whole, or is refused by wm-report
        (wm-eval removes manifest.json first and writes it last); never old and new files that
        read as one report."""
        out = self.previous_report(self.pipe.path("eval-previous"))
        report = os.path.join(out, "dyn")
        before = fh.tree(report)
        small, large = (os.path.getsize(os.path.join(report, f))
                        for f in ("summary.csv", "per_step.csv"))
        self.assertLess(small + 64, large, "the limit must fall between the two files")
        command = self.pipe.eval_argv(out, *EVAL_OPTIONS, "--seed", 1, "--videos", 0,
                                      "--strips", 0)
        p = fh.run(command, preexec_fn=fh.with_file_size_limit((small + large) // 2))
        self.assert_fails_naming(p, "per_step.csv")
        if fh.tree(report) != before:
            self.assert_report_refused(report, out)
        fh.run_ok(command)
        fh.run_ok(argv("wm-report", "compare", report, "--out", out + "-compare.csv"))

    def test_wm_tokenize_decode_disk_full_writes_no_video(self):
        out = self.pipe.path("decode-full")
        os.makedirs(out)
        video = os.path.join(out, "episode_0.mp4")
        command = argv("wm-tokenize", "decode", "--checkpoint", self.pipe.tokenizer(), "--tokens",
                       self.pipe.tokens("val"), "--episode", 0, "--out", video)
        p = fh.run(command, preexec_fn=fh.with_file_size_limit(200))  # below any MP4 of 1+ frames
        self.assert_fails_naming(p, video)
        self.assertEqual(os.listdir(out), [])
        fh.run_ok(command)  # without the limit: the whole video, under its name only
        self.assertEqual(os.listdir(out), ["episode_0.mp4"])
        with open(self.pipe.path("tokens", "val", "index.json"), encoding="utf-8") as f:
            frames = json.load(f)["episodes"][0]["num_frames"]
        capture = cv2.VideoCapture(video)
        self.assertEqual(sum(1 for _ in iter(lambda: capture.read()[0], False)), frames)

    # Read-only output directories.

    def assert_read_only_run_fails(self, out, command, name):
        runner, why = fh.read_only_runner(command[0])
        if runner is None:
            self.skipTest(why)
        before = fh.tree(out)
        fh.set_tree_mode(out, 0o555, 0o444)
        try:
            p = fh.run(command, **runner)
        finally:
            fh.set_tree_mode(out, 0o755, 0o644)
        self.assert_fails_naming(p, name)
        self.assertEqual(fh.tree(out), before)
        self.assertEqual(fh.hidden_files(out), [])

    def test_read_only_output_directories(self):
        cases = {"wm-ingest": lambda out: (self.pipe.ingest_argv("train", out), out),
                 "wm-tokenize encode": lambda out: (self.pipe.encode_argv("train", out), out)}
        for kind in ("tokenizer", "dynamics"):
            def resume(out, kind=kind):
                run, command = self.partial_run(kind, out)
                return command(run, "--resume"), os.path.join(run, "metrics.csv")
            cases[kind] = resume

        cases["wm-eval"] = lambda out: (self.pipe.eval_argv(self.previous_report(out),
                                                            *EVAL_OPTIONS), out)
        for name, prepare in cases.items():
            with self.subTest(tool=name):
                out = self.pipe.path("read-only", name.replace(" ", "-"))
                os.makedirs(out, exist_ok=True)
                command, named = prepare(out)
                self.assert_read_only_run_fails(out, command, os.path.basename(named))


if __name__ == "__main__":
    unittest.main(verbosity=2)
