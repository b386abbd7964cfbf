#!/usr/bin/python3
"""End to end: wm-gen-tabletop -> wm-ingest -> the C++ reader (wm-shard dump) and the independent
Python reader (scripts/wmshard.py) agree on every episode; index.json matches its schema and
numpy's action statistics; a SIGKILLed ingest resumes to identical bytes; sharded jobs merge to
the single-job episodes; `wm-shard slice` keeps each episode from a step on; bad input fails
with a clear message."""
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
PY = "/usr/bin/python3"
sys.path.insert(0, os.path.join(SRC, "scripts"))
import wmshard  # noqa: E402


def run(args, env=None, check=True):
    full_env = dict(os.environ, **(env or {}))
    p = subprocess.run(args, capture_output=True, text=True, env=full_env)
    if check and p.returncode != 0:
        raise AssertionError(f"{args} failed ({p.returncode}):\n{p.stdout}\n{p.stderr}")
    return p


def ingest(raw, out, *extra, env=None, check=True, log="warn"):
    return run([f"{BIN}/wm-ingest", "--format", "rlds", "--input", raw, "--output", out,
                "--log-level", log, *extra], env=env, check=check)


def dir_bytes(path):
    return {n: open(os.path.join(path, n), "rb").read() for n in sorted(os.listdir(path))}


