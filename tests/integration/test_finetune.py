#!/usr/bin/python3
"""`make finetune` on a reduced configuration (a few episodes and steps; about 30 s on 2 cores):
the whole chain writes finetune.csv with the three models and copy_last, finetune_summary.json,
strips and a manifest, each valid against its schema; the fine-tuned run started from the
pretrained checkpoint (its provenance names the parent's SHA-256) and the other two did not; the
summary's gains equal a recomputation from the reports' per-episode values and from
finetune.csv, and their intervals are compare.csv's, oriented so positive = better; a rerun
skips every finished stage and gives the same bytes; a bad config is one line naming the key."""
import csv
import json
import math
import os
import sys
import unittest

import cv2
import jsonschema
import numpy as np
import yaml

from experiment_files import SRC, run_experiment, schema, set_up_experiment, sha256, typed

MODELS = ["finetuned", "scratch", "pretrained"]
EVAL_EPISODES, STRIPS, HORIZON = 3, 2, 4
TEXT_COLUMNS = {"model", "rollout", "init_from_sha256"}


def per_episode(report, metric, rollout="plain"):
    """episode -> value of one report's per_episode.csv."""
    with open(os.path.join(report, "per_episode.csv"), encoding="utf-8") as f:
        return {int(r["episode"]): float(r["value"]) for r in csv.DictReader(f)
                if r["metric"] == metric and r["rollout"] == rollout and r["value"]}


def summary_mismatches(summary, reports_dir, rows, compare):
    """Every way the summary disagrees with a recomputation; empty when it agrees. Gains from the
    per-episode values (mean of paired differences) and from finetune.csv's means; intervals from
    compare.csv, negated and swapped for mse_arm, inside the range of the paired differences."""
    bad = []
    for metric, sign in (("psnr", 1), ("mse_arm", -1)):
        ft = per_episode(os.path.join(reports_dir, "finetuned"), metric)
        sc = per_episode(os.path.join(reports_dir, "scratch"), metric)
        diffs = sign * np.array([ft[k] - sc[k] for k in sorted(ft) if k in sc])
        gain = summary[f"{metric}_gain_vs_scratch"]
        lo, hi = summary[f"{metric}_gain_ci_low"], summary[f"{metric}_gain_ci_high"]
        scale = max(1.0, abs(float(diffs.mean())))
        if len(diffs) != summary["episodes"]:
            bad.append(f"{metric}: {len(diffs)} paired episodes, the summary "
                       f"{summary['episodes']}")
        if not math.isclose(gain, float(diffs.mean()), rel_tol=1e-6, abs_tol=1e-7 * scale):
            bad.append(f"{metric}: gain {gain} != mean paired difference {diffs.mean()}")
        by_means = sign * (float(rows["finetuned"][metric]) - float(rows["scratch"][metric]))
        if not math.isclose(gain, by_means, rel_tol=1e-6, abs_tol=1e-6 * scale):
            bad.append(f"{metric}: gain {gain} != finetune.csv means' difference {by_means}")
        c = compare[("finetuned", "plain")]
        want = sorted(sign * float(c[f"{metric}_delta_ci_{s}"]) for s in ("low", "high"))
        if [lo, hi] != [w + 0.0 for w in want]:
            bad.append(f"{metric}: interval [{lo}, {hi}] != compare.csv's oriented {want}")
        tol = 1e-6 * scale
        if not (diffs.min() - tol <= lo <= gain + tol and gain - tol <= hi <= diffs.max() + tol):
            bad.append(f"{metric}: interval [{lo}, {hi}] is not around {gain} within the paired "
                       f"differences [{diffs.min()}, {diffs.max()}]")
    return bad


def reduced_config(path):
    with open(os.path.join(SRC, "configs", "finetune", "tiny.yaml"), encoding="utf-8") as f:
        cfg = yaml.safe_load(f)
    cfg["data"]["pretrain"].update(train_episodes=4, val_episodes=2)
    cfg["data"]["finetune"].update(train_episodes=3, eval_episodes=EVAL_EPISODES)
    cfg["tokenizer"]["steps"] = 5
    cfg["dynamics"].update(pretrain_steps=3, finetune_steps=2, threads=1)
    cfg["eval"].update(horizon=HORIZON, resamples=50, strips=STRIPS)
    with open(path, "w", encoding="utf-8") as f:
        yaml.safe_dump(cfg, f)
    return cfg


class FinetuneTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        set_up_experiment(cls, "finetune", reduced_config,
                          ["finetune.csv", "finetune_summary.json", "strips/episode_0.png"])
        with open(os.path.join(cls.out, "finetune.csv"), encoding="utf-8") as f:
            cls.rows = list(csv.DictReader(f))
        with open(os.path.join(cls.out, "finetune_summary.json"), encoding="utf-8") as f:
            cls.summary = json.load(f)
        with open(os.path.join(cls.out, "compare.csv"), encoding="utf-8") as f:
            cls.compare = {(r["checkpoint"], r["rollout"]): r for r in csv.DictReader(f)}

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def path(self, *parts):
        return os.path.join(self.out, *parts)

    def by_model(self):
        return {r["model"]: r for r in self.rows}

    def test_three_models_and_copy_last_have_rows_valid_against_the_schema(self):
        self.assertEqual([r["model"] for r in self.rows], [*MODELS, "copy_last"])
        self.assertEqual([r["rollout"] for r in self.rows], ["plain"] * 3 + ["copy_last"])
        validator = jsonschema.Draft202012Validator(schema("finetune-row"))
        for row in self.rows:
            validator.validate(typed(row, TEXT_COLUMNS))
            self.assertEqual(int(row["n_episodes"]), EVAL_EPISODES)
            for m in ["psnr", "mse_arm"]:
                mean, lo, hi = (float(row[m + s]) for s in ["", "_ci_low", "_ci_high"])
                self.assertTrue(lo - 1e-9 <= mean <= hi + 1e-9, (row["model"], m))
        rows = self.by_model()
        self.assertEqual(rows["scratch"]["psnr_vs_scratch"], "")  # the baseline itself
        self.assertEqual(rows["copy_last"]["psnr_vs_scratch"], "")
        self.assertNotEqual(rows["pretrained"]["psnr_vs_scratch"], "")
        d = self.cfg["dynamics"]
        self.assertEqual(int(rows["finetuned"]["train_steps"]), d["finetune_steps"])
        self.assertEqual(int(rows["scratch"]["train_steps"]), d["finetune_steps"])
        self.assertEqual(int(rows["pretrained"]["train_steps"]), d["pretrain_steps"])
        self.assertEqual(int(rows["finetuned"]["train_episodes"]), 3)
        with self.assertRaises(jsonschema.ValidationError):  # the schema can fail
            validator.validate({**typed(self.rows[0], TEXT_COLUMNS), "model": "other"})

    def test_the_finetuned_run_started_from_the_pretrained_checkpoint(self):
        def checkpoint_json(model):
            with open(self.path(model, "dynamics", "checkpoint.json"), encoding="utf-8") as f:
                return json.load(f)
        parent = checkpoint_json("pretrained")
        init = checkpoint_json("finetuned").get("init_from")
        self.assertIsNotNone(init, "the fine-tune records no parent")
        self.assertEqual(init["checkpoint_sha256"],
                         sha256(self.path("pretrained", "dynamics", "checkpoint.wmt")))
        self.assertEqual(init["config_hash"], parent["config_hash"])
        self.assertEqual(init["step"], self.cfg["dynamics"]["pretrain_steps"])
        self.assertNotIn("init_from", checkpoint_json("scratch"))
        self.assertNotIn("init_from", parent)
        rows = self.by_model()
        self.assertEqual(rows["finetuned"]["init_from_sha256"], init["checkpoint_sha256"])
        self.assertEqual(rows["scratch"]["init_from_sha256"], "")
        # All three on tokens of the one pretrained tokenizer; the fine-tune on the new scene.
        tokenizer = sha256(self.path("tokenizer", "checkpoint.wmt"))
        for m in MODELS:
            self.assertEqual(checkpoint_json(m)["tokenizer"]["checkpoint_sha256"], tokenizer, m)
        finetune_data = [d["index_sha256"] for d in checkpoint_json("finetuned")["data"]]
        self.assertEqual(finetune_data, [sha256(self.path("tokens", "finetune_train",
                                                          "index.json"))])

    def test_summary_equals_a_recomputation_and_validates(self):
        jsonschema.validate(self.summary, schema("finetune-summary"))
        self.assertEqual(self.summary["episodes"], EVAL_EPISODES)
        bad = summary_mismatches(self.summary, self.path("reports"), self.by_model(), self.compare)
        self.assertEqual(bad, [])

    def test_a_wrong_summary_is_caught(self):
        """The recomputation can fail: each tampered number is reported."""
        for key, change in [("psnr_gain_vs_scratch", 0.01), ("mse_arm_gain_vs_scratch", 1.0),
                            ("psnr_gain_ci_low", -0.5), ("mse_arm_gain_ci_high", 3.0)]:
            tampered = {**self.summary, key: self.summary[key] + change}
            bad = summary_mismatches(tampered, self.path("reports"), self.by_model(),
                                     self.compare)
            self.assertTrue(bad, key)
        flipped = {**self.summary, "mse_arm_gain_vs_scratch":
                   -self.summary["mse_arm_gain_vs_scratch"] + 1e-3}
        self.assertTrue(summary_mismatches(flipped, self.path("reports"), self.by_model(),
                                           self.compare))

    def test_gains_are_oriented_so_positive_is_better(self):
        """At this scale all three models still copy (every gain 0), so the orientation is
        checked on a compare.csv row with known deltas."""
        sys.path.insert(0, os.path.join(SRC, "scripts"))
        import finetune  # noqa: E402
        row = {"psnr_delta": "0.5", "psnr_delta_ci_low": "0.1", "psnr_delta_ci_high": "0.9",
               "mse_arm_delta": "-30", "mse_arm_delta_ci_low": "-50",
               "mse_arm_delta_ci_high": "-10"}
        s = finetune.summary_from_compare(row, 16, 1000, 0)
        self.assertEqual([s["psnr_gain_vs_scratch"], s["psnr_gain_ci_low"],
                          s["psnr_gain_ci_high"]], [0.5, 0.1, 0.9])
        self.assertEqual([s["mse_arm_gain_vs_scratch"], s["mse_arm_gain_ci_low"],
                          s["mse_arm_gain_ci_high"]], [30.0, 10.0, 50.0])
        jsonschema.validate(s, schema("finetune-summary"))
        row.update(psnr_delta_ci_low="", psnr_delta_ci_high="")  # no interval: null
        self.assertIsNone(finetune.summary_from_compare(row, 1, 1000, 0)["psnr_gain_ci_low"])

    def test_strips_show_the_three_models_on_the_same_episodes(self):
        cell = 64 * 3  # 64 px frames drawn 3x (evaluate/episode_strip.h)
        for k in range(STRIPS):
            picture = cv2.imread(self.path("strips", f"episode_{k}.png"))
            self.assertIsNotNone(picture, k)
            source = cv2.imread(self.path("reports", "scratch", "strips", f"episode_{k}.png"))
            self.assertEqual(picture.shape[0], 24 + 5 * (cell + 2))  # real, 3 models, copy_last
            self.assertEqual(picture.shape[1], source.shape[1])
            # The scratch row (third) is the scratch report's plain row, frames untouched.
            y_src, y_out = 24 + (cell + 2), 24 + 3 * (cell + 2)
            np.testing.assert_array_equal(picture[y_out:y_out + cell, 144:],
                                          source[y_src:y_src + cell, 144:])
        self.assertFalse(os.path.exists(self.path("strips", f"episode_{STRIPS}.png")))

    def test_manifest_validates_and_names_every_input_and_output(self):
        with open(self.path("manifest.json"), encoding="utf-8") as f:
            manifest = json.load(f)
        jsonschema.validate(manifest, schema("finetune-manifest"))
        self.assertEqual(manifest["files"]["finetune.csv"], sha256(self.path("finetune.csv")))
        self.assertEqual(manifest["models"]["finetuned"]["init_from"]["checkpoint_sha256"],
                         manifest["models"]["pretrained"]["checkpoint_sha256"])
        self.assertIsNone(manifest["models"]["scratch"]["init_from"])
        self.assertEqual(manifest["config_sha256"], sha256(self.config))

    def test_rerun_skips_finished_work_and_gives_the_same_bytes(self):
        p = run_experiment("finetune", self.config, self.out)
        self.assertEqual(p.returncode, 0, p.stdout + p.stderr)
        commands = [line for line in p.stdout.splitlines() if line.startswith("+ ")]
        for tool in ["wm-gen-tabletop", "wm-ingest", "wm-tokenize encode", "wm-eval"]:
            self.assertFalse([c for c in commands if f"/{tool} " in c], tool)
        trains = [c for c in commands if "/wm-train " in c or "/wm-tokenize train " in c]
        self.assertEqual(len(trains), 4)
        self.assertTrue(all("--resume" in c for c in trains), trains)  # finished: no-ops
        for name, data in self.bytes.items():
            with open(self.path(name), "rb") as f:
                self.assertEqual(f.read(), data, name)

    def test_a_bad_config_is_one_line_naming_the_key(self):
        bad = dict(self.cfg, data=dict(self.cfg["data"], finetune=dict(
            self.cfg["data"]["finetune"], train_episodes=0)))
        path = os.path.join(self.tmp.name, "bad.yaml")
        with open(path, "w", encoding="utf-8") as f:
            yaml.safe_dump(bad, f)
        p = run_experiment("finetune", path, os.path.join(self.tmp.name, "never"))
        self.assertNotEqual(p.returncode, 0)
        self.assertIn("data.finetune.train_episodes", p.stderr)
        self.assertIn(path, p.stderr)
        self.assertFalse(os.path.exists(os.path.join(self.tmp.name, "never")))


if __name__ == "__main__":
    unittest.main()
