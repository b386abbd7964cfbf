#!/usr/bin/python3
"""scripts/demo.sh's choices that no other test runs (the demo itself takes 10 minutes):

- scripts/demo_motion_config.sh names an existing motion config for each look and refuses an
  unknown look;
- demo.sh refuses a raw dataset that wm-gen-tabletop made with other settings than the run asks
  for (an older demo's 200 episodes would silently change every result), naming the file and
  what differs, and accepts one made with the same settings.
Needs wm-gen-tabletop (WM_BIN_DIR); about 2 s."""
import os
import subprocess
import tempfile
import unittest

SRC = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
BIN = os.environ.get("WM_BIN_DIR", os.path.join(SRC, "build", "bin"))


def run(args, env=None):
    return subprocess.run(args, cwd=SRC, env={**os.environ, **(env or {})}, capture_output=True,
                          text=True)


class MotionConfigForLookTest(unittest.TestCase):
    def test_each_look_has_an_existing_config(self):
        for look in ("plain", "varied"):
            out = run(["bash", "scripts/demo_motion_config.sh", look])
            self.assertEqual(out.returncode, 0, out.stderr)
            self.assertTrue(os.path.isfile(os.path.join(SRC, out.stdout.strip())), out.stdout)

    def test_unknown_look_is_refused(self):
        out = run(["bash", "scripts/demo_motion_config.sh", "shiny"])
        self.assertEqual(out.returncode, 2)
        self.assertIn("unknown look 'shiny'", out.stderr)


class DemoRawDatasetGuardTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.demo_dir = os.path.join(cls.tmp.name, "demo")
        raw = os.path.join(cls.demo_dir, "raw")
        made = run([os.path.join(BIN, "wm-gen-tabletop"), "--out", raw, "--seed", "3", "--size",
                    "64", "--train-episodes", "2", "--val-episodes", "1", "--look", "plain"])
        assert made.returncode == 0, made.stderr

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def run_demo(self, **settings):
        # A BIN without tools: the run stops at the first tool after the guard.
        missing = os.path.join(self.tmp.name, "no-bin")
        return run(["bash", "scripts/demo.sh", missing, self.demo_dir], env=settings)

    def test_other_settings_are_refused(self):
        cases = {"TRAIN_EPISODES": ("1000", "1000, seed 3, plain look"),
                 "SEED": ("4", "2, seed 4, plain look"),
                 "LOOK": ("varied", "2, seed 3, varied look")}
        for key, (value, asked) in cases.items():
            settings = {"TRAIN_EPISODES": "2", "SEED": "3", "LOOK": "plain", key: value}
            out = self.run_demo(**settings)
            self.assertNotEqual(out.returncode, 0, key)
            self.assertIn("dataset_info.json was generated with 2 training episodes, seed 3, "
                          f"plain look; this run asks for {asked}: delete {self.demo_dir}",
                          out.stderr, key)

    def test_same_settings_pass_the_guard(self):
        out = self.run_demo(TRAIN_EPISODES="2", SEED="3", LOOK="plain")
        self.assertIn("already generated", out.stdout)
        self.assertIn("no-bin/wm-ingest", out.stderr)  # the next stage, not the guard
        self.assertNotIn("was generated with", out.stderr)


if __name__ == "__main__":
    unittest.main()
