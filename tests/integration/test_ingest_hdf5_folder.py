#!/usr/bin/python3
"""wm-ingest on robomimic/LIBERO HDF5 written by h5py and on an image-folder dataset written by
OpenCV: the shards hold exactly the actions, rewards and pixels written, read back by the
independent Python reader; bad input exits 1 with a message naming the file, also when the
input crashes libhdf5, makes it allocate without bound or loop (fuzz-found files), and
--on-error skip then skips just that file."""
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import unittest

import cv2
import h5py
import numpy as np

SRC = os.environ.get("WM_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
BIN = os.environ.get("WM_BIN_DIR", os.path.join(SRC, "build", "bin"))
sys.path.insert(0, os.path.join(SRC, "scripts"))
import wmshard  # noqa: E402


DAMAGED = os.path.join(SRC, "tests", "data", "hdf5")  # fuzz-found files; tests/data/README.md


def ingest_command(fmt, src, out, extra=()):
    return [f"{BIN}/wm-ingest", "--format", fmt, "--input", src, "--output", out, "--log-level",
            "warn", *extra]


def ingest(fmt, src, out, check=True, extra=(), timeout=None):
    p = subprocess.run(ingest_command(fmt, src, out, extra), capture_output=True, text=True,
                       timeout=timeout)
    if check and p.returncode != 0:
        raise AssertionError(p.stderr)
    return p


def write_robomimic(path, rng, demos=((10, 4), (2, 3))):
    """A robomimic-layout file of (demo number, steps) demos; returns {n: (actions, pixels)}."""
    written = {}
    with h5py.File(path, "w") as f:
        for n, steps in demos:
            g = f.create_group(f"data/demo_{n}")
            actions = rng.uniform(-1, 1, (steps, 7)).astype(np.float64)
            pixels = rng.integers(0, 256, (steps, 8, 8, 3), dtype=np.uint8)
            g["actions"] = actions
            g["rewards"] = np.arange(steps, dtype=np.float32)
            g["dones"] = (np.arange(steps) == steps - 1).astype(np.int64)
            g["obs/agentview_rgb"] = pixels
            written[n] = (actions, pixels)
    return written


def rss_of_group_mib(pgid):
    """Resident memory of every process in process group `pgid`, summed (pages shared after a
    fork count once per process: an overestimate, which is what a guard wants)."""
    total = 0
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            with open(f"/proc/{pid}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
            if int(fields[2]) != pgid:  # fields[2]: pgrp
                continue
            with open(f"/proc/{pid}/statm") as f:
                total += int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
        except (OSError, IndexError, ValueError):  # the process ended meanwhile
            continue
    return total / 2**20


def run_with_memory_guard(args, kill_above_mib, timeout=60):
    """Runs `args` in a process group of its own, killing the group when its resident memory
    passes `kill_above_mib` or when `timeout` s pass. Returns (exit code, stderr, peak MiB): the
    peak is wait4's ru_maxrss, the largest of the process and of every child it waited for."""
    with tempfile.TemporaryFile() as err:  # a file: a full pipe would block the process
        p = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=err, start_new_session=True)
        deadline = time.monotonic() + timeout
        while True:
            pid, status, usage = os.wait4(p.pid, os.WNOHANG)
            if pid:
                break
            if rss_of_group_mib(p.pid) > kill_above_mib or time.monotonic() > deadline:
                os.killpg(p.pid, signal.SIGKILL)
            time.sleep(0.02)
        p.returncode = os.waitstatus_to_exitcode(status)
        err.seek(0)
        return p.returncode, err.read().decode(errors="replace"), usage.ru_maxrss / 1024


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
        written = write_robomimic(path, self.rng, ((10, 4), (2, 3)))  # demo_2 before demo_10
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
        to catch it): the demo's read dies in its child process, and wm-ingest reports that
        instead of dying with a bare signal."""
        path = os.path.join(DAMAGED, "crashes_libhdf5.hdf5")
        out = os.path.join(self.tmp, "out")
        p = ingest("hdf5", path, out, check=False)
        self.assertEqual(p.returncode, 1, p.stderr)
        self.assertIn("wm-ingest: error: ", p.stderr)
        self.assertIn("crashes_libhdf5.hdf5: demo 0: libhdf5 crashed (SIG", p.stderr)
        self.assertIn("the file is damaged", p.stderr)
        self.assertFalse(os.path.exists(os.path.join(out, "index.json")))

    def test_hdf5_file_on_which_libhdf5_allocates_without_bound_stops_at_the_limit(self):
        """A fuzz-found file on which libhdf5 1.10 allocates without bound (24 GB before the OOM
        killer when unisolated): the file listing stops at the child's 512 MB limit."""
        # The peak is wait4's (wm-ingest's own or that of any child it waited for). An RLIMIT_AS
        # on wm-ingest itself would not do: libhdf5 would fail at it with the same message, so
        # the test would pass without isolation. The guard kills a run past 3 GiB, so that a
        # regression fails here (exit -9) instead of exhausting the machine.
        path = os.path.join(DAMAGED, "allocates_without_bound.hdf5")
        out = os.path.join(self.tmp, "out")
        code, stderr, peak_mib = run_with_memory_guard(
            ingest_command("hdf5", path, out, ["--hdf5-memory-limit-mb", "512"]),
            kill_above_mib=3072)
        self.assertEqual(code, 1, stderr)  # -9: the guard killed it
        self.assertIn("wm-ingest: error: ", stderr)
        self.assertIn("allocates_without_bound.hdf5", stderr)
        self.assertIn("damaged", stderr)
        self.assertFalse(os.path.exists(os.path.join(out, "index.json")))
        # 512 MB for the child on top of what it shares with wm-ingest (~50 MB).
        self.assertLess(peak_mib, 1536, stderr)

    def test_hdf5_file_on_which_libhdf5_loops_stops_at_the_cpu_limit(self):
        """A fuzz-found file on which libhdf5 1.10 loops forever in its global heap code: the
        demo's read is ended after 2 s of CPU time (the timeout only catches a hang)."""
        path = os.path.join(DAMAGED, "loops_in_libhdf5.hdf5")
        out = os.path.join(self.tmp, "out")
        p = ingest("hdf5", path, out, check=False, extra=["--hdf5-cpu-limit-s", "2"], timeout=60)
        self.assertEqual(p.returncode, 1, p.stderr)
        self.assertIn("loops_in_libhdf5.hdf5: demo 0: ", p.stderr)
        self.assertIn("within its limit of 2 s of CPU time", p.stderr)
        self.assertFalse(os.path.exists(os.path.join(out, "index.json")))

    def test_on_error_skip_keeps_good_files_and_lists_the_damaged_one(self):
        """A directory with a good file and one that crashes libhdf5: under --on-error skip the
        good demos are ingested and the damaged one is recorded in index.json's skipped list."""
        root = os.path.join(self.tmp, "mixed")
        os.makedirs(root)
        written = write_robomimic(os.path.join(root, "good.hdf5"), self.rng, ((0, 3), (1, 2)))
        shutil.copy(os.path.join(DAMAGED, "crashes_libhdf5.hdf5"), os.path.join(root, "bad.hdf5"))
        out = os.path.join(self.tmp, "out")
        ingest("hdf5", root, out, extra=["--on-error", "skip"])
        eps = episodes(out)
        self.assertEqual([e["episode_key"] for e in eps], ["good.hdf5#0", "good.hdf5#1"])
        for e, n in zip(eps, (0, 1)):
            np.testing.assert_array_equal(np.float32(written[n][0]), np.float32(e["actions"]))
        with open(os.path.join(out, "index.json")) as f:
            skipped = json.load(f)["skipped"]
        self.assertEqual(skipped["count"], 1, skipped)
        (entry,) = skipped["episodes"]
        self.assertEqual((entry["file"], entry["record"]), ("bad.hdf5", 0), entry)
        self.assertIn("libhdf5 crashed", entry["reason"])

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

    def index(self, out):
        with open(os.path.join(out, "index.json")) as f:
            return json.load(f)

    def test_hdf5_actions_of_another_width_keep_it_and_name_their_space(self):
        path = os.path.join(self.tmp, "bimanual.hdf5")
        actions = self.rng.uniform(-1, 1, (3, 12)).astype(np.float32)  # e.g. robocasa's 12
        with h5py.File(path, "w") as f:
            f["data/demo_0/actions"] = actions
            f["data/demo_0/obs/agentview_image"] = self.rng.integers(0, 256, (3, 8, 8, 3),
                                                                     dtype=np.uint8)
        out = os.path.join(self.tmp, "out")
        ingest("hdf5", path, out)  # wmshard then checks shards, stats and width against index
        (e,) = episodes(out)
        np.testing.assert_array_equal(actions, np.float32(e["actions"]))
        action = self.index(out)["features"]["action"]
        self.assertEqual((action["dim"], action["space"]), (12, "other"))
        self.assertEqual(self.index(out)["format_version"], 2)

        joints = os.path.join(self.tmp, "joints")
        ingest("hdf5", path, joints, extra=("--action-space", "joint_position"))
        self.assertEqual(self.index(joints)["features"]["action"]["space"], "joint_position")
        p = ingest("hdf5", path, os.path.join(self.tmp, "eef"), check=False,
                   extra=("--action-space", "eef_delta"))
        self.assertEqual(p.returncode, 1)
        for part in ("bimanual.hdf5", "demo 0", "key 'actions'", "eef_delta", "got 12"):
            self.assertIn(part, p.stderr)

    def write_folder_episode(self, name, actions):
        ep = os.path.join(self.tmp, "folders", name)
        os.makedirs(ep)
        for t in range(len(actions)):
            cv2.imwrite(os.path.join(ep, f"{t}.png"), np.full((4, 4, 3), 10 * t, np.uint8))
        with open(os.path.join(ep, "actions.csv"), "w") as f:
            f.write("".join(",".join(repr(float(v)) for v in row) + "\n" for row in actions))
        return ep

    def test_folder_actions_of_another_width_keep_it_and_one_width_per_dataset(self):
        actions = self.rng.uniform(-1, 1, (2, 3))
        self.write_folder_episode("ep_0", actions)
        out = os.path.join(self.tmp, "out")
        ingest("folder", os.path.join(self.tmp, "folders"), out)
        (e,) = episodes(out)
        np.testing.assert_array_equal(np.float32(actions), np.float32(e["actions"]))
        action = self.index(out)["features"]["action"]
        self.assertEqual((action["dim"], action["space"]), (3, "other"))

        self.write_folder_episode("ep_1", self.rng.uniform(-1, 1, (2, 4)))
        p = ingest("folder", os.path.join(self.tmp, "folders"), os.path.join(self.tmp, "o"),
                   check=False)
        self.assertEqual(p.returncode, 1)
        for part in ("ep_1", "differ from the dataset's first episode", '"dim":4'):
            self.assertIn(part, p.stderr)
        p = ingest("rlds", os.path.join(self.tmp, "folders"), os.path.join(self.tmp, "r"),
                   check=False, extra=("--action-space", "other"))
        self.assertEqual(p.returncode, 1)
        self.assertIn("--action-space applies to hdf5 and folder inputs", p.stderr)

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
