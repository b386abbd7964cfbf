#!/usr/bin/python3
"""wm-metrics lpips_style and fvd_style (docs/metrics.md) against NumPy/SciPy re-computations
from the encoder features that tokenizer_ref_tool writes for the same frames (the tool runs the
Tokenizer API; resizing, scaling, the distances and the Fréchet statistic are redone here), on a
tokenizer trained for 20 steps and tabletop frames read from the shards with wmshard.py. Also:
the same numbers when streamed in chunks, identical inputs give 0, lpips_style is symmetric, usage errors name --feature-net or the file,
and CSV leaves the per-frame fvd_style cells empty."""
import csv
import io
import json
import os
import subprocess
import sys
import tempfile
import unittest

import cv2
import numpy as np
import scipy.linalg

SRC = os.environ.get("WM_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
BIN = os.environ.get("WM_BIN_DIR", os.path.join(SRC, "build", "bin"))
sys.path.insert(0, os.path.join(SRC, "scripts"))
import wmshard  # noqa: E402  (the independent Python reader of shards)

FRAMES, SIZE, CLIP = 8, 64, 2  # 8 frames in clips of 2: 4 clips per side for fvd_style


def run(tool, *args, check=True):
    p = subprocess.run([os.path.join(BIN, tool), *map(str, args)], capture_output=True, text=True)
    if check and p.returncode != 0:
        raise AssertionError(f"{tool} exited {p.returncode}: {p.stderr}")
    return p


def write_folder(path, frames):
    os.makedirs(path)
    for i, rgb in enumerate(frames):
        cv2.imwrite(os.path.join(path, f"{i:03d}.png"), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))


def tokenizer_input(folder):
    """Rgb8ToPlanar in NumPy: INTER_AREA to the tokenizer size, /127.5 - 1 in float32, planar."""
    out = []
    for name in sorted(os.listdir(folder)):
        rgb = cv2.cvtColor(cv2.imread(os.path.join(folder, name)), cv2.COLOR_BGR2RGB)
        if rgb.shape[:2] != (SIZE, SIZE):
            rgb = cv2.resize(rgb, (SIZE, SIZE), interpolation=cv2.INTER_AREA)
        out.append((rgb.astype(np.float32) / np.float32(127.5) - np.float32(1)).transpose(2, 0, 1))
    return np.ascontiguousarray(np.stack(out))  # [n, 3, S, S]


def lpips_style(fa, fb):
    """Per frame: sum over layers of the space-mean of the channel-summed squared difference of
    channel-unit-normalised features (eps 1e-10 added to the norm, as LPIPS)."""
    def unit(f):
        f = f.astype(np.float64)
        return f / (np.sqrt((f ** 2).sum(1, keepdims=True)) + 1e-10)
    return sum(((unit(a) - unit(b)) ** 2).sum(1).mean((1, 2)) for a, b in zip(fa, fb))


