#!/usr/bin/python3
"""wm-report end to end on report directories written here the way wm-eval writes them:
compare.csv against a NumPy re-computation of means, paired deltas, significance and ranks; every
row of every report file and of compare.csv validates against schemas/report-*.schema.json; the
same inputs give the same bytes; bad input exits 1 naming the file, line and column; `plot`
writes non-empty PNGs (and the scaling-law plot with wm-metrics' fit when wm-metrics is built)."""
import csv
import io
import json
import os
import subprocess
import tempfile
import unittest
import zlib

import jsonschema
import numpy as np

SRC = os.environ.get("WM_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", "..", ".."))
BIN = os.environ.get("WM_BIN_DIR", os.path.join(SRC, "build", "bin"))

EPISODES, HORIZON = 10, 4
POLICIES = ["expert", "noisy", "random", "wrong_goal"]
PER_EPISODE = ["psnr", "ssim", "mse", "lpips_style", "mse_arm", "return_error"]
WHOLE_SET = ["fvd_style", "value_gap", "pearson", "spearman", "kendall", "ranking_accuracy"]
HIGHER = {"psnr", "ssim", "pearson", "spearman", "kendall", "ranking_accuracy"}
INTEGER_COLUMNS = {"n", "step", "episode", "n_episodes"}


def g9(v):
    return "" if v is None or not np.isfinite(v) else "%.9g" % v


def schema(name):
    with open(os.path.join(SRC, "schemas", name), encoding="utf-8") as f:
        return json.load(f)


def typed(row):
    """A CSV row as the schemas see it: empty -> None, numbers -> int / float."""
    out = {}
    for k, v in row.items():
        if v == "":
            out[k] = None
        elif (k in INTEGER_COLUMNS or k.endswith("_rank") or k.endswith("_significant")
              or k.endswith("_beats_copy_last")):
            out[k] = int(v)
        elif k in ("checkpoint", "rollout", "metric", "policy_id"):
            out[k] = v
        else:
            out[k] = float(v)
    return out


def read_rows(path):
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def wm_report(*args):
    return subprocess.run([os.path.join(BIN, "wm-report"), *args], capture_output=True, text=True)


def write_report(root, name, episodes, whole, scale=None):
    """episodes[rollout][metric]: per-episode values (NaN: empty); whole[rollout][metric]: value."""
    d = os.path.join(root, name)
    os.makedirs(d)
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    summary = ["checkpoint,rollout,metric,mean,ci_low,ci_high,n"]
    per_episode = ["checkpoint,rollout,episode,policy_id,metric,value"]
    per_step = ["checkpoint,rollout,step,metric,mean,ci_low,ci_high,n"]
    for rollout, metrics in episodes.items():
        for metric, v in metrics.items():
            ok = v[np.isfinite(v)]
            boot = [np.mean(rng.choice(ok, ok.size)) for _ in range(200)]
            summary.append(f"{name},{rollout},{metric},{g9(ok.mean())},"
                           f"{g9(np.percentile(boot, 2.5))},{g9(np.percentile(boot, 97.5))},"
                           f"{ok.size}")
            for k, x in enumerate(v):
                per_episode.append(f"{name},{rollout},{k},{POLICIES[k % 4]},{metric},{g9(x)}")
            for s in range(1, HORIZON + 1):
                m = ok.mean() * (1 + 0.05 * (s - 1) * (-1 if metric in HIGHER else 1))
                per_step.append(f"{name},{rollout},{s},{metric},{g9(m)},{g9(m * 0.95)},"
                                f"{g9(m * 1.05)},{ok.size}")
    for rollout, metrics in whole.items():
        for metric, x in metrics.items():
            summary.append(f"{name},{rollout},{metric},{g9(x)},,,{len(POLICIES)}")
    values = ["checkpoint,rollout,policy_id,n_episodes,real_value,model_value,value_gap"]
    for rollout in ("plain", "retrace"):
        for i, p in enumerate(POLICIES):
            real, model = 1.0 - 0.25 * i, 1.0 - 0.25 * i + rng.normal(0, 0.1)
            values.append(f"{name},{rollout},{p},{EPISODES // 4},{g9(real)},{g9(model)},"
                          f"{g9(abs(real - model))}")
    manifest = {"checkpoint": {"name": name, "path_basename": name, "sha256": "ab" * 32,
                               "step": 100},
                "tokenizer": {"sha256": "cd" * 32}, "data": {"split": "val"},
                "config": {"horizon": HORIZON}, "config_hash": "ef" * 32, "seed": 0,
                "git_commit": "0123abc", "libraries": {}, "tool": "wm-eval"}
    if scale is not None:
        manifest["scale"] = scale
    for file, lines in (("summary.csv", summary), ("per_episode.csv", per_episode),
                        ("per_step.csv", per_step), ("values.csv", values)):
        with open(os.path.join(d, file), "w", encoding="utf-8") as f:
            f.write("\n".join(lines) + "\n")
    with open(os.path.join(d, "manifest.json"), "w", encoding="utf-8") as f:
        json.dump(manifest, f, indent=2)
    return d


