#!/usr/bin/python3
"""wm-eval end to end on a tiny generated tabletop dataset (tokenizer and dynamics model trained
for a few steps here): every report row validates against schemas/report-*.schema.json; a rerun
gives the same bytes; the copy_last, copy_last_tokens and tokenizer_recon baselines (PSNR, SSIM,
MSE, segmented MSE and moved_error_ratio) equal an independent NumPy / scikit-image
re-computation from the shards and from `wm-tokenize decode`; controllability (delta_tpsnr) is
exactly 0 for the copies, moves with the perturbation and is absent with --controllability off;
summary means and intervals agree with per_episode.csv; inputs that do not belong together exit 1
naming the file; the MP4s hold real | plain | retrace | error panels; the PNG strips hold the
real frames above every rollout, pixel for pixel; --save-rollouts writes image folders that
wm-ingest --format folder reads back into the same frames; two sharded jobs write the single
job's report byte for byte and refuse a corrupted part. A motion checkpoint (wm-motion, 5 steps)
evaluated beside the token one gets the plain rollout only, no value or context rows, rows that
validate against the same schemas, the token report's baseline rows, and a wm-report compare
row against copy_last; --policy refuses it in one line."""
import csv
import hashlib
import json
import os
import re
import subprocess
import sys
import tempfile
import unittest

import cv2
import jsonschema
import numpy as np
from scipy import stats
from skimage.metrics import structural_similarity

