#!/usr/bin/python3
"""wm-ingest on robomimic/LIBERO HDF5 written by h5py and on an image-folder dataset written by
OpenCV: the shards hold exactly the actions, rewards and pixels written, read back by the
independent Python reader; bad input exits 1 with a message naming the file."""
import json
import os
import shutil
import subprocess
import sys
import tempfile
import unittest

import cv2
import h5py
import numpy as np

SRC = os.environ.get("WM_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
BIN = os.environ.get("WM_BIN_DIR", os.path.join(SRC, "build", "bin"))
sys.path.insert(0, os.path.join(SRC, "scripts"))
import wmshard  # noqa: E402


def ingest(fmt, src, out, check=True):
    p = subprocess.run([f"{BIN}/wm-ingest", "--format", fmt, "--input", src, "--output", out,
                        "--log-level", "warn"], capture_output=True, text=True)
    if check and p.returncode != 0:
        raise AssertionError(p.stderr)
    return p


def episodes(out):
    p = subprocess.run(["/usr/bin/python3", f"{SRC}/scripts/wmshard.py", out, "--all", "--json"],
                       capture_output=True, text=True, check=True)
    return json.loads(p.stdout)


def first_frame(out, k):
    """Decoded RGB pixels of step 0 of episode k, read with wmshard's shard reader."""
    with open(os.path.join(out, "index.json")) as f:
        index = json.load(f)
    shard = wmshard.Shard(os.path.join(out, index["shards"][0]["file"]))
    meta, body = shard.record(k)
    section = next(s for s in meta["sections"] if s["name"] == "image")
    blob = wmshard.read_section(body, section, "test")[0]
    return cv2.cvtColor(cv2.imdecode(np.frombuffer(blob, np.uint8), cv2.IMREAD_COLOR),
                        cv2.COLOR_BGR2RGB)


class HdfAndFolderIngest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.mkdtemp(prefix="wmkit-h5-")
        self.rng = np.random.default_rng(3)

    def tearDown(self):
        shutil.rmtree(self.tmp, ignore_errors=True)

    def test_hdf5_demos_round_trip_in_numeric_order(self):
        path = os.path.join(self.tmp, "demo.hdf5")
        written = {}
        with h5py.File(path, "w") as f:
            for n, steps in ((10, 4), (2, 3)):  # demo_2 must come before demo_10
                g = f.create_group(f"data/demo_{n}")
                actions = self.rng.uniform(-1, 1, (steps, 7)).astype(np.float64)
                pixels = self.rng.integers(0, 256, (steps, 8, 8, 3), dtype=np.uint8)
                g["actions"] = actions
                g["rewards"] = np.arange(steps, dtype=np.float32)
                g["dones"] = (np.arange(steps) == steps - 1).astype(np.int64)
                g["obs/agentview_rgb"] = pixels
                written[n] = (actions, pixels)
        out = os.path.join(self.tmp, "out")
        ingest("hdf5", path, out)
        eps = episodes(out)
        self.assertEqual([e["episode_key"] for e in eps], ["demo.hdf5#2", "demo.hdf5#10"])  # record = demo number
        for k, n in enumerate((2, 10)):
            actions, pixels = written[n]
            np.testing.assert_array_equal(np.float32(actions), np.float32(eps[k]["actions"]))
            self.assertEqual(eps[k]["rewards"], list(range(len(actions))))
            self.assertEqual(eps[k]["is_terminal"][-1], 1)
            np.testing.assert_array_equal(first_frame(out, k), pixels[0])  # PNG is lossless

    def test_hdf5_without_data_group_names_the_file(self):
        path = os.path.join(self.tmp, "empty.hdf5")
        with h5py.File(path, "w") as f:
            f["something"] = np.zeros(3)
        p = ingest("hdf5", path, os.path.join(self.tmp, "out"), check=False)
        self.assertEqual(p.returncode, 1)
        self.assertIn("empty.hdf5", p.stderr)
        self.assertIn("'data'", p.stderr)

    def test_hdf5_file_that_crashes_libhdf5_is_an_error_naming_file_and_demo(self):
        """A fuzz-found file on which libhdf5 1.10 itself segfaults (damaged B-tree, no checksum
        to catch it): wm-ingest reports it instead of dying with a bare signal."""
        path = os.path.join(SRC, "tests", "data", "hdf5", "crashes_libhdf5.hdf5")
        out = os.path.join(self.tmp, "out")
        p = ingest("hdf5", path, out, check=False)
        self.assertEqual(p.returncode, 1, p.stderr)
        self.assertIn("wm-ingest: error: libhdf5 crashed", p.stderr)
        self.assertIn("crashes_libhdf5.hdf5, demo 0", p.stderr)
        self.assertFalse(os.path.exists(os.path.join(out, "index.json")))

    def test_folder_episodes_keep_their_bytes(self):
        root = os.path.join(self.tmp, "folders")
        pixels = self.rng.integers(0, 256, (3, 6, 5, 3), dtype=np.uint8)
        actions = self.rng.uniform(-1, 1, (3, 7))
        ep = os.path.join(root, "ep_000")
        os.makedirs(ep)
        for t in range(3):
            cv2.imwrite(os.path.join(ep, f"{t:04d}.png"), cv2.cvtColor(pixels[t], cv2.COLOR_RGB2BGR))
        with open(os.path.join(ep, "actions.csv"), "w") as f:
            f.write("dx,dy,dz,droll,dpitch,dyaw,gripper\n")
            for row in actions:
                f.write(",".join(repr(float(v)) for v in row) + "\n")
        with open(os.path.join(ep, "meta.json"), "w") as f:
            json.dump({"language_instruction": "stack", "policy_id": "human"}, f)
        out = os.path.join(self.tmp, "out")
        ingest("folder", root, out)
        (e,) = episodes(out)
        np.testing.assert_array_equal(np.float32(actions), np.float32(e["actions"]))
        self.assertEqual((e["language_instruction"], e["policy_id"]), ("stack", "human"))
        self.assertEqual(e["image_shape"], [6, 5, 3])
        np.testing.assert_array_equal(first_frame(out, 0), pixels[0])

    def test_folder_with_nan_action_fails_with_key_and_step(self):
        ep = os.path.join(self.tmp, "folders", "ep_0")
        os.makedirs(ep)
        cv2.imwrite(os.path.join(ep, "0.png"), np.zeros((4, 4, 3), np.uint8))
        with open(os.path.join(ep, "actions.csv"), "w") as f:
            f.write("0,0,nan,0,0,0,1\n")
        p = ingest("folder", os.path.join(self.tmp, "folders"), os.path.join(self.tmp, "o"),
                   check=False)
        self.assertEqual(p.returncode, 1)
        self.assertIn("ep_0", p.stderr)
        self.assertIn("action", p.stderr)


if __name__ == "__main__":
    unittest.main(verbosity=2)
