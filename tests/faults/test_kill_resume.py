#!/usr/bin/python3
"""SIGKILL at seeded random points of wm-ingest, wm-tokenize train, wm-tokenize encode, wm-train
and wm-eval on tiny tabletop data: points in each tool's writing phase (first output file to end)
as measured on its uninterrupted run, which is the reference.
After each kill: every visible (non-hidden) output file is byte-identical to the uninterrupted
run's or an earlier state of it that loads (a checkpoint at an earlier step, a log prefix), and
the project's readers refuse an incomplete output naming the missing file. Then the documented
way to continue (rerun with the same options; `--resume` for the trainers) ends with the
uninterrupted run's bytes. Left out of the byte comparison, per the docs: hidden temp/state files
and the wall-clock throughput column of the trainers' metrics.csv."""
import json
import os
import sys
import tempfile
import time
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import fault_harness as fh  # noqa: E402
from fault_harness import DYNAMICS, EVAL_OPTIONS, INGEST_OPTIONS, TOKENIZER, WMSHARD  # noqa: E402
from tiny_pipeline import SRC, argv  # noqa: E402

sys.path.insert(0, os.path.join(SRC, "tests", "tokenize"))
from vqvae_twin import read_archive  # noqa: E402  (independent WMTENSR1 reader: length, CRC32C)

KILLS = 3  # per tool; wm-ingest, being fast, gets more


