#!/usr/bin/python3
"""wm_metrics against independent references, through build/bin/metrics_ref_tool and .npy files:

- MSE, PSNR, SSIM and the SSIM map against scikit-image 0.19 (structural_similarity with
  gaussian_weights=True, sigma=1.5, use_sample_covariance=False, channel_axis=-1), 1e-6 absolute;
- MS-SSIM against the NumPy/SciPy implementation below, written from Wang et al. 2003 and the
  choices in docs/metrics.md (2x2 average pooling, negative terms clamped to 0), 1e-6 absolute;
- the Fréchet distance against the FID reference formula with scipy.linalg.sqrtm, 1e-6 relative.

Cases: identical, noisy, blurred, JPEG-compressed, inverted, constant, odd sizes, grey and colour,
uint8 / float64 / float32, and the photographs that ship with scikit-image.

Run: /usr/bin/python3 tests/metrics/test_metrics_reference.py (after building metrics_ref_tool)
"""
import json
import os
import subprocess
import tempfile
import unittest
import warnings

import cv2
import numpy as np
import scipy.linalg
import scipy.ndimage
import skimage.data
from skimage.metrics import mean_squared_error, peak_signal_noise_ratio, structural_similarity

SRC = os.environ.get("WM_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
BIN = os.environ.get("WM_BIN_DIR", os.path.join(SRC, "build", "bin"))
TOOL = os.path.join(BIN, "metrics_ref_tool")
MS_SSIM_WEIGHTS = [0.0448, 0.2856, 0.3001, 0.2363, 0.1333]


def reference_ms_ssim(a, b, data_range):
    """Wang et al. 2003, eq. 7, per channel then averaged: cs_j at scales 1-4, l*cs at scale 5,
    each the mean over the map without its 5-pixel border; 2x2 mean pooling between scales."""
    c1, c2 = (0.01 * data_range) ** 2, (0.03 * data_range) ** 2
    blur = lambda x: scipy.ndimage.gaussian_filter(x, 1.5, truncate=3.5, mode="reflect")  # noqa
    a = np.atleast_3d(np.asarray(a, np.float64))
    b = np.atleast_3d(np.asarray(b, np.float64))
    values = []
    for ch in range(a.shape[2]):
        x, y, total = a[:, :, ch], b[:, :, ch], 1.0
        for j, weight in enumerate(MS_SSIM_WEIGHTS):
            mx, my = blur(x), blur(y)
            sxx, syy, sxy = blur(x * x) - mx**2, blur(y * y) - my**2, blur(x * y) - mx * my
            cs = (2 * sxy + c2) / (sxx + syy + c2)
            term = cs if j < 4 else (2 * mx * my + c1) / (mx**2 + my**2 + c1) * cs
            total *= max(term[5:-5, 5:-5].mean(), 0.0) ** weight
            h, w = x.shape[0] // 2 * 2, x.shape[1] // 2 * 2
            x = x[:h, :w].reshape(h // 2, 2, w // 2, 2).mean(axis=(1, 3))
            y = y[:h, :w].reshape(h // 2, 2, w // 2, 2).mean(axis=(1, 3))
        values.append(total)
    return float(np.mean(values))


def reference_frechet(f1, f2):
    """The FID reference implementation's formula (Heusel et al. 2017, pytorch-fid)."""
    mu1, mu2 = f1.mean(axis=0), f2.mean(axis=0)
    s1, s2 = np.cov(f1, rowvar=False), np.cov(f2, rowvar=False)
    covmean = scipy.linalg.sqrtm(s1 @ s2)
    trace = np.trace(s1) + np.trace(s2) - 2 * np.trace(covmean.real)
    return float(((mu1 - mu2) ** 2).sum() + trace)


def jpeg(image, quality):
    ok, buf = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, quality])
    assert ok
    return cv2.imdecode(buf, cv2.IMREAD_UNCHANGED)


def noisy(image, sigma, seed):
    rng = np.random.default_rng(seed)
    return np.clip(np.round(image + rng.normal(0, sigma, image.shape)), 0, 255).astype(np.uint8)


class MetricsReference(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.count = 0
        cls.astronaut = skimage.data.astronaut()  # 512x512x3 uint8, ships with python3-skimage
        cls.camera = skimage.data.camera()  # 512x512 uint8

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def save(self, array):
        MetricsReference.count += 1
        path = os.path.join(self.tmp.name, f"{self.count}.npy")
        np.save(path, np.ascontiguousarray(array))
        return path

    def tool(self, *args):
        p = subprocess.run([TOOL, *args], capture_output=True, text=True)
        self.assertEqual(p.returncode, 0, p.stderr)
        return json.loads(p.stdout)

    def check_images(self, a, b, data_range=None, name=""):
        """Tool vs skimage (and the MS-SSIM reference when both sides are >= 176)."""
        extra = [] if data_range is None else ["--data-range", repr(float(data_range))]
        map_path = os.path.join(self.tmp.name, "map.npy")
        got = self.tool("images", self.save(a), self.save(b), "--ssim-map", map_path,
                        "--threads", "3", *extra)
        r = 255.0 if a.dtype == np.uint8 else float(data_range or 1.0)
        a64, b64 = (a, b) if a.dtype == np.uint8 else (a.astype(np.float64), b.astype(np.float64))
        channel_axis = -1 if a.ndim == 3 else None
        ssim, ssim_map = structural_similarity(
            a64, b64, gaussian_weights=True, sigma=1.5, use_sample_covariance=False, data_range=r,
            channel_axis=channel_axis, full=True)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # identical frames: log10(x / 0)
            psnr = peak_signal_noise_ratio(a64, b64, data_range=r)
        with self.subTest(case=name):
            self.assertAlmostEqual(got["mse"], mean_squared_error(a64, b64), delta=1e-6)
            if np.isinf(psnr):
                self.assertEqual(got["psnr"], "inf")  # the JSON-safe form
            else:
                self.assertAlmostEqual(got["psnr"], psnr, delta=1e-6)
            self.assertAlmostEqual(got["ssim"], ssim, delta=1e-6)
            ours_map = np.load(map_path).reshape(ssim_map.shape)
            self.assertLess(np.abs(ours_map - ssim_map).max(), 1e-6)  # borders: 'reflect' mode
            if min(a.shape[:2]) >= 176:
                self.assertAlmostEqual(got["ms_ssim"], reference_ms_ssim(a64, b64, r), delta=1e-6)
            else:
                self.assertIsNone(got["ms_ssim"])
        return got

    def test_photographs(self):
        astro, cam = self.astronaut, self.camera
        blurred = cv2.GaussianBlur(astro, (7, 7), 2.0)
        got = self.check_images(astro, astro, name="identical astronaut")
        self.assertAlmostEqual(got["ssim"], 1.0, delta=1e-12)
        self.assertAlmostEqual(got["ms_ssim"], 1.0, delta=1e-12)
        self.check_images(astro, noisy(astro, 15, 1), name="noisy astronaut")
        self.check_images(astro, blurred, name="blurred astronaut")
        self.check_images(astro, jpeg(astro, 20), name="JPEG astronaut")
        self.check_images(cam, jpeg(cam, 10), name="JPEG camera (grey)")
        self.check_images(cam, cv2.GaussianBlur(cam, (5, 5), 1.0), name="blurred camera (grey)")
        got = self.check_images(cam, 255 - cam, name="inverted camera: negative cs clamped")
        self.assertEqual(got["ms_ssim"], 0.0)

    def test_odd_and_small_sizes(self):
        rng = np.random.default_rng(2)
        for h, w, c in [(37, 53, 3), (37, 53, 1), (11, 11, 3), (12, 40, 1), (181, 197, 3)]:
            a = rng.integers(0, 256, (h, w, c), dtype=np.uint8)
            a = cv2.GaussianBlur(a, (5, 5), 1.5).reshape(h, w, c)  # some structure to keep
            a = a[:, :, 0] if c == 1 else a
            self.check_images(a, noisy(a, 12, h), name=f"{h}x{w}x{c}")

    def test_float_images(self):
        astro = self.astronaut[100:300, 150:330].astype(np.float64) / 255  # 200x180
        self.check_images(astro, np.clip(astro + 0.05 * np.sin(astro * 20), 0, 1), name="float")
        self.check_images(astro * 2 - 1, np.clip(cv2.GaussianBlur(astro, (5, 5), 1) * 2 - 1, -1, 1),
                          data_range=2.0, name="float in [-1, 1], R = 2")
        cam = (self.camera[:64, :80] / 255).astype(np.float32)
        self.check_images(cam, np.clip(cam * 0.9 + 0.05, 0, 1).astype(np.float32),
                          name="float32 grey")

    def test_constant_images(self):
        a = np.full((20, 30, 3), 100, np.uint8)
        got = self.check_images(a, np.full_like(a, 110), name="constant 100 vs 110")
        self.assertAlmostEqual(got["mse"], 100.0, delta=1e-12)
        self.check_images(a, a, name="constant identical")
        z = np.zeros((180, 180), np.uint8)
        self.check_images(z, np.full_like(z, 255), name="black vs white")

    def test_frechet(self):
        rng = np.random.default_rng(3)
        mix = rng.normal(size=(16, 16))
        x = rng.normal(size=(300, 16)) @ mix
        y = rng.normal(size=(250, 16)) @ (mix + 0.3 * rng.normal(size=(16, 16))) + 0.5
        low_rank_x = rng.normal(size=(10, 24)) * 3  # 10 samples in 24 dims: rank 9
        low_rank_y = rng.normal(size=(14, 24)) + 1
        cases = {"full rank": (x, y), "rank-deficient": (low_rank_x, low_rank_y),
                 "one side rank-deficient": (x[:40, :16], x[:8, :16] * 2)}
        for name, (f1, f2) in cases.items():
            with self.subTest(case=name):
                got = self.tool("frechet", self.save(f1), self.save(f2))["frechet"]
                ref = reference_frechet(f1, f2)
                self.assertLess(abs(got - ref), 1e-6 * abs(ref), f"{got} vs {ref}")
        got = self.tool("frechet", self.save(x), self.save(x))["frechet"]
        self.assertLess(got, 1e-9 * np.trace(np.cov(x, rowvar=False)))

    def test_errors_are_one_line(self):
        p = subprocess.run([TOOL, "images", self.save(np.zeros((150, 160), np.uint8)),
                            self.save(np.zeros((150, 161), np.uint8))], capture_output=True,
                           text=True)
        self.assertEqual(p.returncode, 1)
        self.assertIn("150x160x1 vs 150x161x1", p.stderr)


if __name__ == "__main__":
    unittest.main()
