#!/usr/bin/python3
"""`wm-metrics value` against independent references, to 1e-9:

- per-policy values, value gap (plain and normalised), optimism, top-1 agreement and pairwise
  accuracy against the NumPy implementations below, written from docs/metrics-value.md;
- Pearson, Spearman and Kendall tau-b (across policies and across episodes) against
  scipy.stats.pearsonr, spearmanr and kendalltau (variant 'b');
- the stratified percentile bootstrap against the same scheme re-implemented here, with a
  pure-Python std::mt19937_64, so every interval must match exactly.

Data: continuous random returns, 0/1 success returns (many ties), integer returns with policies
tied in value, two policies, one policy, constant returns. Every JSON output is validated against
schemas/value-metrics.schema.json.

Run: /usr/bin/python3 tests/metrics/value/test_value_reference.py (after building wm-metrics)
"""
import csv
import io
import json
import math
import os
import subprocess
import tempfile
import unittest
import warnings

import jsonschema
import numpy as np
import scipy.stats

SRC = os.environ.get("WM_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", "..", ".."))
BIN = os.environ.get("WM_BIN_DIR", os.path.join(SRC, "build", "bin"))
SCHEMA = os.path.join(SRC, "schemas", "value-metrics.schema.json")
MASK64 = (1 << 64) - 1


class Mt19937_64:
    """std::mt19937_64 (Matsumoto & Nishimura 2004 constants, as fixed by C++11 [rand.predef])."""

    def __init__(self, seed):
        self.mt = [seed & MASK64]
        for i in range(1, 312):
            prev = self.mt[-1]
            self.mt.append((6364136223846793005 * (prev ^ (prev >> 62)) + i) & MASK64)
        self.index = 312

    def __call__(self):
        if self.index >= 312:
            mt = self.mt
            for i in range(312):
                x = (mt[i] & 0xFFFFFFFF80000000) | (mt[(i + 1) % 312] & 0x7FFFFFFF)
                mt[i] = mt[(i + 156) % 312] ^ (x >> 1) ^ (0xB5026F5AA96619E9 if x & 1 else 0)
            self.index = 0
        x = self.mt[self.index]
        self.index += 1
        x ^= (x >> 29) & 0x5555555555555555
        x ^= (x << 17) & 0x71D67FFFEDA60000
        x ^= (x << 37) & 0xFFF7EEE000000000
        return (x ^ (x >> 43)) & MASK64


def correlations(x, y):
    """SciPy's three coefficients; NaN where SciPy gives NaN or refuses (fewer than 2 pairs)."""
    if len(x) < 2:
        return {"pearson": math.nan, "spearman": math.nan, "kendall_tau_b": math.nan}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # constant input: SciPy warns and returns NaN
        return {"pearson": float(scipy.stats.pearsonr(x, y)[0]),
                "spearman": float(scipy.stats.spearmanr(x, y)[0]),
                "kendall_tau_b": float(scipy.stats.kendalltau(x, y)[0])}


def top1(vr, vm):
    if len(vr) < 2:
        return math.nan
    best_model, best_real = vm == vm.max(), vr == vr.max()
    return (best_model & best_real).sum() / best_model.sum()


def pairwise(vr, vm):
    i, j = np.triu_indices(len(vr), 1)
    true_order, model_order = np.sign(vr[j] - vr[i]), np.sign(vm[j] - vm[i])
    ordered = true_order != 0
    if not ordered.any():
        return math.nan
    scores = np.where(model_order == 0, 0.5, (model_order == true_order).astype(float))
    return float(scores[ordered].mean())


def reference(groups):
    """Every metric as {json path: value}; groups maps policy_id -> (real, model) arrays."""
    ids = sorted(groups)
    vr = np.array([groups[p][0].mean() for p in ids])
    vm = np.array([groups[p][1].mean() for p in ids])
    gap, spread = np.abs(vr - vm), vr.max() - vr.min()
    out = {("value_gap",): gap.mean(), ("optimism",): (vm - vr).mean(),
           ("normalized_value_gap",): gap.mean() / spread if spread > 0 else math.nan,
           ("policy_ranking", "top1_agreement"): top1(vr, vm),
           ("policy_ranking", "pairwise_accuracy"): pairwise(vr, vm)}
    for name, value in correlations(vr, vm).items():
        out[("policy_ranking", name)] = value
    all_real = np.concatenate([groups[p][0] for p in ids])
    all_model = np.concatenate([groups[p][1] for p in ids])
    for name, value in correlations(all_real, all_model).items():
        out[("episode_correlation", name)] = value
    for k, p in enumerate(ids):
        out.update({("per_policy", k, "real_value"): vr[k], ("per_policy", k, "model_value"): vm[k],
                    ("per_policy", k, "value_gap"): gap[k],
                    ("per_policy", k, "optimism"): vm[k] - vr[k]})
    return out


def reference_intervals(groups, resamples, seed, level):
    """The stratified percentile bootstrap of docs/metrics-value.md, replicate by replicate."""
    ids, rng = sorted(groups), Mt19937_64(seed)
    replicates = []
    for _ in range(resamples):
        resampled = {}
        for p in ids:
            real, model = groups[p]
            draw = np.array([rng() % len(real) for _ in range(len(real))])
            resampled[p] = (real[draw], model[draw])
        replicates.append(reference(resampled))
    intervals = {}
    for key in replicates[0]:
        values = np.array([r[key] for r in replicates], dtype=float)
        values = values[~np.isnan(values)]
        if len(values) == 0:
            intervals[key] = (math.nan, math.nan, 0)
        else:
            low, high = np.quantile(values, [(1 - level) / 2, (1 + level) / 2])
            intervals[key] = (low, high, len(values))
    return intervals