def clip_descriptors(features, clip):
    """Per clip: mean and population std over its frames of the space-averaged features."""
    d = np.concatenate([f.astype(np.float64).mean((2, 3)) for f in features], 1)  # [n, dim]
    clips = d[:len(d) // clip * clip].reshape(-1, clip, d.shape[1])  # remainder dropped
    return np.concatenate([clips.mean(1), clips.std(1)], 1)  # [clips, 2 dim]


def frechet(x, y):
    s1, s2 = np.cov(x, rowvar=False), np.cov(y, rowvar=False)  # ddof = 1
    covmean = scipy.linalg.sqrtm(s1 @ s2).real
    return ((x.mean(0) - y.mean(0)) ** 2).sum() + np.trace(s1 + s2 - 2 * covmean)


class FeatureMetrics(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        raw, shards, cls.tok = cls.path("raw"), cls.path("shards"), cls.path("tok")
        run("wm-gen-tabletop", "--out", raw, "--size", SIZE, "--train-episodes", 4,
            "--val-episodes", 1, "--seed", 0)
        run("wm-ingest", "--format", "rlds", "--input", os.path.join(raw, "wm_tabletop", "1.0.0"),
            "--split", "train", "--output", shards, "--threads", 1)
        run("wm-tokenize", "train", "--config", os.path.join(SRC, "configs", "tokenizer",
            "tiny.yaml"), "--data", shards, "--out", cls.tok, "--steps", 20, "--threads", 1)
        _, _, blobs = wmshard.Dataset(shards).episode(0)
        assert len(blobs["image"]) >= 2 * FRAMES, "episode 0 is too short for this fixture"
        ref = [cv2.cvtColor(cv2.imdecode(np.frombuffer(b, np.uint8), cv2.IMREAD_COLOR),
                            cv2.COLOR_BGR2RGB) for b in blobs["image"][:2 * FRAMES:2]]
        rng = np.random.default_rng(0)
        # The prediction: shifted 2 px right and 1 px down, plus noise, like an imperfect rollout.
        pred = [np.clip(np.roll(f, (1, 2), (0, 1)) + rng.normal(0, 6, f.shape), 0, 255)
                .astype(np.uint8) for f in ref]
        for name, frames in [("ref", ref), ("pred", pred)]:
            write_folder(cls.path(name), frames)
            # 96 x 96 copies: wm-metrics resizes them to the tokenizer's 64 (INTER_AREA)
            write_folder(cls.path(name + "96"), [cv2.resize(f, (96, 96),
                         interpolation=cv2.INTER_CUBIC) for f in frames])

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    @classmethod
    def path(cls, *parts):
        return os.path.join(cls.tmp.name, *parts)

    def features(self, folder):
        """The encoder feature maps of tokenizer_ref_tool for a folder's frames, shallow first."""
        frames, out = self.path(folder + ".f32"), self.path("features", folder)
        tokenizer_input(self.path(folder)).tofile(frames)
        shapes = json.loads(run("tokenizer_ref_tool", "--checkpoint", self.tok, "--frames",
                                frames, "--out-dir", out, "--threads", 1).stdout)["features"]
        return [np.load(os.path.join(out, f"features_{k}.npy")) for k in range(len(shapes))]

    def metrics(self, ref, pred, *args, metrics="lpips_style,fvd_style", clip=CLIP, check=True):
        p = run("wm-metrics", "--ref", self.path(ref), "--pred", self.path(pred), "--metrics",
                metrics, "--feature-net", self.tok, "--clip-length", clip, "--threads", 1, *args,
                check=check)
        return p if not check or "csv" in args else json.loads(p.stdout)

    def test_lpips_style_per_frame_matches_numpy(self):
        for ref, pred in [("ref", "pred"), ("ref96", "pred96")]:
            with self.subTest(size=ref):
                want = lpips_style(self.features(ref), self.features(pred))
                out = self.metrics(ref, pred, "--per-frame", metrics="lpips_style")
                got = [row["lpips_style"] for row in out["per_frame"]]
                self.assertTrue(np.all(want > 0))
                np.testing.assert_allclose(got, want, rtol=1e-6, atol=0)
                np.testing.assert_allclose(out["lpips_style"], want.mean(), rtol=1e-6, atol=0)

    def test_fvd_style_matches_scipy(self):
        # 4 (or 2) clips of 448-dimensional descriptors: both covariances have rank 3 (or 1), so
        # S1 S2 is singular and sqrtm of it ill-conditioned (imaginary parts ~1e-6 of the real
        # ones); its trace then differs from the C++'s (which drops eigenvalues below the rank
        # tolerance) by 2-4e-6 relative on this fixture. fvd_style is ~7e-5 here, so an absolute
        # 1e-8 would allow 1.5e-4 relative: the check is relative only.
        ref, pred = self.features("ref"), self.features("pred")
        for clip in (CLIP, 3):  # 3: 2 clips, the remaining 2 frames dropped
            with self.subTest(clip_length=clip):
                x, y = clip_descriptors(ref, clip), clip_descriptors(pred, clip)
                out = self.metrics("ref", "pred", metrics="fvd_style", clip=clip)
                self.assertEqual(out["fvd_style_clips"], FRAMES // clip)
                np.testing.assert_allclose(out["fvd_style"], frechet(x, y), rtol=1e-5, atol=0)

    # Chunks of 3 frames split the second clip of 2 across two chunks: the carried frames must
    # give the same clips (the encoder runs on other batch sizes, hence not bit-equal).
    def test_streaming_in_chunks_gives_the_same_numbers(self):
        whole = self.metrics("ref", "pred", "--per-frame")
        chunked = self.metrics("ref", "pred", "--per-frame", "--chunk-frames", 3)
        self.assertEqual(chunked["fvd_style_clips"], whole["fvd_style_clips"])
        np.testing.assert_allclose(chunked["fvd_style"], whole["fvd_style"], rtol=1e-5)
        np.testing.assert_allclose([r["lpips_style"] for r in chunked["per_frame"]],
                                   [r["lpips_style"] for r in whole["per_frame"]], rtol=1e-5)

    def test_identical_inputs_give_zero(self):
        out = self.metrics("pred", "pred", "--per-frame")
        self.assertLessEqual(abs(out["fvd_style"]), 1e-9)
        for value in [out["lpips_style"]] + [r["lpips_style"] for r in out["per_frame"]]:
            self.assertLessEqual(abs(value), 1e-9)

    def test_lpips_style_is_symmetric(self):
        there = self.metrics("ref", "pred", "--per-frame", metrics="lpips_style")
        back = self.metrics("pred", "ref", "--per-frame", metrics="lpips_style")
        np.testing.assert_allclose([r["lpips_style"] for r in back["per_frame"]],
                                   [r["lpips_style"] for r in there["per_frame"]], rtol=1e-12)

    def test_lpips_style_without_feature_net_is_refused(self):
        p = run("wm-metrics", "--ref", self.path("ref"), "--pred", self.path("pred"),
                "--metrics", "lpips_style", check=False)
        self.assertNotEqual(p.returncode, 0)
        self.assertIn("--feature-net", p.stderr)

    def test_fvd_style_with_too_few_frames_names_the_file(self):
        p = self.metrics("ref", "pred", clip=FRAMES + 1, check=False)
        self.assertEqual(p.returncode, 1)
        self.assertIn(self.path("ref"), p.stderr)

    # 8 frames in clips of 5 make one clip: a Gaussian fit needs two, so the error names the
    # input and the option instead of failing inside the fit.
    def test_fvd_style_with_one_clip_names_the_file(self):
        p = self.metrics("ref", "pred", clip=FRAMES // 2 + 1, check=False)
        self.assertEqual(p.returncode, 1)
        self.assertIn(self.path("ref"), p.stderr)
        self.assertIn("--clip-length", p.stderr)

    def test_csv_leaves_per_frame_fvd_style_empty(self):
        rows = list(csv.DictReader(io.StringIO(
            self.metrics("ref", "pred", "--per-frame", "--format", "csv").stdout)))
        want = self.metrics("ref", "pred")
        self.assertEqual(len(rows), FRAMES + 1)
        for row in rows[:-1]:
            self.assertEqual(row["fvd_style"], "")
            self.assertGreater(float(row["lpips_style"]), 0)
        self.assertEqual(rows[-1]["frame"], "mean")
        np.testing.assert_allclose([float(rows[-1][m]) for m in ("lpips_style", "fvd_style")],
                                   [want["lpips_style"], want["fvd_style"]], rtol=1e-12)


if __name__ == "__main__":
    unittest.main()