class IngestPipeline(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.mkdtemp(prefix="wmkit-it-")
        run([f"{BIN}/wm-gen-tabletop", "--out", cls.tmp, "--train-episodes", "12",
             "--val-episodes", "4", "--size", "64", "--max-steps", "20", "--seed", "7"])
        cls.raw = os.path.join(cls.tmp, "wm_tabletop", "1.0.0")
        cls.out = os.path.join(cls.tmp, "train")
        ingest(cls.raw, cls.out, "--shard-size-mb", "0.05")

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.tmp, ignore_errors=True)

    def test_cpp_and_python_readers_agree_on_every_episode(self):
        cpp = json.loads(run([f"{BIN}/wm-shard", "dump", self.out]).stdout)
        py = json.loads(run([PY, f"{SRC}/scripts/wmshard.py", self.out, "--all", "--json"]).stdout)
        self.assertEqual(len(cpp), 12)
        self.assertEqual(len(py), 12)
        keys = ["episode_key", "num_steps", "actions", "rewards", "discounts", "is_first",
                "is_last", "is_terminal", "language_instruction", "policy_id", "episode_seed",
                "image_shape", "image_sha256"]
        for c, p in zip(cpp, py):
            for k in keys:
                self.assertEqual(c[k], p[k], f"{c['episode_key']}: {k}")
            self.assertEqual(c["image_shape"], [64, 64, 3])
            self.assertEqual(set(c["num_frames"]), {"image", "depth", "segmentation"})

    def test_index_matches_schema_and_numpy_statistics(self):
        index = json.load(open(os.path.join(self.out, "index.json")))
        schema = json.load(open(os.path.join(SRC, "schemas", "shard-index.schema.json")))
        jsonschema.validate(index, schema)
        self.assertGreater(len(index["shards"]), 1, "0.05 MB shards should roll")
        episodes = json.loads(run([PY, f"{SRC}/scripts/wmshard.py", self.out, "--all", "--json"]).stdout)
        actions = np.concatenate([np.asarray(e["actions"], dtype=np.float64) for e in episodes])
        stats = index["action_stats"]
        np.testing.assert_allclose(stats["mean"], actions.mean(0), rtol=0, atol=1e-12)
        np.testing.assert_allclose(stats["std"], actions.std(0), rtol=0, atol=1e-12)
        np.testing.assert_allclose(stats["q01"], np.quantile(actions, 0.01, axis=0), atol=1e-12)
        np.testing.assert_allclose(stats["q99"], np.quantile(actions, 0.99, axis=0), atol=1e-12)
        self.assertEqual(index["num_steps"], len(actions))
        prov = index["provenance"]
        for k in ("git_commit", "config_hash", "libraries", "config"):
            self.assertIn(k, prov)
        self.assertTrue(all(len(i["sha256"]) == 64 for i in index["source"]["inputs"]))

    def test_rerun_is_byte_identical_and_idempotent(self):
        again = os.path.join(self.tmp, "again")
        ingest(self.raw, again, "--shard-size-mb", "0.05", "--threads", "1")
        self.assertEqual(dir_bytes(self.out), dir_bytes(again))
        p = ingest(self.raw, again, "--shard-size-mb", "0.05", log="info")
        self.assertIn("nothing to do", p.stderr)
        p = ingest(self.raw, again, "--shard-size-mb", "1", check=False)
        self.assertEqual(p.returncode, 1)
        self.assertIn("other options", p.stderr)

    def test_killed_ingest_resumes_to_identical_bytes(self):
        killed = os.path.join(self.tmp, "killed")
        p = ingest(self.raw, killed, "--shard-size-mb", "0.05",
                   env={"WMKIT_FAULT_KILL_AFTER": "7"}, check=False)
        self.assertEqual(p.returncode, -9, p.stderr)
        self.assertFalse(os.path.exists(os.path.join(killed, "index.json")))
        p = ingest(self.raw, killed, "--shard-size-mb", "0.05", log="info")
        self.assertIn("resuming after", p.stderr)
        self.assertEqual(dir_bytes(self.out), dir_bytes(killed))

    def test_sharded_jobs_merge_to_the_single_job_episodes(self):
        parts = []
        for i in range(3):
            part = os.path.join(self.tmp, f"part-{i}")
            ingest(self.raw, part, "--shard-size-mb", "0.05", "--shard-index", str(i),
                   "--num-shards", "3")
            parts.append(part)
        merged = os.path.join(self.tmp, "merged")
        run([f"{BIN}/wm-shard", "merge", "--output", merged, *parts])
        run([f"{BIN}/wm-shard", "verify", merged])
        single = json.loads(run([f"{BIN}/wm-shard", "dump", self.out]).stdout)
        joined = json.loads(run([f"{BIN}/wm-shard", "dump", merged]).stdout)
        self.assertEqual(single, joined)
        a = json.load(open(os.path.join(self.out, "index.json")))
        b = json.load(open(os.path.join(merged, "index.json")))
        self.assertEqual(a["action_stats"], b["action_stats"])
        self.assertEqual(a["num_steps"], b["num_steps"])

    def test_slice_keeps_each_episode_from_a_step_on(self):
        episodes = json.loads(run([f"{BIN}/wm-shard", "dump", self.out]).stdout)
        out = os.path.join(self.tmp, "from5")
        run([f"{BIN}/wm-shard", "slice", "--from-step", "5", "--max-steps", "9", "--min-steps",
             "8", "--output", out, self.out])
        run([f"{BIN}/wm-shard", "verify", out])
        sliced = json.loads(run([f"{BIN}/wm-shard", "dump", out]).stdout)
        kept = [e for e in episodes if e["num_steps"] - 5 >= 8]
        self.assertGreater(len(kept), 0)
        self.assertLess(len(kept), len(episodes), "some episodes end early (success)")
        self.assertEqual(len(sliced), len(kept))
        for whole, part in zip(kept, sliced):
            n = min(whole["num_steps"] - 5, 9)
            self.assertEqual(part["num_steps"], n)
            self.assertEqual(part["episode_key"], whole["episode_key"] + "@5")
            for k in ("actions", "rewards", "discounts", "is_last", "is_terminal",
                      "image_sha256"):
                self.assertEqual(part[k], whole[k][5:5 + n], f"{part['episode_key']}: {k}")
            self.assertEqual(part["is_first"], [1] + whole["is_first"][6:5 + n])
            self.assertEqual(part["num_frames"], {k: n for k in whole["num_frames"]})
            for k in ("policy_id", "episode_seed", "language_instruction"):
                self.assertEqual(part[k], whole[k])
        index = json.load(open(os.path.join(out, "index.json")))
        jsonschema.validate(index, json.load(open(os.path.join(SRC, "schemas",
                                                                 "shard-index.schema.json"))))
        self.assertEqual(index["skipped"]["count"], len(episodes) - len(kept))
        self.assertIn("--min-steps 8", index["skipped"]["episodes"][0]["reason"])
        actions = np.concatenate([np.asarray(e["actions"], np.float64) for e in sliced])
        np.testing.assert_allclose(index["action_stats"]["mean"], actions.mean(0), atol=1e-12)
        self.assertEqual(index["provenance"]["tool"], "wm-shard slice")
        # sliced again: its log counts the slice's own skips apart from the input's
        short = sum(1 for e in sliced if e["num_steps"] < 9)
        self.assertLess(short, len(sliced), "some slices keep 9 steps")
        resliced = run([f"{BIN}/wm-shard", "slice", "--min-steps", "9", "--output",
                        os.path.join(self.tmp, "from5-min9"), out])
        self.assertIn(f"{short} too short, {len(episodes) - len(kept)} already skipped in the "
                      "input", resliced.stdout + resliced.stderr)
        twin = os.path.join(self.tmp, "from5-again")
        run([f"{BIN}/wm-shard", "slice", "--from-step", "5", "--max-steps", "9", "--min-steps",
             "8", "--output", twin, self.out])
        self.assertEqual(dir_bytes(out), dir_bytes(twin))
        again = run([f"{BIN}/wm-shard", "slice", "--from-step", "5", "--output", out, self.out],
                    check=False)
        self.assertEqual(again.returncode, 1)
        self.assertIn("already holds a dataset", again.stderr)
        none = run([f"{BIN}/wm-shard", "slice", "--from-step", "500", "--output",
                    os.path.join(self.tmp, "none"), self.out], check=False)
        self.assertEqual(none.returncode, 1)
        self.assertIn("no episodes were written", none.stderr)

    def test_resize_reencodes_every_stream(self):
        out = os.path.join(self.tmp, "resized")
        ingest(self.raw, out, "--resize", "32x24", "--max-episodes", "2")
        with open(os.path.join(out, "index.json")) as f:
            index = json.load(f)
        features = index["features"]
        self.assertEqual(features["image"]["shape"], [24, 32, 3])
        self.assertEqual(features["depth"]["shape"], [24, 32, 1])
        self.assertEqual(features["segmentation"]["shape"], [24, 32, 1])
        run([PY, f"{SRC}/scripts/wmshard.py", out, "--verify"])
        # Labels are resized with nearest neighbour: no new label values appear.
        shard = wmshard.Shard(os.path.join(out, index["shards"][0]["file"]))
        meta, body = shard.record(0)
        seg = next(s for s in meta["sections"] if s["name"] == "segmentation")
        for blob in wmshard.read_section(body, seg, "test"):
            labels = cv2.imdecode(np.frombuffer(blob, np.uint8), cv2.IMREAD_UNCHANGED)
            self.assertEqual(labels.shape, (24, 32))
            self.assertTrue(set(np.unique(labels)) <= {0, 1, 2, 3})

    def test_truncated_tfrecord_fails_or_is_skipped_and_counted(self):
        bad = os.path.join(self.tmp, "bad_raw")
        shutil.copytree(self.raw, bad)
        victim = sorted(f for f in os.listdir(bad) if "-train.tfrecord-" in f)[0]
        path = os.path.join(bad, victim)
        os.truncate(path, os.path.getsize(path) - 100)
        p = ingest(bad, os.path.join(self.tmp, "bad_out"), check=False)
        self.assertEqual(p.returncode, 1)
        self.assertIn(victim, p.stderr)
        self.assertIn("truncated", p.stderr)
        self.assertFalse(os.path.exists(os.path.join(self.tmp, "bad_out", "index.json")))
        out = os.path.join(self.tmp, "bad_skip")
        ingest(bad, out, "--on-error", "skip")
        index = json.load(open(os.path.join(out, "index.json")))
        self.assertEqual(index["skipped"]["count"], 1)
        self.assertEqual(index["skipped"]["episodes"][0]["file"], victim)
        self.assertEqual(index["num_episodes"], 11)


class ExternalFractalSample(unittest.TestCase):
    """The OXE fractal sample written outside wmkit, through the CLI, read by the Python reader."""

    def test_every_episode_matches_expected_json(self):
        data = os.path.join(SRC, "tests", "data", "rlds")
        with tempfile.TemporaryDirectory() as tmp:
            out = os.path.join(tmp, "fractal")
            ingest(os.path.join(data, "fractal20220817_data"), out)
            got = json.loads(run([PY, f"{SRC}/scripts/wmshard.py", out, "--all", "--json"]).stdout)
        with open(os.path.join(data, "fractal20220817_data.expected.json")) as f:
            expected = json.load(f)
        self.assertEqual(len(got), len(expected))
        for g, x in zip(got, expected):
            self.assertEqual(g["num_steps"], x["num_steps"])
            np.testing.assert_array_equal(np.float32(g["actions"]), np.float32(x["actions"]))
            np.testing.assert_array_equal(np.float32(g["rewards"]), np.float32(x["rewards"]))
            self.assertEqual(g["language_instruction"], x["language_instruction"])
            self.assertEqual(g["image_shape"], x["image_shape"])


if __name__ == "__main__":
    unittest.main(verbosity=2)
