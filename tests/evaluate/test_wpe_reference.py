#!/usr/bin/python3
"""WPE statistics (evaluate/wpe_report.h) against SciPy: for random sets of policy values, with
and without ties and in/out-of-distribution mixes, wpe_tool's wpe_summary.json has SciPy's
Spearman rho and Kendall tau-b, the pairwise accuracy, mean |gap| and optimism computed here, and
its wpe.csv validates against schemas/wpe-row.schema.json and the summary against
schemas/wpe-summary.schema.json. Usage: test_wpe_reference.py PATH/TO/wpe_tool"""
import csv
import itertools
import json
import math
import os
import subprocess
import sys
import tempfile
import unittest

import jsonschema
import numpy as np
from scipy import stats

TOOL = sys.argv.pop(1) if len(sys.argv) > 1 else "wpe_tool"
SRC = os.environ.get("WM_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))


def schema(name):
    with open(os.path.join(SRC, "schemas", name + ".schema.json"), encoding="utf-8") as f:
        return json.load(f)


def pairwise_accuracy(truth, model):
    """Pairs ordered differently in truth: 1 when the model orders them alike, 1/2 if tied."""
    scores = [1.0 if (truth[i] - truth[j]) * (model[i] - model[j]) > 0 else
              0.5 if model[i] == model[j] else 0.0
              for i, j in itertools.combinations(range(len(truth)), 2) if truth[i] != truth[j]]
    return sum(scores) / len(scores) if scores else math.nan


def same(a, b):
    return (a is None and math.isnan(b)) or (a is not None and abs(a - b) < 1e-12)


class WpeReference(unittest.TestCase):
    def run_tool(self, truth, model, in_dist):
        with tempfile.TemporaryDirectory() as out:
            rows = "".join(f"p{i},{int(d)},{t!r},{m!r}\n"
                           for i, (t, m, d) in enumerate(zip(truth, model, in_dist)))
            subprocess.run([TOOL, out], input=rows, text=True, check=True)
            with open(os.path.join(out, "wpe_summary.json"), encoding="utf-8") as f:
                summary = json.load(f)
            with open(os.path.join(out, "wpe.csv"), newline="", encoding="utf-8") as f:
                table = list(csv.DictReader(f))
        return summary, table

    def check(self, truth, model, in_dist):
        summary, table = self.run_tool(truth, model, in_dist)
        jsonschema.validate(summary, schema("wpe-summary"))
        row_schema = schema("wpe-row")
        for row in table:
            typed = {k: (v == "true" if k == "in_distribution" else
                         v if k == "policy" else int(v) if k.endswith("episodes") else
                         None if v == "" else float(v)) for k, v in row.items()}
            jsonschema.validate(typed, row_schema)
        truth, model = np.array(truth), np.array(model)
        gap = model - truth
        with np.errstate(invalid="ignore"), __import__("warnings").catch_warnings():
            __import__("warnings").simplefilter("ignore")
            rho = stats.spearmanr(truth, model).correlation
            tau = stats.kendalltau(truth, model).correlation
        in_dist = np.array(in_dist, dtype=bool)
        expected = {"spearman": rho, "kendall": tau,
                    "pairwise_accuracy": pairwise_accuracy(list(truth), list(model)),
                    "mean_abs_gap": np.abs(gap).mean(), "optimism": gap.mean(),
                    "optimism_in_distribution": gap[in_dist].mean() if in_dist.any() else math.nan,
                    "optimism_out_of_distribution":
                        gap[~in_dist].mean() if (~in_dist).any() else math.nan}
        for key, value in expected.items():
            self.assertTrue(same(summary[key], float(value)), f"{key}: {summary[key]} vs {value}")
        self.assertEqual(summary["num_policies"], len(truth))
        for row, g in zip(table, gap):
            self.assertAlmostEqual(float(row["gap"]), g, places=7)

    def test_random_values_match_scipy(self):
        rng = np.random.default_rng(0)
        for trial in range(40):
            n = int(rng.integers(2, 9))
            truth = rng.integers(0, 11, n) / 10  # success rates: ties are common
            model = rng.integers(0, 11, n) / 10 if trial % 2 else rng.random(n)
            self.check(list(truth), list(model), list(rng.random(n) < 0.4))

    def test_constant_model_values_are_undefined(self):
        """A model that rates every policy 0 (today's copy-the-last-frame model): no ranking."""
        summary, _ = self.run_tool([0.87, 0.65, 0.1, 0.0], [0, 0, 0, 0], [1, 0, 1, 1])
        self.assertIsNone(summary["spearman"])
        self.assertIsNone(summary["kendall"])
        self.assertEqual(summary["pairwise_accuracy"], 0.5)
        self.assertAlmostEqual(summary["optimism_out_of_distribution"], -0.65)


if __name__ == "__main__":
    unittest.main()
