#!/usr/bin/python3
"""`make scaling` on a reduced configuration (3 sizes x 2 data sizes, a few steps; about 30 s on
2 cores): scaling.csv has one row per (size, data size), each valid against its schema; the
parameter counts are the model's own (the total equals what wm-train logged, the dynamics count
is the same at every data size and grows with the size); the validation loss is the run's last
validation row; each data size is a prefix of the next; every run used the one tokenizer; every
fit is finite, converged, valid against scaling-fit.schema.json, and its extrapolation is its
own law evaluated; summary and manifest validate; a rerun skips every finished stage and gives
the same bytes; a bad config is one line naming the key."""
import csv
import json
import math
import os
import re
import subprocess
import unittest

import jsonschema
import yaml

from experiment_files import BIN, SRC, run_experiment, schema, set_up_experiment, sha256, \
    typed

SIZES = [{"d_model": 16, "num_layers": 1}, {"d_model": 32, "num_layers": 1},
         {"d_model": 32, "num_layers": 2}]
EPISODES, VAL_EPISODES, STEPS = [3, 6], 3, 3
TEXT_COLUMNS = {"size", "checkpoint_sha256"}


def reduced_config(path):
    with open(os.path.join(SRC, "configs", "scaling", "tiny.yaml"), encoding="utf-8") as f:
        cfg = yaml.safe_load(f)
    cfg["data"].update(train_episodes=EPISODES, val_episodes=VAL_EPISODES)
    cfg["tokenizer"]["steps"] = 5
    cfg["dynamics"].update(sizes=SIZES, steps=STEPS, val_batches=1, jobs=2)
    cfg["eval"].update(horizon=4, resamples=50)
    with open(path, "w", encoding="utf-8") as f:
        yaml.safe_dump(cfg, f)
    return cfg


class ScalingTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        set_up_experiment(cls, "scaling", reduced_config,
                          ["scaling.csv", "scaling_summary.json", "scaling.png", "scaling.md"])
        with open(os.path.join(cls.out, "scaling.csv"), encoding="utf-8") as f:
            cls.rows = [typed(r, TEXT_COLUMNS) for r in csv.DictReader(f)]
        with open(os.path.join(cls.out, "scaling_summary.json"), encoding="utf-8") as f:
            cls.summary = json.load(f)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def path(self, *parts):
        return os.path.join(self.out, *parts)

    def test_every_cell_has_a_row_valid_against_the_schema(self):
        names = [f"d{s['d_model']}_l{s['num_layers']}" for s in SIZES]
        self.assertEqual([(r["size"], r["train_episodes"]) for r in self.rows],
                         [(s, n) for s in names for n in EPISODES])
        validator = jsonschema.Draft202012Validator(schema("scaling-row"))
        for r in self.rows:
            validator.validate(r)
            self.assertEqual(r["train_steps"], STEPS)
            self.assertEqual(r["n_episodes"], VAL_EPISODES)
            self.assertTrue(r["psnr_ci_low"] <= r["psnr"] <= r["psnr_ci_high"], r["size"])
        with self.assertRaises(jsonschema.ValidationError):  # the schema can fail
            validator.validate({**self.rows[0], "dynamics_parameters": 0})

    def test_parameter_counts_are_the_models_own(self):
        logged = {}
        for r in self.rows:
            log = self.path("runs", f"{r['size']}_n{r['train_episodes']}.log")
            with open(log, encoding="utf-8") as f:
                counts = re.findall(r" (\d+) parameters; wrote", f.read())
            self.assertEqual(len(counts), 1, log)
            self.assertEqual(r["total_parameters"], int(counts[0]), log)
            self.assertLess(r["dynamics_parameters"], r["total_parameters"])
            logged.setdefault(r["size"], set()).add(r["dynamics_parameters"])
        self.assertTrue(all(len(v) == 1 for v in logged.values()), logged)
        by_size = [logged[f"d{s['d_model']}_l{s['num_layers']}"].pop() for s in SIZES]
        self.assertEqual(by_size, sorted(set(by_size)))  # grows with width and with depth
        # The policy embedding is the same in every run: total - dynamics is constant.
        self.assertEqual(len({r["total_parameters"] - r["dynamics_parameters"]
                              for r in self.rows}), 1)

    def test_validation_loss_is_the_runs_last_validation_row(self):
        for r in self.rows:
            with open(self.path("runs", r["size"], f"n{r['train_episodes']}", "metrics.csv"),
                      encoding="utf-8") as f:
                val = [row for row in csv.DictReader(f) if row["val_token_ce"]]
            self.assertEqual(int(val[-1]["step"]), STEPS)
            self.assertEqual(r["val_token_ce"], float(val[-1]["val_token_ce"]))

    def test_data_sizes_are_nested_and_share_one_tokenizer(self):
        def seeds(split, n):
            out = []
            for k in range(n):
                p = subprocess.run([os.path.join(BIN, "wm-shard"), "dump",
                                    self.path("shards", split), "--episode", str(k)],
                                   capture_output=True, text=True, check=True)
                out.append(re.search(r'"episode_seed":\s*(\d+)', p.stdout).group(1))
            return out
        small, large = seeds(f"train_n{EPISODES[0]}", EPISODES[0]), seeds(
            f"train_n{EPISODES[1]}", EPISODES[1])
        self.assertEqual(small, large[:EPISODES[0]])
        self.assertEqual(len(set(large)), EPISODES[1])
        tokenizer = sha256(self.path("tokenizer", "checkpoint.wmt"))
        for r in self.rows:
            with open(self.path("runs", r["size"], f"n{r['train_episodes']}", "checkpoint.json"),
                      encoding="utf-8") as f:
                ckpt = json.load(f)
            self.assertEqual(ckpt["tokenizer"]["checkpoint_sha256"], tokenizer)
            self.assertEqual(ckpt["config"]["model"]["d_model"], r["d_model"])
            self.assertEqual(ckpt["config"]["model"]["num_layers"], r["num_layers"])

    def test_fits_are_finite_converged_and_their_own_extrapolation(self):
        jsonschema.validate(self.summary, schema("scaling-summary"))
        fits = self.summary["fits"]
        self.assertEqual(len(fits), 2 * (len(EPISODES) + len(SIZES)))
        fit_schema = schema("scaling-fit")
        for f in fits:
            self.assertTrue(math.isfinite(f["a"]) and math.isfinite(f["b"]), f["name"])
            self.assertTrue(f["converged"], f["name"])
            with open(self.path(f["file"]), encoding="utf-8") as fh:
                jsonschema.validate(json.load(fh), fit_schema)
            cut = [r for r in self.rows if all(r[k] == v for k, v in f["held"].items())]
            self.assertEqual(f["x"], sorted(r[f["against"]] for r in cut), f["name"])
            self.assertEqual(f["y"], [r[f["metric"]] for r in sorted(cut, key=lambda r:
                                                                      r[f["against"]])])
            self.assertAlmostEqual(f["change"], (f["y"][-1] - f["y"][0]) / f["y"][0])
            for e in f["extrapolation"]:
                self.assertTrue(math.isclose(e["y"], f["a"] * e["x"] ** -f["b"], rel_tol=1e-9))
        # Three sizes: the fit against parameters has a standard error; two data sizes: none.
        by_name = {f["name"]: f for f in fits}
        self.assertIsNotNone(by_name["val_token_ce_vs_parameters_n6"]["b_std_error"])
        self.assertIsNone(by_name["val_token_ce_vs_episodes_d32_l2"]["b_std_error"])
        self.assertEqual(self.summary["headline"]["val_token_ce_vs_parameters"]["name"],
                         "val_token_ce_vs_parameters_n6")

    def test_manifest_validates_and_names_every_input_and_output(self):
        with open(self.path("manifest.json"), encoding="utf-8") as f:
            manifest = json.load(f)
        jsonschema.validate(manifest, schema("scaling-manifest"))
        for name in self.bytes:
            self.assertEqual(manifest["files"][name], sha256(self.path(name)), name)
        self.assertEqual(manifest["config_sha256"], sha256(self.config))
        self.assertEqual(len(manifest["runs"]), len(SIZES) * len(EPISODES))
        for r in self.rows:
            run = manifest["runs"][f"{r['size']}_n{r['train_episodes']}"]
            self.assertEqual(run["checkpoint_sha256"], r["checkpoint_sha256"])
            self.assertEqual(run["step"], STEPS)

    def test_rerun_skips_finished_work_and_gives_the_same_bytes(self):
        p = run_experiment("scaling", self.config, self.out)
        self.assertEqual(p.returncode, 0, p.stdout + p.stderr)
        commands = [line for line in p.stdout.splitlines() if line.startswith("+ ")]
        for tool in ["wm-gen-tabletop", "wm-ingest", "wm-tokenize encode", "wm-eval"]:
            self.assertFalse([c for c in commands if f"/{tool} " in c], tool)
        trains = [c for c in commands if "/wm-train " in c or "/wm-tokenize train " in c]
        self.assertEqual(len(trains), 1 + len(SIZES) * len(EPISODES))
        self.assertTrue(all("--resume" in c for c in trains), trains)  # finished: no-ops
        for name, data in self.bytes.items():
            with open(self.path(name), "rb") as f:
                self.assertEqual(f.read(), data, name)

    def test_a_bad_config_is_one_line_naming_the_key(self):
        for key, bad in [("data.train_episodes", dict(self.cfg["data"], train_episodes=[6, 3])),
                         ("dynamics.sizes[1]", dict(self.cfg["dynamics"],
                                                    sizes=[SIZES[0], {"d_model": 8}]))]:
            section = key.split(".")[0]
            path = os.path.join(self.tmp.name, "bad.yaml")
            with open(path, "w", encoding="utf-8") as f:
                yaml.safe_dump({**self.cfg, section: bad}, f)
            p = run_experiment("scaling", path, os.path.join(self.tmp.name, "never"))
            self.assertNotEqual(p.returncode, 0)
            self.assertIn(key, p.stderr)
            self.assertIn(path, p.stderr)
            self.assertEqual(len(p.stderr.strip().splitlines()), 1, p.stderr)
            self.assertFalse(os.path.exists(os.path.join(self.tmp.name, "never")))


if __name__ == "__main__":
    unittest.main()