class KillAndResume(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory(prefix="wmkit-faults-")
        pipe = cls.pipe = fh.tiny_pipeline(cls.tmp.name, validate=True)
        # Each tool: its command writing to an output dir, and its uninterrupted reference run
        # (the pipeline's own output, where it has one), made here in pipeline order and timed.
        cls.tools = {
            "wm-ingest": (lambda out: pipe.ingest_argv("train", out, *INGEST_OPTIONS),
                          pipe.path("ingest")),
            "wm-tokenize-train": (pipe.tokenizer_argv, pipe.path("tok")),
            "wm-tokenize-encode": (lambda out: pipe.encode_argv("train", out),
                                   pipe.path("tokens", "train")),
            "wm-train": (pipe.dynamics_argv, pipe.path("dyn")),
            "wm-eval": (lambda out: pipe.eval_argv(out, *EVAL_OPTIONS, "--save-rollouts",
                                                   out + "-export"), pipe.path("report")),
        }
        pipe.shards("val")  # inputs made untimed: the shards; val tokens when wm-train needs them
        cls.phases = {}
        for name, (command, ref) in cls.tools.items():
            if not os.path.exists(ref):
                _, first, total = fh.watch(command(ref), ref)
                cls.phases[name] = (first, total)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def after_each_kill(self, name, check, kills=KILLS):
        """Kills the tool at each seeded point of its reference run's writing phase (from its
        first output file to its end) and calls check(killed out dir, reference, command)."""
        command, ref = self.tools[name]
        first, total = self.phases[name]
        for i, fraction in enumerate(fh.kill_fractions(name, kills)):
            out = self.pipe.path("killed", f"{name}-{i}")
            status, _, _ = fh.watch(command(out), out, fraction * (total - first))
            print(f"{name}: killed {fraction * (total - first):.2f} s after the first file "
                  f"(writing phase {total - first:.2f} s of {total:.2f} s; exit {status}): "
                  f"{sorted(fh.tree(out))}", flush=True)
            with self.subTest(tool=name, kill=i):
                check(out, ref, command)

    def assert_visible_files_complete(self, out, ref):
        refs = fh.tree(ref)
        for f, digest in fh.tree(out).items():
            self.assertEqual(digest, refs.get(f), f"{out}/{f} is not the uninterrupted run's file")

    def assert_reader_refuses_or_accepts_complete(self, out, ref, command, missing):
        """`command` (a reader) succeeds iff `out` holds the whole uninterrupted output; else it
        exits non-zero naming the file it misses."""
        p = fh.run(command)
        if fh.tree(out) == fh.tree(ref):
            self.assertEqual(p.returncode, 0, p.stderr)
        else:
            self.assertNotEqual(p.returncode, 0, f"{command} accepted an incomplete {out}")
            self.assertIn(missing, p.stderr)

    def assert_rerun_gives_reference(self, out, ref, command):
        fh.run_ok(command)
        self.assertEqual(fh.tree(out), fh.tree(ref))
        leftovers = fh.hidden_files(out)
        if leftovers:  # allowed (readers never open them); listed so they are seen
            print(f"  hidden files left after the rerun in {out}: {leftovers}")

    def test_wm_ingest_rerun_resumes_to_identical_shards(self):
        def check(out, ref, command):
            self.assert_visible_files_complete(out, ref)
            for reader in (argv("wm-shard", "verify", out), [*WMSHARD, out, "--verify"]):
                self.assert_reader_refuses_or_accepts_complete(out, ref, reader, "index.json")
            self.assert_rerun_gives_reference(out, ref, command(out))
        self.after_each_kill("wm-ingest", check, kills=5)

    def test_wm_tokenize_encode_rerun_gives_identical_tokens(self):
        def check(out, ref, command):
            self.assert_visible_files_complete(out, ref)
            reader = [*WMSHARD, "--tokens", out, "--verify"]
            self.assert_reader_refuses_or_accepts_complete(out, ref, reader, "index.json")
            self.assert_rerun_gives_reference(out, ref, command(out))
        self.after_each_kill("wm-tokenize-encode", check)

    def assert_killed_run_dir_loads(self, run, ref, spec):
        """A trainer's run directory after a kill: a checkpoint, if any, is whole (CRC32C, length)
        and at a checkpoint step; checkpoint.json never describes a newer one (it is written
        after the archive); the logs are complete lines and a prefix of the uninterrupted run's."""
        files = fh.tree(run)
        self.assertLessEqual(set(files), set(fh.tree(ref)))
        ckpt = os.path.join(run, "checkpoint.wmt")
        if "checkpoint.wmt" not in files:
            self.assertNotIn("checkpoint.json", files)
        else:
            _, header = read_archive(ckpt)
            step = header["meta"]["step"]
            self.assertTrue(step % spec["every"] == 0 or step == spec["steps"], step)
            if step == spec["steps"]:
                self.assertEqual(files["checkpoint.wmt"], fh.tree(ref)["checkpoint.wmt"])
            if "checkpoint.json" in files:
                with open(os.path.join(run, "checkpoint.json"), encoding="utf-8") as f:
                    manifest = json.load(f)
                self.assertLessEqual(manifest["step"], step)
                if manifest["step"] == step:
                    self.assertEqual(manifest["checkpoint"]["sha256"], files["checkpoint.wmt"])
        for log, timing in (("metrics.csv", spec["timing"]), ("val.csv", None)):
            if log in files:
                rows = fh.csv_rows(os.path.join(run, log), timing)
                self.assertEqual(rows, fh.csv_rows(os.path.join(ref, log), timing)[:len(rows)], log)

    def assert_resume_gives_reference(self, run, ref, command, spec):
        fh.run_ok(command)
        self.assertEqual(fh.run_dir_state(run, spec), fh.run_dir_state(ref, spec))

    def test_wm_tokenize_train_resume_gives_identical_checkpoint(self):
        def check(out, ref, command):
            self.assert_killed_run_dir_loads(out, ref, TOKENIZER)
            self.assert_resume_gives_reference(out, ref, command(out, "--resume"), TOKENIZER)
        self.after_each_kill("wm-tokenize-train", check)

    def test_wm_train_resume_gives_identical_checkpoint(self):
        def check(out, ref, command):
            self.assert_killed_run_dir_loads(out, ref, DYNAMICS)
            self.assert_resume_gives_reference(out, ref, command(out, "--resume"), DYNAMICS)
        self.after_each_kill("wm-train", check)

    def test_wm_eval_rerun_gives_identical_report(self):
        """A report is REPORT_DIR/<name>; wm-report reads it (manifest.json, summary.csv,
        per_episode.csv). Killed, it must be absent, refused or whole; a rerun into the same
        REPORT_DIR gives the same bytes, videos and strips included. Every visible episode
        folder of --save-rollouts is whole (the uninterrupted run's files, all of them)."""
        def check(out, ref, command):
            report, ref_report = os.path.join(out, "dyn"), os.path.join(ref, "dyn")
            self.assert_visible_files_complete(report, ref_report)
            export, ref_export = out + "-export", ref + "-export"
            episodes = {os.path.dirname(f) for f in fh.tree(export)}
            for episode in episodes:
                self.assertEqual(fh.tree(os.path.join(export, episode)),
                                 fh.tree(os.path.join(ref_export, episode)), episode)
            print(f"  whole exported episodes after the kill: {len(episodes)} of "
                  f"{len({os.path.dirname(f) for f in fh.tree(ref_export)})}")
            reader = argv("wm-report", "compare", report, "--out", out + "-compare.csv")
            self.assert_reader_refuses_or_accepts_complete(report, ref_report, reader, report)
            self.assert_rerun_gives_reference(out, ref, command(out))
            self.assertEqual(fh.tree(export), fh.tree(ref_export))
        self.after_each_kill("wm-eval", check)


if __name__ == "__main__":
    start = time.monotonic()
    result = unittest.main(verbosity=2, exit=False).result
    print(f"{time.monotonic() - start:.1f} s")
    sys.exit(not result.wasSuccessful())
