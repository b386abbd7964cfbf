#!/usr/bin/python3
"""scripts/eval.sh's split of scoring and comparing (make demo scores the token model while
the motion model trains): REPORT=0 scores without comparing; SCORED="NAME..." skips the
scoring of reports already written, still comparing them, in the order given (the first is
the baseline); a SCORED name without its report, or whose report scored another checkpoint
(a retrained one), is refused; EVAL_JOBS=N scores as N shard jobs at once, then compares once.
Runs eval.sh against a BIN of
recording shell scripts in place of wm-eval and wm-report (the tools have their own tests);
well under a second."""
import os
import stat
import subprocess
import tempfile
import unittest

SRC = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")

# Appends its name and arguments to $CALLS; wm-eval writes each --name's manifest with its
# checkpoint's sha256 and wm-report its --markdown table, as the real ones do.
RECORDER = """#!/usr/bin/env bash
echo "$(basename "$0") $*" >> "$CALLS"
# FAIL_ON: a call whose arguments contain it fails, as a crashed job would.
if [ -n "${FAIL_ON:-}" ] && [[ "$*" == *"$FAIL_ON"* ]]; then exit 3; fi
if [ "$(basename "$0")" = wm-eval ]; then
  out="" names=() checkpoints=() list=""
  while [ $# -gt 0 ]; do
    case "$1" in
      --out) out=$2; shift; list="" ;;
      --name) list=names ;;
      --checkpoint) list=checkpoints ;;
      --*) list="" ;;
      *) [ "$list" = names ] && names+=("$1"); [ "$list" = checkpoints ] && checkpoints+=("$1") ;;
    esac
    shift
  done
  for i in "${!names[@]}"; do
    sha=$(sha256sum "${checkpoints[$i]}/checkpoint.wmt" | cut -d' ' -f1)
    mkdir -p "$out/${names[$i]}"
    echo "{\\"checkpoint\\": {\\"sha256\\": \\"$sha\\"}}" > "$out/${names[$i]}/manifest.json"
  done
fi
while [ $# -gt 0 ]; do
  [ "$1" = --markdown ] && echo "| table |" > "$2"
  shift
done
"""


class EvalScriptTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.bin = os.path.join(self.tmp.name, "bin")
        os.mkdir(self.bin)
        for tool in ("wm-eval", "wm-report"):
            path = os.path.join(self.bin, tool)
            with open(path, "w") as f:
                f.write(RECORDER)
            os.chmod(path, os.stat(path).st_mode | stat.S_IEXEC)
        self.calls = os.path.join(self.tmp.name, "calls")
        self.reports = os.path.join(self.tmp.name, "reports")
        for run in ("r/early/dynamics", "r/dynamics", "r/motion"):
            self.write_checkpoint(run, run)

    def write_checkpoint(self, run, content):
        os.makedirs(os.path.join(self.tmp.name, run), exist_ok=True)
        with open(os.path.join(self.tmp.name, run, "checkpoint.wmt"), "w") as f:
            f.write(content)

    def tearDown(self):
        self.tmp.cleanup()

    def eval_sh(self, checkpoints, **env):
        open(self.calls, "w").close()
        # The checkpoints as relative paths, from the directory that holds them.
        script = os.path.join(SRC, "scripts", "eval.sh")
        out = subprocess.run(["bash", script, self.bin, self.reports, "tok", "val",
                              "val_tokens", *checkpoints], cwd=self.tmp.name, capture_output=True,
                             text=True, env={**os.environ, "CALLS": self.calls, **env})
        with open(self.calls) as f:
            return out, f.read().splitlines()

    def test_report_0_scores_without_comparing(self):
        out, calls = self.eval_sh(["r/early/dynamics", "r/dynamics"], REPORT="0")
        self.assertEqual(out.returncode, 0, out.stderr)
        self.assertEqual(len(calls), 1)
        self.assertIn("--checkpoint r/early/dynamics r/dynamics --name early r", calls[0])

    def test_scored_reports_are_compared_not_scored_again(self):
        self.eval_sh(["r/early/dynamics", "r/dynamics"], REPORT="0")
        out, calls = self.eval_sh(["r/early/dynamics", "r/dynamics", "r/motion"],
                                  SCORED="early r")
        self.assertEqual(out.returncode, 0, out.stderr)
        self.assertTrue(calls[0].startswith("wm-eval --checkpoint r/motion --name motion "),
                        calls[0])
        compare = [c for c in calls if c.startswith("wm-report compare")]
        self.assertEqual(len(compare), 1)
        r = self.reports
        self.assertIn(f"compare {r}/early {r}/r {r}/motion --baseline early", compare[0])

    def test_a_scored_name_without_its_report_is_refused(self):
        out, calls = self.eval_sh(["r/early/dynamics", "r/motion"], SCORED="early")
        self.assertNotEqual(out.returncode, 0)
        self.assertIn("SCORED names early", out.stderr)
        self.assertIn("manifest.json is missing", out.stderr)
        self.assertEqual(calls, [])

    def test_a_scored_report_of_another_checkpoint_is_refused(self):
        self.eval_sh(["r/early/dynamics", "r/dynamics"], REPORT="0")
        self.write_checkpoint("r/dynamics", "retrained")
        out, calls = self.eval_sh(["r/early/dynamics", "r/dynamics", "r/motion"],
                                  SCORED="early r")
        self.assertNotEqual(out.returncode, 0)
        self.assertIn("SCORED names r, but", out.stderr)
        self.assertIn("drop r from SCORED", out.stderr)
        self.assertEqual(calls, [])

    def test_eval_jobs_scores_as_shard_jobs_then_compares_once(self):
        out, calls = self.eval_sh(["r/early/dynamics", "r/motion"], EVAL_JOBS="2")
        self.assertEqual(out.returncode, 0, out.stderr)
        scoring = sorted(c for c in calls if c.startswith("wm-eval"))
        self.assertEqual(len(scoring), 2, calls)
        for i, call in enumerate(scoring):
            self.assertIn("--name early motion ", call)
            self.assertTrue(call.endswith(f"--shard-index {i} --num-shards 2"), call)
        self.assertEqual(len([c for c in calls if c.startswith("wm-report compare")]), 1)

    def test_a_failed_shard_job_fails_the_script_before_comparing(self):
        out, calls = self.eval_sh(["r/early/dynamics", "r/motion"], EVAL_JOBS="2",
                                  FAIL_ON="--shard-index 1 ")
        self.assertEqual(out.returncode, 1)
        self.assertIn("a wm-eval shard job failed", out.stderr)
        self.assertEqual([c for c in calls if c.startswith("wm-report")], [])

    def test_eval_jobs_must_be_a_positive_integer(self):
        for bad in ("0", "two", "-1"):
            out, calls = self.eval_sh(["r/early/dynamics"], EVAL_JOBS=bad)
            self.assertEqual(out.returncode, 2, bad)
            self.assertIn("EVAL_JOBS must be a positive integer", out.stderr)
            self.assertEqual(calls, [])


if __name__ == "__main__":
    unittest.main()