SRC = os.environ.get("WM_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
BIN = os.environ.get("WM_BIN_DIR", os.path.join(SRC, "build", "bin"))
CONFIGS = os.path.join(SRC, "configs")
sys.path.insert(0, os.path.join(SRC, "scripts"))
import wmshard  # noqa: E402  (the independent Python reader of shards and token datasets)
sys.path.insert(0, os.path.join(SRC, "tests"))
from tiny_pipeline import UNANCHORED_TOKENIZER, derived_config  # noqa: E402

HORIZON, EPISODES, SIZE = 3, 2, 64  # SIZE: configs/tokenizer/tiny.yaml model.image_size
CSVS = {"summary.csv": "report-summary", "per_step.csv": "report-per-step",
        "per_episode.csv": "report-per-episode", "values.csv": "report-values",
        "contexts.csv": "report-contexts"}
INTEGER_COLUMNS = {"n", "step", "episode", "n_episodes", "slot", "frame"}
TEXT_COLUMNS = {"checkpoint", "rollout", "metric", "policy_id"}
STRIPS = [os.path.join("strips", f"episode_{k}.png") for k in range(EPISODES)]
# evaluate/episode_strip.h: label column, header row, gap between cells; frames drawn 3x.
STRIP_LABEL, STRIP_HEADER, STRIP_GAP, STRIP_SCALE = 144, 24, 2, 3
STRIP_ROWS = ["real", "plain", "retrace", "copy_last", "copy_last_tokens", "tokenizer_recon",
              "error plain"]
# configs/segmentation/tabletop.yaml: segmentation label values -> region.
REGIONS = {"arm": [1], "object": [2], "background": [0, 3]}


def schema(name):
    with open(os.path.join(SRC, "schemas", name + ".schema.json"), encoding="utf-8") as f:
        return json.load(f)


def typed(row):
    """A CSV row as the schemas see it: empty -> None, numbers -> int / float."""
    def cast(k, v):
        return v if k in TEXT_COLUMNS else int(v) if k in INTEGER_COLUMNS else float(v)
    return {k: None if v == "" else cast(k, v) for k, v in row.items()}


def number(cell):
    return np.nan if cell == "" else float(cell)


def read_rows(path):
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def read_bytes(path):
    with open(path, "rb") as f:
        return f.read()


def sha256(path):
    return hashlib.sha256(read_bytes(path)).hexdigest()


def tool(name, *args):
    return subprocess.run([os.path.join(BIN, name), *map(str, args)], capture_output=True,
                          text=True)


def ok(name, *args):
    p = tool(name, *args)
    if p.returncode != 0:
        raise AssertionError(f"{name} {' '.join(map(str, args))}: exit {p.returncode}\n{p.stderr}")
    return p


def decode(blob, flags=cv2.IMREAD_COLOR):
    """An encoded frame as OpenCV decodes it (the same libopencv as the C++); colour -> RGB."""
    img = cv2.imdecode(np.frombuffer(blob, np.uint8), flags)
    return cv2.cvtColor(img, cv2.COLOR_BGR2RGB) if img.ndim == 3 else img


def evaluator_frame(rgb):
    """What the evaluator scores as the real frame: tokenize::DecodeFrame (INTER_AREA resize to
    the tokenizer size, a no-op at 64x64; uint8 / 127.5 - 1 in float32), then PlanarToRgb8
    (round((v + 1) * 127.5), clamped), in float32 like the C++. std::round rounds halves away from
    zero and np.round to even, but (v + 1) * 127.5 lies within float32 error of an integer, never
    near a half, so the two agree (and the round trip gives back every byte)."""
    if rgb.shape[:2] != (SIZE, SIZE):
        rgb = cv2.resize(rgb, (SIZE, SIZE), interpolation=cv2.INTER_AREA)
    v = rgb.astype(np.float32) / np.float32(127.5) - np.float32(1)
    return np.clip(np.round((v + np.float32(1)) * np.float32(127.5)), 0, 255).astype(np.uint8)


def frame_scores(real, pred):
    """Per frame of uint8 RGB clips [T, S, S, 3]: MSE (8-bit units), PSNR (R = 255), SSIM."""
    mse = ((real.astype(np.float64) - pred) ** 2).mean(axis=(1, 2, 3))
    with np.errstate(divide="ignore"):
        psnr = 10 * np.log10(255.0 ** 2 / mse)
    ssim = [structural_similarity(a, b, gaussian_weights=True, sigma=1.5,
                                  use_sample_covariance=False, data_range=255, channel_axis=-1)
            for a, b in zip(real, pred)]
    return {"mse": mse, "psnr": psnr, "ssim": np.array(ssim)}


def region_scores(real, pred, labels):
    """WPE eq. 3 per frame: squared error summed over the region's pixels x 3 channels, divided
    by their count; NaN for a frame without the region. Masks come from the true frames (at
    64x64 the nearest-neighbour resize of evaluate/region_masks.cc is the identity)."""
    err = ((real.astype(np.float64) - pred) ** 2).sum(axis=-1)  # [T, S, S]
    out = {}
    for region, labels_of_region in REGIONS.items():
        mask = np.isin(labels, labels_of_region)
        count = mask.sum(axis=(1, 2))
        with np.errstate(invalid="ignore", divide="ignore"):
            out["mse_" + region] = np.where(count > 0, (err * mask).sum(axis=(1, 2)) / (3 * count),
                                            np.nan)
    return out


def motion_scores(real, pred, first):
    """moved_error_ratio per frame: over the pixels where some channel of the true frame differs
    from the first frame by more than 30 levels, sum |pred - real| / sum |pred - first| over their
    3 channels; NaN when no pixel moved or the prediction equals the first frame there."""
    real, pred, first = (x.astype(np.int64) for x in (real, pred, first))
    moved = (np.abs(real - first) > 30).any(axis=-1, keepdims=True)  # [T, S, S, 1]
    to_truth = (np.abs(pred - real) * moved).sum(axis=(1, 2, 3))
    to_start = (np.abs(pred - first) * moved).sum(axis=(1, 2, 3))
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = to_truth / to_start
    return {"moved_error_ratio": np.where(moved.any(axis=(1, 2, 3)) & (to_start > 0), ratio,
                                          np.nan)}


def finite_mean(values):
    """The evaluator's mean: non-finite values (identical frames, absent regions) left out."""
    values = np.asarray(values, dtype=np.float64)
    finite = values[np.isfinite(values)]
    return (finite.mean() if finite.size else np.nan), finite.size


class WmEval(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.make_reports()
        cls.rows = {f: read_rows(os.path.join(cls.reports[0], f)) for f in CSVS}
        cls.read_references()

    @classmethod
    def make_reports(cls):
        """Data, a tokenizer (60 steps), a dynamics model (10 steps), and wm-eval run twice."""
        path = cls.path
        ok("wm-gen-tabletop", "--out", path("raw"), "--size", SIZE, "--train-episodes", 24,
           "--val-episodes", 4, "--seed", 0)
        for split in ("train", "val"):
            ok("wm-ingest", "--format", "rlds", "--input", path("raw", "wm_tabletop", "1.0.0"),
               "--split", split, "--output", path("shards", split), "--threads", 1)
        # Without the preset's anchor decoder: after 60 steps an anchored tokenizer decodes
        # nearly any tokens to its anchor, so sampled or action-perturbed rollouts could not
        # differ. The anchored path is checked end to end in test_against_copies.py.
        config = derived_config("tokenizer", path("tokenizer.yaml"), UNANCHORED_TOKENIZER)
        ok("wm-tokenize", "train", "--config", config,
           "--data", path("shards", "train"), "--out", path("tok"), "--steps", 60,
           "--threads", 1)
        for split in ("train", "val"):
            ok("wm-tokenize", "encode", "--checkpoint", path("tok"), "--data",
               path("shards", split), "--out", path("tokens", split), "--threads", 1)
        ok("wm-train", "--config", os.path.join(CONFIGS, "dynamics", "tiny.yaml"), "--tokens",
           path("tokens", "train"), "--out", path("dyn"), "--steps", 10, "--threads", 1)
        ok("wm-motion", "train", "--config", os.path.join(CONFIGS, "motion", "tiny.yaml"),
           "--data", path("shards", "train"), "--out", path("motion"), "--steps", 5,
           "--threads", 1)
        cls.reports = [path(out, "dyn") for out in ("reports", "rerun")]
        # The rerun also exports its frames, which must not change a byte of the report.
        cls.eval_logs = [ok("wm-eval", *cls.eval_args(os.path.dirname(report)), *extra).stderr
                         for report, extra in zip(cls.reports,
                                                  ([], ["--save-rollouts", path("exported")]))]

    @classmethod
    def read_references(cls):
        """Independently of wm-eval: real frames 0..H and labels from the shards (wmshard.py),
        the tokenizer's reconstruction from `wm-tokenize decode`, and both baselines' frames."""
        shards = wmshard.Dataset(cls.path("shards", "val"))
        tokens = wmshard.TokenDataset(cls.path("tokens", "val"))
        cls.real, cls.labels, cls.policies, recon = [], [], [], []
        for k in range(EPISODES):
            meta = tokens.index["episodes"][k]
            _, _, blobs = shards.episode(meta["source_episode"])
            assert len(blobs["image"]) > HORIZON, "the horizon is not capped in this fixture"
            cls.real.append(np.stack([evaluator_frame(decode(b))
                                      for b in blobs["image"][:HORIZON + 1]]))
            cls.labels.append(np.stack([decode(b, cv2.IMREAD_UNCHANGED)
                                        for b in blobs["segmentation"][:HORIZON + 1]]))
            cls.policies.append(meta["policy_id"])
            out = cls.path("decoded", str(k))
            ok("wm-tokenize", "decode", "--checkpoint", cls.path("tok"), "--tokens",
               cls.path("tokens", "val"), "--episode", k, "--out", out)
            recon.append(np.stack([decode(read_bytes(os.path.join(out, f"frame_{t:04d}.png")))
                                   for t in range(HORIZON + 1)]))
        # Frame 0 is the rollouts' given first frame, never scored.
        cls.baselines = {"copy_last": [np.repeat(r[:1], HORIZON + 1, axis=0) for r in cls.real],
                         "copy_last_tokens": [np.repeat(r[:1], HORIZON + 1, axis=0)
                                              for r in recon],
                         "tokenizer_recon": recon}

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    @classmethod
    def path(cls, *parts):
        return os.path.join(cls.tmp.name, *parts)

    @classmethod
    def eval_args(cls, out, tokens="val", tokenizer="tok"):
        return ["--checkpoint", cls.path("dyn"), "--tokenizer", cls.path(tokenizer),
                "--data", cls.path("shards", "val"), "--tokens", cls.path("tokens", tokens),
                "--out", out, "--horizon", HORIZON, "--episodes", EPISODES, "--resamples", 100,
                "--masks", "files", "--seg-config",
                os.path.join(CONFIGS, "segmentation", "tabletop.yaml"), "--threads", 1]

    def select(self, file, rollout, metric):
        return [r for r in self.rows[file] if r["rollout"] == rollout and r["metric"] == metric]

    def assert_close(self, got, want, what, rel=1e-6):
        """Equal up to `rel` (the CSVs print 9 significant digits); NaN matches an empty cell."""
        if np.isnan(want):
            self.assertTrue(np.isnan(got), f"{what}: {got}, expected an empty cell")
        else:
            self.assertAlmostEqual(got, want, delta=rel * abs(want) + 1e-12, msg=what)

    def assert_baseline_scores(self, score):
        """per_episode.csv (episode mean over steps 1..H) and per_step.csv (mean over episodes)
        of every baseline against score(real, pred, labels, first real frame) computed here, per
        frame."""
        for rollout, clips in self.baselines.items():
            scores = [score(real[1:], pred[1:], labels[1:], real[0])
                      for real, pred, labels in zip(self.real, clips, self.labels)]
            for metric in scores[0]:
                what = f"{rollout} {metric}"
                rows = self.select("per_episode.csv", rollout, metric)
                self.assertEqual([(int(r["episode"]), r["policy_id"]) for r in rows],
                                 list(enumerate(self.policies)), what)
                for r, s in zip(rows, scores):
                    self.assert_close(number(r["value"]), finite_mean(s[metric])[0],
                                      f"{what} episode {r['episode']}")
                rows = self.select("per_step.csv", rollout, metric)
                self.assertEqual([int(r["step"]) for r in rows], list(range(1, HORIZON + 1)))
                for r in rows:
                    mean, n = finite_mean([s[metric][int(r["step"]) - 1] for s in scores])
                    self.assertEqual(int(r["n"]), n, f"{what} step {r['step']}")
                    self.assert_close(number(r["mean"]), mean, f"{what} step {r['step']}")

    def test_rows_validate_against_the_schemas(self):
        for file, name in CSVS.items():
            validator = jsonschema.Draft202012Validator(schema(name))
            self.assertTrue(self.rows[file], file)
            self.assertEqual(list(self.rows[file][0]), validator.schema["required"], file)
            for row in self.rows[file]:
                validator.validate(typed(row))
        with open(os.path.join(self.reports[0], "manifest.json"), encoding="utf-8") as f:
            jsonschema.validate(json.load(f), schema("report-manifest"))
        self.assertEqual({r["rollout"] for r in self.rows["summary.csv"]},
                         {"plain", "retrace", "copy_last", "copy_last_tokens", "tokenizer_recon"})

    def test_motion_checkpoint_beside_the_token_one(self):
        """wm-eval --checkpoint dyn --checkpoint motion: the motion report's rows validate against
        the schemas (values.csv and contexts.csv: header only, no reward head and no token
        context), it has plain but no retrace (--rollout auto), the baselines equal the token
        report's, the token report is the one wm-eval writes alone, and wm-report compare puts
        the motion rollout against its copy_last."""
        out = self.path("with_motion")
        ok("wm-eval", *self.eval_args(out), "--checkpoint", self.path("motion"))
        motion = os.path.join(out, "motion")
        rows = {f: read_rows(os.path.join(motion, f)) for f in CSVS}
        for file, name in CSVS.items():
            validator = jsonschema.Draft202012Validator(schema(name))
            with open(os.path.join(motion, file), encoding="utf-8") as f:
                self.assertEqual(next(csv.reader(f))[:len(validator.schema["required"])],
                                 validator.schema["required"], file)
            for row in rows[file]:
                validator.validate(typed(row))
        self.assertEqual((rows["values.csv"], rows["contexts.csv"]), ([], []))
        with open(os.path.join(motion, "manifest.json"), encoding="utf-8") as f:
            m = json.load(f)
        jsonschema.validate(m, schema("report-manifest"))
        self.assertEqual((m["checkpoint"]["model_kind"], m["checkpoint"]["sha256"]),
                         ("motion", sha256(self.path("motion", "checkpoint.wmt"))))
        self.assertEqual(m["config"]["rollouts"], ["plain"])
        self.assertEqual({r["rollout"] for r in rows["summary.csv"]},
                         {"plain", "copy_last", "copy_last_tokens", "tokenizer_recon"})
        self.assertTrue(any(r["metric"] == "delta_tpsnr" for r in rows["summary.csv"]
                            if r["rollout"] == "plain"))
        def baselines(report):
            return [{**r, "checkpoint": ""} for r in read_rows(os.path.join(report, "summary.csv"))
                    if r["rollout"] not in ("plain", "retrace")]
        self.assertEqual(baselines(motion), baselines(self.reports[0]))
        for file in CSVS:
            self.assertEqual(read_bytes(os.path.join(out, "dyn", file)),
                             read_bytes(os.path.join(self.reports[0], file)), file)
        ok("wm-report", "compare", os.path.join(out, "dyn"), motion, "--out",
           self.path("with_motion.csv"), "--metrics", "psnr,mse_arm")
        (row,) = [r for r in read_rows(self.path("with_motion.csv"))
                  if (r["checkpoint"], r["rollout"]) == ("motion", "plain")]
        self.assertNotEqual(row["psnr_vs_copy_last_ci_low"], "")
        p = tool("wm-eval", *self.eval_args(self.path("motion_policy")), "--checkpoint",
                 self.path("motion"), "--policy", "idle=true")
        self.assertEqual(p.returncode, 1, p.stderr)
        self.assertIn("needs --success-model", p.stderr)

    def test_rolling_out_shows_its_progress_before_scoring(self):
        # A token model imagines every episode up front (plain, retrace, perturbed actions):
        # minutes on a few hundred episodes, which must not pass in silence.
        log = self.eval_logs[0]
        done = re.findall(r"imagine dyn +100% (\d+)/(\d+) rollouts", log)
        self.assertEqual(len(done), 1, log)
        rollouts = int(done[0][1])
        self.assertEqual(int(done[0][0]), rollouts)
        # plain and retrace (eef_delta actions), and plain again with perturbed actions
        self.assertEqual(rollouts, 3 * EPISODES, log)
        self.assertLess(log.index("imagine dyn"), log.index("score dyn"), log)

    def test_rerun_gives_the_same_bytes_and_the_manifest_names_the_inputs(self):
        # The manifest records no time or host, so it is byte-identical too.
        for file in [*CSVS, "manifest.json", *STRIPS]:
            self.assertEqual(*(read_bytes(os.path.join(r, file)) for r in self.reports), file)
        with open(os.path.join(self.reports[0], "manifest.json"), encoding="utf-8") as f:
            m = json.load(f)
        self.assertEqual(m["checkpoint"]["name"], "dyn")
        self.assertEqual(m["checkpoint"]["sha256"], sha256(self.path("dyn", "checkpoint.wmt")))
        self.assertEqual(m["tokenizer"]["sha256"], sha256(self.path("tok", "checkpoint.wmt")))
        self.assertEqual(m["data"]["shards"][0]["sha256"],
                         sha256(self.path("shards", "val", "shard-00000.wms")))
        self.assertEqual((m["data"]["split"], m["config"]["horizon"], m["seed"]), ("val", 3, 0))
        compact = json.dumps(m["config"], separators=(",", ":"), sort_keys=True)
        self.assertEqual(m["config_hash"], hashlib.sha256(compact.encode()).hexdigest())

    def test_argmax_decoding_ignores_the_seed_and_sampling_does_not(self):
        """--temperature 0 decodes every frame by argmax, so another --seed imagines the same
        frames; the checkpoint's own temperature (1.0) samples, so another seed changes them."""
        def plain_means(report):
            rows = read_rows(os.path.join(report, "per_step.csv"))
            return [r["mean"] for r in rows if r["rollout"] == "plain"]

        runs = {}
        for name, extra in (("argmax0", ["--temperature", 0, "--seed", 0]),
                            ("argmax1", ["--temperature", 0, "--seed", 1]),
                            ("sampled1", ["--seed", 1])):
            ok("wm-eval", *self.eval_args(self.path(name)), "--rollout", "plain", *extra)
            runs[name] = self.path(name, "dyn")
        self.assertEqual(plain_means(runs["argmax0"]), plain_means(runs["argmax1"]))
        self.assertNotEqual(plain_means(self.reports[0]), plain_means(runs["sampled1"]))
        with open(os.path.join(runs["argmax0"], "manifest.json"), encoding="utf-8") as f:
            self.assertEqual(json.load(f)["config"]["temperature"], 0)
        # Samples of argmax decoding are identical: zero uncertainty, and wm-eval says why.
        p = ok("wm-eval", *self.eval_args(self.path("argmax_samples")), "--rollout", "plain",
               "--temperature", 0, "--samples", 2)
        self.assertIn("--samples 2 with argmax decoding", p.stderr)
        rows = read_rows(os.path.join(self.path("argmax_samples", "dyn"), "per_episode.csv"))
        spread = [float(r["value"]) for r in rows if r["metric"] == "uncertainty"]
        self.assertEqual(spread, [0.0] * EPISODES)

    def test_retrace_ks_adds_uncertainty_and_changes_nothing_else(self):
        """--retrace-ks (docs/reports.md, "Uncertainty without ensembles"): the report without it
        is this one less the new metrics' rows and uncertainty.csv, which validates against its
        schema; the variants agree at step 1 (each is frame 0 and a_0); entropies lie in
        (0, ln K]; the mse column is plain's. With --samples 2 on 4 episodes every signal's
        Pearson, Spearman and AUROC (Mann-Whitney U / (n_pos n_neg), episodes above the median
        mean MSE positive) equal SciPy's on the CSV; bad --retrace-ks values exit 1."""
        signals = ("retrace_disagreement", "token_entropy", "sample_disagreement")
        out = self.path("uncertainty")
        ok("wm-eval", *self.eval_args(out), "--retrace-ks", "0,1,2")
        report = os.path.join(out, "dyn")
        for file in ("values.csv", "contexts.csv", *STRIPS):
            self.assertEqual(read_bytes(os.path.join(report, file)),
                             read_bytes(os.path.join(self.reports[0], file)), file)
        for file in ("summary.csv", "per_step.csv", "per_episode.csv"):
            rows = read_rows(os.path.join(report, file))
            self.assertEqual([r for r in rows if not r["metric"].startswith(signals)],
                             self.rows[file], file)
        with open(os.path.join(report, "manifest.json"), encoding="utf-8") as f:
            self.assertEqual(json.load(f)["config"]["retrace_ks"], [0, 1, 2])
        rows = read_rows(os.path.join(report, "uncertainty.csv"))
        jsonschema.Draft202012Validator.check_schema(schema("report-uncertainty"))
        validator = jsonschema.Draft202012Validator(schema("report-uncertainty"))
        self.assertEqual(list(rows[0]), validator.schema["required"])
        for row in rows:
            validator.validate(typed(row))
        self.assertEqual(len(rows), EPISODES * HORIZON)
        num_codes = wmshard.TokenDataset(self.path("tokens", "val")).index["tokenizer"]["num_codes"]
        for r in rows:
            self.assertTrue(0 < float(r["token_entropy"]) <= np.log(num_codes), r)
            if r["step"] == "1":
                self.assertEqual(float(r["retrace_disagreement"]), 0.0, r)
        plain_mse = [number(r["value"]) for r in self.select("per_episode.csv", "plain", "mse")]
        for k, want in enumerate(plain_mse):
            mse = [float(r["mse"]) for r in rows if r["episode"] == str(k)]
            self.assert_close(np.mean(mse), want, f"episode {k} mse", rel=1e-6)
        self.assert_uncertainty_scores_equal_scipy(signals)
        for bad in ("0,9", "2"):
            p = tool("wm-eval", *self.eval_args(self.path("bad_ks")), "--retrace-ks", bad)
            self.assertEqual(p.returncode, 1, p.stderr)
            self.assertIn("--retrace-ks", p.stderr)

    def assert_uncertainty_scores_equal_scipy(self, signals):
        args = self.eval_args(self.path("uncertainty4"))
        args[args.index("--episodes") + 1] = 4
        ok("wm-eval", *args, "--retrace-ks", "0,1,4", "--samples", 2, "--temperature", 1)
        report = self.path("uncertainty4", "dyn")
        rows = read_rows(os.path.join(report, "uncertainty.csv"))
        summary = {r["metric"]: r for r in read_rows(os.path.join(report, "summary.csv"))
                   if r["rollout"] == "plain"}
        episodes = sorted({int(r["episode"]) for r in rows})
        self.assertEqual(episodes, [0, 1, 2, 3])
        error = np.array([float(r["mse"]) for r in rows])
        of = np.array([int(r["episode"]) for r in rows])
        mean_error = np.array([error[of == k].mean() for k in episodes])
        positive = mean_error > np.median(mean_error)
        for signal in signals:
            x = np.array([float(r[signal]) for r in rows])
            self.assert_close(number(summary[signal + "_error_pearson"]["mean"]),
                              stats.pearsonr(x, error)[0], signal, rel=1e-6)
            self.assert_close(number(summary[signal + "_error_spearman"]["mean"]),
                              stats.spearmanr(x, error)[0], signal, rel=1e-6)
            score = np.array([x[of == k].mean() for k in episodes])
            u = stats.mannwhitneyu(score[positive], score[~positive]).statistic
            self.assert_close(number(summary[signal + "_auroc"]["mean"]),
                              u / (positive.sum() * (~positive).sum()), signal, rel=1e-6)
            self.assertEqual(int(summary[signal + "_auroc"]["n"]), 4)
            self.assertEqual(int(summary[signal + "_error_spearman"]["n"]), len(rows))
        self.assert_close(number(summary["sample_disagreement_error_pearson"]["mean"]),
                          number(summary["uncertainty_error_corr"]["mean"]), "samples", rel=1e-9)

    def test_sharded_jobs_write_the_single_job_report(self):
        args = self.eval_args(self.path("sharded"))
        report = self.path("sharded", "dyn")
        ok("wm-eval", *args, "--shard-index", 1, "--num-shards", 2)
        self.assertFalse(os.path.exists(os.path.join(report, "manifest.json")), "1 part of 2")
        ok("wm-eval", *args, "--shard-index", 0, "--num-shards", 2)
        videos = [os.path.join("videos", f"episode_{k}.mp4") for k in range(EPISODES)]
        for file in [*CSVS, "manifest.json", *videos, *STRIPS]:
            self.assertEqual(read_bytes(os.path.join(report, file)),
                             read_bytes(os.path.join(self.reports[0], file)), file)
        paths = [os.path.join(report, "parts", f"part-{i}-of-2.json") for i in range(2)]
        parts = [json.loads(read_bytes(path)) for path in paths]
        for part in parts:
            jsonschema.validate(part, schema("eval-part"))
        self.assertEqual([[r["episode"] for r in p["records"]] for p in parts], [[0], [1]])
        # Job 0 again keeps its part and retries the report, which checks every part's checksum.
        parts[1]["records"][0]["real_return"] = 123.0
        with open(paths[1], "w", encoding="utf-8") as f:
            json.dump(parts[1], f)
        p = tool("wm-eval", *args, "--shard-index", 0, "--num-shards", 2)
        self.assertEqual(p.returncode, 1, p.stderr)
        self.assertIn(paths[1], p.stderr)
        self.assertIn("checksum mismatch", p.stderr)
        self.assertIn("already scored", p.stderr)

    def test_baseline_pixel_metrics_equal_numpy(self):
        # Exact up to printing: the same decoder (libopencv/libjpeg), uint8 frames on both sides.
        self.assert_baseline_scores(lambda real, pred, *_: frame_scores(real, pred))

    def test_baseline_segmented_mse_equals_numpy(self):
        self.assert_baseline_scores(lambda real, pred, labels, _: region_scores(real, pred, labels))

    def test_baseline_moved_error_ratio_equals_numpy(self):
        """copy_last is undefined at every step (it is the first frame); the others by hand."""
        self.assert_baseline_scores(lambda real, pred, _, first: motion_scores(real, pred, first))
        self.assertEqual({r["value"] for r in self.select("per_episode.csv", "copy_last",
                                                          "moved_error_ratio")}, {""})
        tokens = [number(r["value"]) for r in self.select("per_episode.csv", "copy_last_tokens",
                                                          "moved_error_ratio")]
        self.assertTrue(np.isfinite(tokens).any(), "the fixture's arm moves more than 30 levels")

    def test_controllability_rows_and_the_copies_score_0(self):
        """delta_tpsnr = PSNR(plain) - PSNR(plain with the episode's actions reversed): rows for
        plain and, exactly 0 by construction (a copy reads no action), for copy_last and
        copy_last_tokens. Another perturbation gives other values; --controllability off drops
        the rows and leaves the plain scores as they are."""
        rows = [r for r in self.rows["summary.csv"] if r["metric"] == "delta_tpsnr"]
        self.assertEqual(sorted((r["rollout"], int(r["n"])) for r in rows),
                         [("copy_last", EPISODES), ("copy_last_tokens", EPISODES),
                          ("plain", EPISODES)])
        steps = self.select("per_step.csv", "plain", "delta_tpsnr")
        self.assertEqual([int(r["step"]) for r in steps], list(range(1, HORIZON + 1)))
        for copy in ("copy_last", "copy_last_tokens"):
            self.assertEqual({r["value"] for r in self.select("per_episode.csv", copy,
                                                              "delta_tpsnr")}, {"0"}, copy)
        # The perturbed actions reach the model: its frames, and so its PSNR, change.
        reversed_values = [number(r["value"]) for r in self.select("per_episode.csv", "plain",
                                                                   "delta_tpsnr")]
        self.assertTrue(all(np.isfinite(reversed_values)), reversed_values)
        self.assertTrue(any(v != 0 for v in reversed_values), reversed_values)
        with open(os.path.join(self.reports[0], "manifest.json"), encoding="utf-8") as f:
            self.assertEqual(json.load(f)["config"]["controllability"], "reversed")

        ok("wm-eval", *self.eval_args(self.path("shuffled")), "--rollout", "plain",
           "--controllability", "shuffled")
        rows = read_rows(self.path("shuffled", "dyn", "per_episode.csv"))
        shuffled = [number(r["value"]) for r in rows
                    if r["rollout"] == "plain" and r["metric"] == "delta_tpsnr"]
        self.assertEqual(len(shuffled), EPISODES)
        self.assertNotEqual(shuffled, reversed_values)

        ok("wm-eval", *self.eval_args(self.path("off")), "--rollout", "plain",
           "--controllability", "off")
        off = read_rows(self.path("off", "dyn", "per_step.csv"))
        self.assertFalse([r for r in off if r["metric"] == "delta_tpsnr"])
        self.assertEqual([r for r in off if r["rollout"] == "plain"],
                         [r for r in self.rows["per_step.csv"] if r["rollout"] == "plain"
                          and r["metric"] != "delta_tpsnr"])

    def test_inputs_that_do_not_belong_together_exit_1_naming_the_file(self):
        # Another tokenizer: the same config, one step (the check is on the checkpoint's SHA-256).
        ok("wm-tokenize", "train", "--config", os.path.join(CONFIGS, "tokenizer", "tiny.yaml"),
           "--data", self.path("shards", "val"), "--out", self.path("tok2"), "--steps", 1,
           "--threads", 1)
        cases = [({"tokens": "train"}, self.path("tokens", "train", "index.json"),
                  "source.shards"),
                 ({"tokenizer": "tok2"}, self.path("tokens", "val", "index.json"),
                  "tokenizer.checkpoint_sha256")]
        for i, (args, file, key) in enumerate(cases):
            out = self.path(f"bad{i}")
            p = tool("wm-eval", *self.eval_args(out, **args))
            self.assertEqual(p.returncode, 1, p.stderr)
            self.assertIn(f"wm-eval: error: {file}: key '{key}'", p.stderr)
            self.assertFalse(os.path.exists(out), "checked before anything is written")
        # A residual tokenizer's level stacks, with their own tokenizer, for a one-level model.
        config = derived_config("tokenizer", self.path("levels.yaml"), {"model": {"levels": 2}})
        ok("wm-tokenize", "train", "--config", config, "--data", self.path("shards", "val"),
           "--out", self.path("tok_levels"), "--steps", 1, "--threads", 1)
        ok("wm-tokenize", "encode", "--checkpoint", self.path("tok_levels"), "--data",
           self.path("shards", "val"), "--out", self.path("tokens", "levels"))
        out = self.path("bad_levels")
        p = tool("wm-eval", *self.eval_args(out, tokens="levels", tokenizer="tok_levels"))
        self.assertEqual(p.returncode, 1, p.stderr)
        self.assertIn(f"wm-eval: error: {self.path('tokens', 'levels')}: the model was trained on "
                      "8x8 tokens of 1024 codes per frame; this data has 2 levels x 8x8 tokens of "
                      "1024 codes (tokenizer.levels)", p.stderr)
        self.assertFalse(os.path.exists(out), "checked before anything is written")

    def test_official_lpips_of_the_baselines_equals_wm_metrics(self):
        """--lpips-weights adds `lpips` (here with the exporter's seeded random weights): each
        baseline episode's mean equals wm-metrics' LPIPS of the same frames written as PNGs."""
        weights = self.path("lpips-rand.wmt")
        subprocess.run(["/usr/bin/python3", os.path.join(SRC, "scripts", "export_lpips_weights.py"),
                        "--random-seed", "0", "--out", weights], check=True, capture_output=True)
        ok("wm-eval", *self.eval_args(self.path("with_lpips")), "--lpips-weights", weights)
        rows = read_rows(self.path("with_lpips", "dyn", "per_episode.csv"))
        for rollout, clips in self.baselines.items():
            for k, (real, pred) in enumerate(zip(self.real, clips)):
                dirs = [self.path("lpips_frames", rollout, str(k), side) for side in "ab"]
                for d, frames in zip(dirs, (real, pred)):
                    os.makedirs(d)
                    for t in range(1, HORIZON + 1):
                        cv2.imwrite(os.path.join(d, f"{t:03d}.png"),
                                    cv2.cvtColor(frames[t], cv2.COLOR_RGB2BGR))
                want = json.loads(ok("wm-metrics", "--ref", dirs[0], "--pred", dirs[1],
                                     "--metrics", "lpips", "--lpips-weights", weights).stdout)
                got = [r for r in rows if r["rollout"] == rollout and r["metric"] == "lpips"
                       and int(r["episode"]) == k]
                self.assertEqual(len(got), 1)
                self.assert_close(number(got[0]["value"]), want["lpips"], f"{rollout} {k}")

    def test_videos_hold_real_model_and_error_panels(self):
        # evaluate/clip_video.cc: frames 1..H, panels real | plain | retrace (std::map order) |
        # JET heat map of 3 x grey |real - plain|, each drawn 2x with nearest-neighbour.
        for k in range(EPISODES):
            cap = cv2.VideoCapture(os.path.join(self.reports[0], "videos", f"episode_{k}.mp4"))
            frames = []
            while (frame := cap.read())[0]:
                frames.append(frame[1])
            self.assertEqual(len(frames), HORIZON, k)
            for t, frame in enumerate(frames, start=1):
                self.assertEqual(frame.shape, (2 * SIZE, 4 * 2 * SIZE, 3))
                real, plain, _, heat = (p[::2, ::2] for p in np.split(frame, 4, axis=1))
                # H.264 at CRF 18 is lossy: 1.7 levels of mean error on the real panel at most
                # (mp4v was ~2.5); model panels are ~20+.
                want = cv2.cvtColor(self.real[k][t], cv2.COLOR_RGB2BGR)
                self.assertLess(cv2.absdiff(real, want).mean(), 4, (k, t))
                # The heat map from the decoded panels: ~10 apart (codec noise x 3 through JET);
                # a heat map of another error (e.g. none) is ~60+ apart.
                grey = cv2.cvtColor(cv2.absdiff(real, plain), cv2.COLOR_BGR2GRAY)
                expect = cv2.applyColorMap(cv2.multiply(grey, 3), cv2.COLORMAP_JET)
                self.assertLess(cv2.absdiff(heat, expect).mean(), 25, (k, t))

    def strip_cells(self, k):
        """strips/episode_k.png as {row: [H + 1 frames, RGB, at frame size]}, after checking its
        pixel size and that every cell is a 3x nearest-neighbour upscale of its frame."""
        strip = cv2.imread(os.path.join(self.reports[0], "strips", f"episode_{k}.png"))
        cell = SIZE * STRIP_SCALE
        columns, rows = HORIZON + 1, len(STRIP_ROWS)
        self.assertEqual(strip.shape, (STRIP_HEADER + rows * cell + (rows - 1) * STRIP_GAP,
                                       STRIP_LABEL + columns * cell + (columns - 1) * STRIP_GAP,
                                       3))
        out = {}
        for r, row in enumerate(STRIP_ROWS):
            y = STRIP_HEADER + r * (cell + STRIP_GAP)
            out[row] = []
            for c in range(columns):
                x = STRIP_LABEL + c * (cell + STRIP_GAP)
                big = strip[y:y + cell, x:x + cell]
                small = big[::STRIP_SCALE, ::STRIP_SCALE]
                up = np.repeat(np.repeat(small, STRIP_SCALE, 0), STRIP_SCALE, 1)
                np.testing.assert_array_equal(big, up, f"episode {k} {row} column {c}")
                out[row].append(cv2.cvtColor(small, cv2.COLOR_BGR2RGB))
            out[row] = np.stack(out[row])
        return out

    def test_strips_show_the_real_frames_above_every_rollout(self):
        """Rows against independent references: real (the shards), copy_last (real frame 0),
        tokenizer_recon (wm-tokenize decode); the error row is the heat map of |real - plain|."""
        for k in range(EPISODES):
            cells = self.strip_cells(k)
            np.testing.assert_array_equal(cells["real"], self.real[k])
            np.testing.assert_array_equal(cells["copy_last"], self.baselines["copy_last"][k])
            np.testing.assert_array_equal(cells["tokenizer_recon"][1:],
                                          self.baselines["tokenizer_recon"][k][1:])
            np.testing.assert_array_equal(cells["copy_last_tokens"][1:],
                                          self.baselines["copy_last_tokens"][k][1:])
            for row in ("plain", "retrace", "copy_last", "copy_last_tokens", "tokenizer_recon"):
                # Column 0 is the given real frame in every row.
                np.testing.assert_array_equal(cells[row][0], self.real[k][0], row)
            diff = np.abs(self.real[k].astype(int) - cells["plain"]).astype(np.uint8)
            grey = cv2.cvtColor(diff.reshape(-1, SIZE, 3), cv2.COLOR_RGB2GRAY)
            heat = cv2.applyColorMap(cv2.multiply(grey, 3), cv2.COLORMAP_JET)
            np.testing.assert_array_equal(cells["error plain"],
                                          cv2.cvtColor(heat, cv2.COLOR_BGR2RGB).reshape(
                                              HORIZON + 1, SIZE, SIZE, 3))
            self.assertGreater(np.abs(cells["plain"][1:].astype(int) - self.real[k][1:]).max(),
                               0, "a 10-step model does not imagine the real frames")

    def test_strip_overview_stacks_each_episodes_real_plain_and_error_rows(self):
        cell = SIZE * STRIP_SCALE
        overview = cv2.imread(os.path.join(self.reports[0], "strips", "overview.png"))
        self.assertEqual(overview.shape[0], STRIP_HEADER + EPISODES * (3 * cell + 5 * STRIP_GAP))
        for k in range(EPISODES):
            strip = cv2.imread(os.path.join(self.reports[0], "strips", f"episode_{k}.png"))
            self.assertEqual(overview.shape[1], strip.shape[1])
            y0 = STRIP_HEADER + k * (3 * cell + 5 * STRIP_GAP)
            for i, r in enumerate((0, 1, len(STRIP_ROWS) - 1)):  # real, plain, error plain
                y, ys = y0 + i * (cell + STRIP_GAP), STRIP_HEADER + r * (cell + STRIP_GAP)
                np.testing.assert_array_equal(overview[y:y + cell, STRIP_LABEL:],
                                              strip[ys:ys + cell, STRIP_LABEL:], f"{k} {r}")

    def test_saved_rollouts_read_back_through_wm_ingest(self):
        """Every exported kind, ingested with wm-ingest --format folder, decodes to the frames
        the report scored (PNG is lossless), with the episode's logged actions; meta.json says
        where each came from. A killed run's hidden temp folder is not read as an episode."""
        export = self.path("exported", "dyn")
        os.makedirs(os.path.join(export, "plain", ".episode_7.tmp"))  # a killed run's leftover
        shards = wmshard.Dataset(self.path("shards", "val"))
        tokens = wmshard.TokenDataset(self.path("tokens", "val"))
        strips = [self.strip_cells(k) for k in range(EPISODES)]
        want = {"real": [r[1:] for r in self.real], "context": [r[:1] for r in self.real],
                **{kind: [s[kind][1:] for s in strips]
                   for kind in ("plain", "retrace", "copy_last", "copy_last_tokens",
                                "tokenizer_recon")}}
        self.assertEqual(sorted(os.listdir(export)), sorted(want))
        validator = jsonschema.Draft202012Validator(schema("folder-meta"))
        for kind, clips in want.items():
            out = self.path("reingested", kind)
            ok("wm-ingest", "--format", "folder", "--input", os.path.join(export, kind),
               "--output", out, "--threads", 1)
            data = wmshard.Dataset(out)
            self.assertEqual(data.num_episodes, EPISODES, kind)
            for k in range(EPISODES):
                got, _, blobs = data.episode(k)
                first = 0 if kind == "context" else 1
                np.testing.assert_array_equal(np.stack([decode(b) for b in blobs["image"]]),
                                              clips[k], f"{kind} episode {k}")
                source = tokens.index["episodes"][k]["source_episode"]
                real = shards.episode(source)[0]
                self.assertEqual(got["actions"], real["actions"][first:first + len(clips[k])])
                with open(os.path.join(export, kind, f"episode_{k}", "meta.json"),
                          encoding="utf-8") as f:
                    meta = json.load(f)
                validator.validate(meta)
                source_of = meta["wmkit_export"]
                self.assertEqual((source_of["kind"], source_of["episode"],
                                  source_of["source_episode"], source_of["first_step"],
                                  source_of["steps"]), (kind, k, source, first, len(clips[k])))
                self.assertEqual(source_of["checkpoint"]["sha256"],
                                 sha256(self.path("dyn", "checkpoint.wmt")))
                self.assertEqual(meta["policy_id"], self.policies[k])
                self.assertEqual(meta["action_space"], "eef_delta")
        # Paired with the real frames, wm-metrics scores an exported rollout as the report did.
        for k in range(EPISODES):
            got = json.loads(ok("wm-metrics", "--ref", os.path.join(export, "real", f"episode_{k}"),
                                "--pred", os.path.join(export, "plain", f"episode_{k}"),
                                "--metrics", "psnr,mse").stdout)
            for metric in ("psnr", "mse"):
                (row,) = [r for r in self.select("per_episode.csv", "plain", metric)
                          if int(r["episode"]) == k]
                self.assert_close(got[metric], float(row["value"]), f"plain {metric} {k}")


if __name__ == "__main__":
    unittest.main(verbosity=2)
