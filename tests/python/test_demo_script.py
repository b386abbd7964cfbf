#!/usr/bin/python3
"""scripts/demo.sh's choices that no other test runs (the demo itself takes 10 minutes):

- scripts/demo_motion_config.sh names an existing motion config for each look and refuses an
  unknown look;
- demo.sh refuses a raw dataset that wm-gen-tabletop made with other settings than the run asks
  for (an older demo's 200 episodes would silently change every result), naming the file and
  what differs, and accepts one made with the same settings;
- scripts/demo_heldout.sh makes its held-out set with data seed SEED + 7 in the asked look (tools
  replaced by stubs that log their arguments), reuses a finished set and remakes a partial one.
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


# A stub of each tool demo_heldout.sh runs: logs its arguments, and wm-tokenize makes the file
# that marks a finished set.
STUB = """#!/usr/bin/env bash
echo "$(basename "$0") $*" >> "$STUB_LOG"
if [ "$(basename "$0")" = wm-tokenize ]; then
  out=${@: -1}; mkdir -p "$out" && echo {} > "$out/index.json"
fi
"""


class DemoHeldoutTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.bin = os.path.join(self.tmp.name, "bin")
        os.makedirs(self.bin)
        for tool in ("wm-gen-tabletop", "wm-ingest", "wm-tokenize"):
            path = os.path.join(self.bin, tool)
            with open(path, "w") as f:
                f.write(STUB)
            os.chmod(path, 0o755)
        self.out = os.path.join(self.tmp.name, "heldout")
        self.log = os.path.join(self.tmp.name, "calls.log")

    def tearDown(self):
        self.tmp.cleanup()

    def heldout(self, *args):
        args = args or (self.bin, self.out, "TOK", "3", "varied", "5")
        return run(["bash", "scripts/demo_heldout.sh", *args], env={"STUB_LOG": self.log})

    def calls(self):
        if not os.path.exists(self.log):
            return []
        with open(self.log) as f:
            return f.read().splitlines()

    def test_makes_the_set_with_seed_plus_7_in_the_asked_look(self):
        out = self.heldout()
        self.assertEqual(out.returncode, 0, out.stderr)
        gen, ingest, encode = self.calls()
        self.assertIn("--seed 10 ", gen)
        self.assertIn("--val-episodes 5 --look varied", gen)
        self.assertIn(f"--split val --output {self.out}/shards", ingest)
        self.assertEqual(f"wm-tokenize encode --checkpoint TOK --data {self.out}/shards --out "
                         f"{self.out}/tokens", encode)

    def test_a_finished_set_is_reused(self):
        self.heldout()
        os.remove(self.log)
        out = self.heldout()
        self.assertEqual(out.returncode, 0, out.stderr)
        self.assertIn("already made", out.stdout)
        self.assertEqual(self.calls(), [])

    def test_a_partial_set_is_remade(self):
        os.makedirs(os.path.join(self.out, "shards"))
        stale = os.path.join(self.out, "shards", "stale")
        open(stale, "w").close()
        out = self.heldout()
        self.assertEqual(out.returncode, 0, out.stderr)
        self.assertFalse(os.path.exists(stale))
        self.assertEqual(len(self.calls()), 3)

    def test_wrong_arguments_print_the_usage(self):
        out = self.heldout(self.bin, self.out)
        self.assertEqual(out.returncode, 2)
        self.assertIn("scripts/demo_heldout.sh BIN OUT TOKENIZER SEED LOOK EPISODES", out.stderr)


if __name__ == "__main__":
    unittest.main()
