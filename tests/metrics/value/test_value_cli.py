#!/usr/bin/python3
"""`wm-metrics value` input errors: each bad returns file gives exit 1 and one error line naming
the file, the line and the column; usage errors keep CLI11's messages; and frame comparison
without a subcommand still demands --ref and --pred exactly as before the subcommands existed."""
import os
import subprocess
import tempfile
import unittest

SRC = os.environ.get("WM_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", "..", ".."))
BIN = os.environ.get("WM_BIN_DIR", os.path.join(SRC, "build", "bin"))
HEADER = "episode,policy_id,real_return,model_return\n"
GOOD_ROWS = "e0,a,1.0,0.5\ne1,a,0.0,0.25\ne0,b,0.5,0.5\n"


def wm_metrics(*args):
    return subprocess.run([f"{BIN}/wm-metrics", *args], capture_output=True, text=True)


class ValueCli(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()

    def tearDown(self):
        self.tmp.cleanup()

    def write(self, text, name="returns.csv"):
        path = os.path.join(self.tmp.name, name)
        with open(path, "w") as f:
            f.write(text)
        return path

    def assertInputError(self, text, *expected):
        path = self.write(text)
        p = wm_metrics("value", "--returns", path)
        self.assertEqual(p.returncode, 1, p.stderr)
        self.assertEqual(p.stdout, "")
        self.assertEqual(len(p.stderr.strip().splitlines()), 1, p.stderr)
        for part in (path,) + expected:
            self.assertIn(part, p.stderr)

    def test_good_file_runs(self):
        p = wm_metrics("value", "--returns", self.write(HEADER + GOOD_ROWS), "--bootstrap", "10")
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertIn('"value_gap"', p.stdout)

    def test_bad_cells_name_line_and_column(self):
        self.assertInputError(HEADER + GOOD_ROWS + "e2,b,abc,1\n",
                              "line 5", "column 'real_return'", "'abc' is not a number")
        self.assertInputError(HEADER + "e0,a,1,nan\n", "line 2", "column 'model_return'",
                              "not finite")
        self.assertInputError(HEADER + GOOD_ROWS + "e3,a,-inf,1\n", "line 5",
                              "column 'real_return'", "not finite")
        self.assertInputError(HEADER + "e0,a,1,\n", "line 2", "column 'model_return'",
                              "empty cell")
        self.assertInputError(HEADER + "e0,,1,1\n", "line 2", "column 'policy_id'", "empty cell")
        self.assertInputError(HEADER + "e0,a,1\n", "line 2", "3 cells", "4 columns")

    def test_bad_files(self):
        self.assertInputError("", "empty file")
        self.assertInputError(HEADER, "no episode rows")
        self.assertInputError("episode,policy_id,real_return\ne0,a,1\n",
                              "line 1", "missing column 'model_return'")
        self.assertInputError(HEADER + GOOD_ROWS + "e1,a,2,2\n", "line 5",
                              "episode 'e1' of policy 'a' is listed twice")
        p = wm_metrics("value", "--returns", os.path.join(self.tmp.name, "absent.csv"))
        self.assertEqual(p.returncode, 1)
        self.assertIn("absent.csv: cannot open", p.stderr)

    def test_usage_errors(self):
        path = self.write(HEADER + GOOD_ROWS)
        for args in (["--ci", "1"], ["--ci", "0"], ["--bootstrap", "-5"], ["--format", "xml"]):
            p = wm_metrics("value", "--returns", path, *args)
            self.assertNotIn(p.returncode, (0, 1), args)
            self.assertIn("Run with --help", p.stderr)
        p = wm_metrics("value")
        self.assertIn("--returns is required", p.stderr)
        p = wm_metrics("--ref", path, "value", "--returns", path)
        self.assertNotIn(p.returncode, (0, 1))
        self.assertIn("value excludes --ref", p.stderr)

    def test_help_is_a_manual(self):
        p = wm_metrics("value", "--help")
        self.assertEqual(p.returncode, 0)
        for part in ("--returns", "--bootstrap", "--seed", "--ci", "Examples:", "value_gap"):
            self.assertIn(part, p.stdout)
        self.assertIn("wm-metrics value --returns", wm_metrics("--help").stdout)

    def test_frame_comparison_still_requires_ref_and_pred(self):
        p = wm_metrics()
        self.assertEqual(p.returncode, 2)  # a bad command line, as when they were required()
        self.assertEqual(p.stderr, "--ref is required\nRun with --help for more information.\n")
        p = wm_metrics("--ref", "x.png")
        self.assertEqual(p.returncode, 2)
        self.assertEqual(p.stderr, "--pred is required\nRun with --help for more information.\n")


if __name__ == "__main__":
    unittest.main(verbosity=2)
