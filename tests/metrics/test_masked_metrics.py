#!/usr/bin/python3
"""`wm-metrics --mask`: MSE, PSNR and SSIM inside a mask against NumPy and scikit-image's SSIM
map (mean over the mask's pixels inside the 5-pixel border, every channel), one mask for every
frame or one per frame, the same numbers when streamed in chunks of 1 or 2 frames, and the errors: a metric with no masked form, a mask of another size,
a mask empty in every frame."""
import json
import os
import subprocess
import tempfile
import unittest

import cv2
import numpy as np
from skimage.metrics import structural_similarity

SRC = os.environ.get("WM_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
BIN = os.environ.get("WM_BIN_DIR", os.path.join(SRC, "build", "bin"))
CROP = 5


def reference(a, b, mask):
    inside = mask != 0
    d = (a.astype(np.float64) - b.astype(np.float64))[inside]
    mse = float(np.mean(d * d))
    _, ssim_map = structural_similarity(a, b, gaussian_weights=True, sigma=1.5,
                                        use_sample_covariance=False, data_range=255,
                                        channel_axis=-1, full=True)
    core = np.zeros_like(inside)
    core[CROP:-CROP, CROP:-CROP] = True
    return mse, 10 * np.log10(255.0 ** 2 / mse), float(ssim_map[inside & core].mean())


class MaskedMetricsTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        rng = np.random.default_rng(3)
        cls.frames = {"ref": [], "pred": [], "masks": []}
        for name in cls.frames:
            os.makedirs(cls.path(name))
        for i in range(3):
            a = cv2.GaussianBlur(rng.integers(0, 256, (48, 40, 3), dtype=np.uint8), (5, 5), 0)
            b = np.clip(a + rng.normal(0, 12, a.shape), 0, 255).astype(np.uint8)
            m = np.zeros((48, 40), np.uint8)
            m[4 + i:30 + i, 8:36] = 255  # touches the SSIM border: those pixels are left out
            for name, img in (("ref", a), ("pred", b), ("masks", m)):
                cls.frames[name].append(img)
                rgb = img if img.ndim == 2 else cv2.cvtColor(img, cv2.COLOR_RGB2BGR)
                cv2.imwrite(os.path.join(cls.path(name), f"{i:03d}.png"), rgb)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    @classmethod
    def path(cls, name):
        return os.path.join(cls.tmp.name, name)

    def metrics(self, *args):
        return subprocess.run([os.path.join(BIN, "wm-metrics"), "--ref", self.path("ref"),
                               "--pred", self.path("pred"), *map(str, args)],
                              capture_output=True, text=True)

    def test_per_frame_masks_match_numpy_and_skimage(self):
        p = self.metrics("--mask", self.path("masks"), "--per-frame")
        self.assertEqual(p.returncode, 0, p.stderr)
        out = json.loads(p.stdout)
        want = [reference(a, b, m) for a, b, m in
                zip(self.frames["ref"], self.frames["pred"], self.frames["masks"])]
        for row, (mse, psnr, ssim), m in zip(out["per_frame"], want, self.frames["masks"]):
            self.assertAlmostEqual(row["mse"], mse, delta=1e-9 * mse)
            self.assertAlmostEqual(row["psnr"], psnr, delta=1e-9 * psnr)
            self.assertAlmostEqual(row["ssim"], ssim, delta=1e-6)
            self.assertEqual(row["mask_pixels"], int(np.count_nonzero(m)))
        for k, name in enumerate(["mse", "psnr", "ssim"]):
            self.assertAlmostEqual(out[name], np.mean([w[k] for w in want]), delta=1e-6)

    def test_one_mask_applies_to_every_frame(self):
        mask_file = os.path.join(self.path("masks"), "001.png")
        out = json.loads(self.metrics("--mask", mask_file, "--per-frame").stdout)
        m = self.frames["masks"][1]
        for row, a, b in zip(out["per_frame"], self.frames["ref"], self.frames["pred"]):
            self.assertAlmostEqual(row["ssim"], reference(a, b, m)[2], delta=1e-6)

    def test_streaming_in_chunks_gives_the_same_numbers(self):
        whole = json.loads(self.metrics("--mask", self.path("masks"), "--per-frame").stdout)
        for chunk in (1, 2):
            p = self.metrics("--mask", self.path("masks"), "--per-frame", "--chunk-frames", chunk)
            self.assertEqual(p.returncode, 0, p.stderr)
            self.assertEqual(json.loads(p.stdout), whole)

    def test_mask_count_other_than_one_or_one_per_frame_is_refused(self):
        for count, message in ((2, "fewer masks than frames"), (4, "more masks than frames")):
            folder = os.path.join(self.tmp.name, f"masks{count}")
            os.makedirs(folder)
            for i in range(count):
                cv2.imwrite(os.path.join(folder, f"{i:03d}.png"), self.frames["masks"][i % 3])
            p = self.metrics("--mask", folder, "--chunk-frames", 2)
            self.assertEqual(p.returncode, 1)
            self.assertIn(message, p.stderr)
            self.assertIn(folder, p.stderr)

    def test_errors_name_the_option_or_file(self):
        p = self.metrics("--mask", self.path("masks"), "--metrics", "psnr,ms_ssim")
        self.assertEqual(p.returncode, 1)
        self.assertIn("ms_ssim", p.stderr)
        small = os.path.join(self.tmp.name, "small.png")
        cv2.imwrite(small, np.full((10, 10), 255, np.uint8))
        p = self.metrics("--mask", small)
        self.assertEqual(p.returncode, 1)
        self.assertIn("small.png", p.stderr)
        empty = os.path.join(self.tmp.name, "empty.png")
        cv2.imwrite(empty, np.zeros((48, 40), np.uint8))
        p = self.metrics("--mask", empty)
        self.assertEqual(p.returncode, 1)
        self.assertIn("empty in every frame", p.stderr)


if __name__ == "__main__":
    unittest.main()