class WmReport(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        root = cls.tmp.name
        rng = np.random.default_rng(0)
        base = {"psnr": 20 + rng.normal(0, 1, EPISODES), "ssim": rng.uniform(0.5, 0.7, EPISODES),
                "mse": rng.uniform(0.01, 0.02, EPISODES),
                "lpips_style": rng.uniform(0.2, 0.3, EPISODES),
                "mse_arm": rng.uniform(0.02, 0.04, EPISODES),
                "return_error": rng.uniform(0, 1, EPISODES)}
        base["psnr"][3] = np.nan  # identical frames somewhere: an undefined PSNR
        copy_last = {m: v * 1.5 for m, v in base.items()}
        # The same copy_last baseline in every report (it depends on the data only).
        cls.episodes = {}
        cls.whole = {}
        for i, name in enumerate(["small", "base", "large"]):
            better = {m: (v + 1.5 * i + 0.2 * i * rng.uniform(0, 1, EPISODES) if m in HIGHER
                          else v * (1 - 0.2 * i) + rng.normal(0, 0.001, EPISODES))
                      for m, v in base.items()}
            better["ssim"] = np.clip(base["ssim"] + 0.05 * i, 0, 1)
            if name == "large":
                better["mse_arm"] = cls.episodes["base"]["plain"]["mse_arm"]  # a tie with base
            cls.episodes[name] = {"plain": better,
                                  "retrace": {m: v * 1.01 for m, v in better.items()},
                                  "copy_last": copy_last}
            cls.whole[name] = {r: {"fvd_style": 50.0 - 10 * i, "value_gap": 0.3 - 0.1 * i,
                                   "pearson": 0.5 + 0.2 * i, "spearman": 0.4 + 0.2 * i,
                                   "kendall": 0.3 + 0.2 * i, "ranking_accuracy": 0.5 + 0.25 * i}
                               for r in ("plain", "retrace")}
            cls.whole[name]["copy_last"] = {"fvd_style": 80.0}
        cls.dirs = [write_report(root, n, cls.episodes[n], cls.whole[n], scale=4.0 ** i * 1e6)
                    for i, n in enumerate(["small", "base", "large"])]
        cls.out = os.path.join(root, "compare.csv")
        cls.md = os.path.join(root, "compare.md")
        p = wm_report("compare", *cls.dirs, "--out", cls.out, "--markdown", cls.md, "--seed", "5")
        if p.returncode != 0:
            raise AssertionError(p.stderr)
        cls.rows = read_rows(cls.out)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def metrics(self):
        with open(self.out, encoding="utf-8") as f:
            header = next(csv.reader(f))
        return [h for h in header[2:] if h + "_rank" in header]

    def summary_mean(self, name, rollout, metric):
        if metric in WHOLE_SET:
            return float(g9(self.whole[name].get(rollout, {}).get(metric, np.nan)) or "nan")
        v = self.episodes[name][rollout].get(metric)
        return np.nan if v is None else float(g9(np.nanmean(v)))

    def test_columns_follow_the_headline_order(self):
        self.assertEqual(self.metrics(), ["psnr", "ssim", "mse", "lpips_style", "fvd_style",
                                          "mse_arm", "value_gap", "pearson", "spearman",
                                          "kendall", "ranking_accuracy", "return_error"])
        self.assertEqual([(r["rollout"], r["checkpoint"]) for r in self.rows],
                         [(ro, n) for ro in ("plain", "retrace", "copy_last")
                          for n in ("small", "base", "large")])

    def test_means_deltas_and_ranks_equal_numpy(self):
        for row in self.rows:
            name, rollout = row["checkpoint"], row["rollout"]
            for m in self.metrics():
                mean = self.summary_mean(name, rollout, m)
                if np.isnan(mean):
                    self.assertEqual(row[m], "", (name, rollout, m))
                    self.assertEqual(row[m + "_rank"], "")
                    continue
                self.assertAlmostEqual(float(row[m]), mean, delta=1e-9 * max(1, abs(mean)))
                # Rank: 1 + the checkpoints of this rollout strictly better.
                others = [self.summary_mean(n, rollout, m) for n in ("small", "base", "large")]
                better = sum(1 for o in others if not np.isnan(o) and
                             (o > mean if m in HIGHER else o < mean))
                self.assertEqual(int(row[m + "_rank"]), better + 1, (name, rollout, m))
                if name == "small":  # the baseline: no delta cells
                    for s in ("_delta", "_delta_ci_low", "_delta_ci_high", "_delta_significant"):
                        self.assertEqual(row[m + s], "", (rollout, m, s))
                    continue
                if m in WHOLE_SET:
                    want = mean - self.summary_mean("small", rollout, m)
                    self.assertAlmostEqual(float(row[m + "_delta"]), want, delta=1e-8)
                    self.assertEqual(row[m + "_delta_ci_low"], "")
                    self.assertEqual(row[m + "_delta_significant"], "")
                    continue
                a = np.array([float(g9(x) or "nan") for x in self.episodes[name][rollout][m]])
                b = np.array([float(g9(x) or "nan")
                              for x in self.episodes["small"][rollout][m]])
                both = np.isfinite(a) & np.isfinite(b)
                diff = a[both] - b[both]
                # %.9g keeps 9 significant digits: a relative rounding of at most 5e-9.
                self.assertAlmostEqual(float(row[m + "_delta"]), diff.mean(),
                                       delta=1e-8 * max(1, abs(diff.mean())))
                lo, hi = float(row[m + "_delta_ci_low"]), float(row[m + "_delta_ci_high"])
                self.assertLessEqual(lo, hi)
                self.assertEqual(int(row[m + "_delta_significant"]), int(lo > 0 or hi < 0))
                # The interval's width matches NumPy's paired bootstrap.
                if np.ptp(diff) > 1e-6 * max(1, abs(diff.mean())):
                    rng = np.random.default_rng(1)
                    boot = diff[rng.integers(0, diff.size, (4000, diff.size))].mean(axis=1)
                    ref = np.percentile(boot, 97.5) - np.percentile(boot, 2.5)
                    self.assertLess(abs((hi - lo) / ref - 1), 0.35, (name, rollout, m))

    def test_each_row_against_its_own_copy_last_equals_numpy(self):
        """m_vs_copy_last: the mean paired difference to the same report's copy_last (the whole-
        set difference for fvd_style, empty where copy_last lacks the metric); m_beats_copy_last:
        the interval's side of 0 in the metric's direction."""
        verdicts = set()
        for row in self.rows:
            name, rollout = row["checkpoint"], row["rollout"]
            for m in self.metrics():
                cells = [row[m + s] for s in ("_vs_copy_last", "_vs_copy_last_ci_low",
                                              "_vs_copy_last_ci_high", "_beats_copy_last")]
                if rollout == "copy_last" or m not in PER_EPISODE + ["fvd_style"]:
                    self.assertEqual(cells, [""] * 4, (name, rollout, m))
                    continue
                if m == "fvd_style":
                    want = self.whole[name][rollout][m] - self.whole[name]["copy_last"][m]
                    self.assertAlmostEqual(float(cells[0]), want, delta=1e-8)
                    self.assertEqual(cells[1:], [""] * 3)
                    continue
                a, b = (np.array([float(g9(x) or "nan") for x in self.episodes[name][r][m]])
                        for r in (rollout, "copy_last"))
                both = np.isfinite(a) & np.isfinite(b)
                diff = a[both] - b[both]
                self.assertAlmostEqual(float(cells[0]), diff.mean(),
                                       delta=1e-8 * max(1, abs(diff.mean())), msg=(name, m))
                lo, hi = float(cells[1]), float(cells[2])
                self.assertLessEqual(diff.min() - 1e-9, lo)
                self.assertLessEqual(lo, hi)
                self.assertLessEqual(hi, diff.max() + 1e-9)
                better = (lo > 0) if m in HIGHER else (hi < 0)
                worse = (hi < 0) if m in HIGHER else (lo > 0)
                self.assertEqual(int(cells[3]), 1 if better else -1 if worse else 0, (name, m))
                verdicts.add(int(cells[3]))
        # copy_last is 1.5x the baseline checkpoint: higher PSNR (worse for the models), higher
        # MSE (better for them) -- both signs occur.
        self.assertTrue({1, -1} <= verdicts, verdicts)

    def test_better_on_every_episode_is_significant_and_identical_is_not(self):
        rows = {(r["checkpoint"], r["rollout"]): r for r in self.rows}
        self.assertEqual(rows[("large", "plain")]["psnr_delta_significant"], "1")
        self.assertEqual(rows[("large", "plain")]["psnr_rank"], "1")
        self.assertEqual(rows[("base", "copy_last")]["psnr_delta_significant"], "0")
        self.assertEqual(rows[("base", "copy_last")]["psnr_delta"], "0")
        self.assertEqual(rows[("large", "plain")]["mse_arm_rank"], "1")  # tied with base
        self.assertEqual(rows[("base", "plain")]["mse_arm_rank"], "1")

    def test_rows_validate_against_the_schemas(self):
        compare = jsonschema.Draft202012Validator(schema("report-compare.schema.json"))
        for row in self.rows:
            compare.validate(typed(row))
        for file, name in (("summary.csv", "report-summary"), ("per_step.csv", "report-per-step"),
                           ("per_episode.csv", "report-per-episode"),
                           ("values.csv", "report-values")):
            validator = jsonschema.Draft202012Validator(schema(name + ".schema.json"))
            for d in self.dirs:
                rows = read_rows(os.path.join(d, file))
                self.assertTrue(rows)
                self.assertEqual(list(rows[0].keys()),
                                 list(validator.schema["required"]))  # documented header order
                for row in rows:
                    validator.validate(typed(row))
        manifest = jsonschema.Draft202012Validator(schema("report-manifest.schema.json"))
        for d in self.dirs:
            with open(os.path.join(d, "manifest.json"), encoding="utf-8") as f:
                manifest.validate(json.load(f))
        with self.assertRaises(jsonschema.ValidationError):
            compare.validate({"checkpoint": "a", "rollout": "plain", "psnr_rank": 0})

    def test_same_inputs_same_bytes_and_options_select(self):
        out2, md2 = self.out + ".2", self.md + ".2"
        p = wm_report("compare", *self.dirs, "--out", out2, "--markdown", md2, "--seed", "5")
        self.assertEqual(p.returncode, 0, p.stderr)
        for a, b in ((self.out, out2), (self.md, md2)):
            with open(a, "rb") as fa, open(b, "rb") as fb:
                self.assertEqual(fa.read(), fb.read())
        with open(self.md, encoding="utf-8") as f:
            md = f.read()
        self.assertIn("| checkpoint | rollout | psnr ↑ | Δ psnr |", md)
        self.assertIn("| checkpoint | rollout | Δ psnr ↑ | Δ ssim ↑ |", md)  # against copy_last
        # --metrics before the directories takes one argument, not the directories too.
        p = wm_report("compare", "--metrics", "mse,value_gap", *self.dirs, "--out", out2,
                      "--baseline", "large", "--rollout", "plain")
        self.assertEqual(p.returncode, 0, p.stderr)
        rows = read_rows(out2)
        self.assertEqual([r["checkpoint"] for r in rows], ["small", "base", "large"])
        self.assertEqual(list(rows[0])[2:4], ["mse", "mse_ci_low"])
        self.assertEqual(len(rows[0]), 2 + 2 * (8 + 4))  # + 4 against copy_last per metric
        self.assertEqual(rows[0]["value_gap_vs_copy_last"], "")  # copy_last has no value_gap
        self.assertEqual(rows[2]["mse_delta"], "")
        self.assertGreater(float(rows[0]["mse_delta"]), 0)

    def test_bad_input_exits_1_naming_file_line_and_column(self):
        root = os.path.join(self.tmp.name, "bad")
        good = write_report(root, "good", self.episodes["small"], self.whole["small"])
        bad = write_report(root, "bad", self.episodes["base"], self.whole["base"])
        out = os.path.join(root, "c.csv")

        def fails(expect, *args):
            p = wm_report("compare", good, bad, "--out", out, *args)
            self.assertEqual(p.returncode, 1, p.stderr)
            for e in expect:
                self.assertIn(e, p.stderr)

        fails(["unknown metric 'sharpness'"], "--metrics", "psnr,sharpness")
        path = os.path.join(bad, "per_episode.csv")
        with open(path, encoding="utf-8") as f:
            text = f.read()
        with open(path, "w", encoding="utf-8") as f:
            f.write(text.replace("metric,value", "metric,score", 1))
        fails([f"{path}: line 1", "missing column 'value'"])
        with open(path, "w", encoding="utf-8") as f:
            f.write(text.replace("bad,plain,0,expert,psnr,", "bad,plain,0,expert,psnr,1,", 1))
        fails([f"{path}: line 2", "cells, but the header has 6 columns"])
        with open(path, "w", encoding="utf-8") as f:
            f.write(text.replace("bad,plain,1,noisy,psnr,", "bad,plain,1,noisy,psnr,x", 1))
        fails([f"{path}: line 3", "column 'value'", "is not a number"])
        os.remove(path)
        fails([path, "missing file"])
        self.assertEqual(wm_report("compare", good).returncode, 2)  # no --out: usage

    def test_help_and_version(self):
        for args in (("--help",), ("compare", "--help"), ("plot", "--help")):
            p = wm_report(*args)
            self.assertEqual(p.returncode, 0, p.stderr)
            self.assertIn("Example", p.stdout)
        self.assertIn("wm-report", wm_report("--version").stdout)

    def test_plot_writes_non_empty_pngs(self):
        out = os.path.join(self.tmp.name, "plots")
        p = wm_report("plot", *self.dirs, "--out", out, "--scaling-metric", "mse")
        self.assertEqual(p.returncode, 0, p.stderr)
        names = ["step_psnr.png", "step_mse.png", "step_lpips_style.png", "values.png",
                 "scaling_mse_plain.png"]
        for name in names:
            path = os.path.join(out, name)
            self.assertTrue(os.path.isfile(path), p.stdout + p.stderr)
            with open(path, "rb") as f:
                data = f.read()
            self.assertTrue(data.startswith(b"\x89PNG\r\n\x1a\n"), name)
            self.assertGreater(len(data), 2000, name)
        points = read_rows(os.path.join(out, "scaling_points.csv"))
        self.assertEqual([r["label"] for r in points], ["small", "base", "large"])
        if os.path.isfile(os.path.join(BIN, "wm-metrics")):
            with open(os.path.join(out, "scaling_fit.json"), encoding="utf-8") as f:
                fit = json.load(f)
            jsonschema.validate(fit, schema("scaling-fit.schema.json"))
            self.assertEqual(fit["points"], 3)
        else:
            self.assertIn("fit skipped", p.stderr)

    def test_plot_bad_input_exits_1_naming_the_file(self):
        empty = os.path.join(self.tmp.name, "empty")
        os.makedirs(empty, exist_ok=True)
        p = wm_report("plot", empty, "--out", os.path.join(self.tmp.name, "p2"))
        self.assertEqual(p.returncode, 1)
        self.assertIn(os.path.join(empty, "manifest.json"), p.stderr)
        p = wm_report("plot", *self.dirs, "--out", os.path.join(self.tmp.name, "p3"),
                      "--metrics", "nope")
        self.assertEqual(p.returncode, 1)
        self.assertIn("metric 'nope' is in no per_step.csv", p.stderr)


if __name__ == "__main__":
    unittest.main(verbosity=2)