def at(obj, path):
    for key in path:
        obj = obj[key]
    return obj


def write_returns(path, groups, rng):
    """Policies interleaved at random (each policy's episodes stay in order, which the bootstrap
    draws index), columns in a shuffled order, plus a column to ignore."""
    slots = [p for p, (real, _) in groups.items() for _ in real]
    slots = [slots[k] for k in rng.permutation(len(slots))]
    next_episode = {p: 0 for p in groups}
    names = ["episode", "policy_id", "real_return", "model_return", "note"]
    order = rng.permutation(len(names))
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow([names[k] for k in order])
        for p in slots:
            i = next_episode[p]
            next_episode[p] += 1
            cells = [f"ep{i}", p, repr(float(groups[p][0][i])), repr(float(groups[p][1][i])),
                     "x, y"]
            writer.writerow([cells[k] for k in order])


def datasets():
    rng = np.random.default_rng(5)
    out = {}
    groups = {}
    for k in range(6):
        n = int(rng.integers(3, 20))
        real = rng.normal(k * 0.4, 1.0, n)
        groups[f"policy_{k}"] = (real, 0.7 * real + rng.normal(0.2, 0.6, n))
    out["continuous"] = groups
    out["success_01"] = {f"p{k}": (rng.binomial(1, 0.15 * k + 0.1, 10).astype(float),
                                   rng.binomial(1, 0.12 * k + 0.2, 10).astype(float))
                         for k in range(5)}
    # Integer returns; "a" and "b" have equal real sums (tied V_real), "c" and "d" equal model
    # sums (tied V_model): ties in every ranking metric.
    out["tied_values"] = {"a": (np.array([1.0, 3, 2]), np.array([2.0, 2, 2])),
                          "b": (np.array([2.0, 2, 2]), np.array([1.0, 1, 1])),
                          "c": (np.array([0.0, 1, 0, 3]), np.array([0.0, 2, 2, 0])),
                          "d": (np.array([5.0, 1]), np.array([1.0, 3]))}
    out["two_policies"] = {"x": (np.array([1.0, 2, 3]), np.array([1.5, 2, 2])),
                           "y": (np.array([0.0, 0.5]), np.array([0.25, 1]))}
    out["one_policy"] = {"solo": (np.array([1.0, 2, 4, 8]), np.array([1.0, 3, 3, 9]))}
    out["constant_real"] = {p: (np.ones(4), rng.normal(size=4)) for p in ("a", "b", "c")}
    return out


class ValueReference(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        with open(SCHEMA) as f:
            cls.validator = jsonschema.Draft202012Validator(json.load(f))
        cls.rng = np.random.default_rng(11)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def run_value(self, groups, *args, fmt="json"):
        path = os.path.join(self.tmp.name, "returns.csv")
        write_returns(path, groups, self.rng)
        p = subprocess.run([f"{BIN}/wm-metrics", "value", "--returns", path, "--format", fmt,
                            *args], capture_output=True, text=True)
        self.assertEqual(p.returncode, 0, p.stderr)
        if fmt == "csv":
            return p.stdout
        out = json.loads(p.stdout)
        self.validator.validate(out)
        return out

    def assertClose(self, got, expected, what):
        if math.isnan(expected):
            self.assertIsNone(got, what)
        else:
            self.assertIsNotNone(got, what)
            self.assertAlmostEqual(got, expected, delta=1e-9, msg=what)

    def test_mt19937_64_reference_is_the_standard_engine(self):
        rng = Mt19937_64(5489)
        for _ in range(9999):
            rng()
        self.assertEqual(rng(), 9981545732273789042)  # C++11 [rand.predef]

    def test_point_metrics_equal_numpy_and_scipy(self):
        for name, groups in datasets().items():
            out = self.run_value(groups, "--bootstrap", "0")
            self.assertEqual(out["episodes"], sum(len(r) for r, _ in groups.values()))
            self.assertEqual([p["policy_id"] for p in out["per_policy"]], sorted(groups))
            for path, expected in reference(groups).items():
                self.assertClose(at(out, path)["value"], float(expected), f"{name} {path}")
                self.assertIsNone(at(out, path)["ci_low"])

    def test_intervals_equal_the_reimplemented_bootstrap(self):
        all_sets = datasets()
        for name in ("continuous", "tied_values", "constant_real"):
            groups = all_sets[name]
            out = self.run_value(groups, "--bootstrap", "120", "--seed", "7", "--ci", "0.9")
            self.assertEqual(out["bootstrap"]["resamples"], 120)
            for path, (low, high, defined) in reference_intervals(groups, 120, 7, 0.9).items():
                got = at(out, path)
                self.assertClose(got["ci_low"], low, f"{name} {path} ci_low")
                self.assertClose(got["ci_high"], high, f"{name} {path} ci_high")
                self.assertEqual(got["resamples_defined"], defined, f"{name} {path}")

    def test_csv_holds_the_json_values(self):
        groups = datasets()["continuous"]
        out = self.run_value(groups, "--bootstrap", "50")
        rows = list(csv.DictReader(io.StringIO(self.run_value(groups, "--bootstrap", "50",
                                                              fmt="csv"))))
        ids = [p["policy_id"] for p in out["per_policy"]]
        for row in rows:
            path = tuple(row["metric"].split("."))
            if row["policy_id"]:
                path = ("per_policy", ids.index(row["policy_id"])) + path
            expected = at(out, path)
            for key in ("value", "ci_low", "ci_high"):
                self.assertEqual(float(row[key]), expected[key], f"{path} {key}")
            self.assertEqual(int(row["resamples_defined"]), expected["resamples_defined"])
        self.assertEqual(len(rows), 11 + 4 * len(ids))


if __name__ == "__main__":
    unittest.main(verbosity=2)
