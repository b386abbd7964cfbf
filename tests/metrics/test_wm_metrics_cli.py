#!/usr/bin/python3
"""wm-metrics end to end: folder and video inputs against scikit-image's values, CSV output, and
clear errors (exit 1, the file named) for mismatched sizes, counts, empty folders, bad files, and
peak memory that does not grow with the number of frames."""
import csv
import io
import json
import os
import subprocess
import tempfile
import unittest

import cv2
import numpy as np
import skimage.data
from skimage.metrics import peak_signal_noise_ratio, structural_similarity

SRC = os.environ.get("WM_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
BIN = os.environ.get("WM_BIN_DIR", os.path.join(SRC, "build", "bin"))


def wm_metrics(*args, check=True):
    p = subprocess.run([f"{BIN}/wm-metrics", *args], capture_output=True, text=True)
    if check and p.returncode != 0:
        raise AssertionError(p.stderr)
    return p


def write_rgb(path, rgb):
    cv2.imwrite(path, cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))


class WmMetricsCli(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.ref, self.pred = os.path.join(self.tmp.name, "ref"), os.path.join(self.tmp.name, "pred")
        os.makedirs(self.ref)
        os.makedirs(self.pred)
        photo = skimage.data.astronaut()[100:300, 120:320]
        rng = np.random.default_rng(0)
        self.pairs = []
        for i in range(3):
            a = np.roll(photo, 7 * i, axis=1)
            b = np.clip(a + rng.normal(0, 4 + 3 * i, a.shape), 0, 255).astype(np.uint8)
            write_rgb(os.path.join(self.ref, f"{i:03d}.png"), a)
            write_rgb(os.path.join(self.pred, f"{i:03d}.png"), b)
            self.pairs.append((a, b))

    def tearDown(self):
        self.tmp.cleanup()

    def test_folder_means_equal_scikit_image(self):
        out = json.loads(wm_metrics("--ref", self.ref, "--pred", self.pred,
                                    "--metrics", "psnr,ssim,mse", "--per-frame").stdout)
        psnr = [peak_signal_noise_ratio(a, b, data_range=255) for a, b in self.pairs]
        ssim = [structural_similarity(a, b, channel_axis=-1, gaussian_weights=True, sigma=1.5,
                                      use_sample_covariance=False, data_range=255)
                for a, b in self.pairs]
        self.assertEqual(out["frames"], 3)
        self.assertAlmostEqual(out["psnr"], np.mean(psnr), delta=1e-9)
        self.assertAlmostEqual(out["ssim"], np.mean(ssim), delta=1e-9)
        for row, p, s in zip(out["per_frame"], psnr, ssim):
            self.assertAlmostEqual(row["psnr"], p, delta=1e-9)
            self.assertAlmostEqual(row["ssim"], s, delta=1e-9)

    def test_csv_has_a_row_per_frame_and_the_mean(self):
        text = wm_metrics("--ref", self.ref, "--pred", self.pred, "--metrics", "psnr,ssim",
                          "--per-frame", "--format", "csv").stdout
        rows = list(csv.DictReader(io.StringIO(text)))
        self.assertEqual([r["frame"].endswith(".png") for r in rows], [True] * 3 + [False])
        self.assertEqual(rows[-1]["frame"], "mean")
        self.assertAlmostEqual(float(rows[-1]["psnr"]),
                               np.mean([float(r["psnr"]) for r in rows[:3]]), delta=1e-9)

    def test_identical_inputs_give_inf_psnr_as_a_string(self):
        out = json.loads(wm_metrics("--ref", self.ref, "--pred", self.ref).stdout)
        self.assertEqual(out["psnr"], "inf")
        self.assertEqual(out["ssim"], 1.0)
        self.assertEqual(out["mse"], 0.0)

    def test_errors_name_the_file_and_exit_1(self):
        small = os.path.join(self.tmp.name, "small.png")
        write_rgb(small, np.zeros((20, 30, 3), np.uint8))
        p = wm_metrics("--ref", os.path.join(self.ref, "000.png"), "--pred", small, check=False)
        self.assertEqual(p.returncode, 1)
        self.assertIn("small.png", p.stderr)
        empty = os.path.join(self.tmp.name, "empty")
        os.makedirs(empty)
        p = wm_metrics("--ref", self.ref, "--pred", empty, check=False)
        self.assertEqual(p.returncode, 1)
        self.assertIn("empty", p.stderr)
        bad = os.path.join(self.tmp.name, "bad.png")
        with open(bad, "wb") as f:
            f.write(b"not a png")
        p = wm_metrics("--ref", bad, "--pred", bad, check=False)
        self.assertEqual(p.returncode, 1)
        self.assertIn("bad.png", p.stderr)
        p = wm_metrics("--ref", self.ref, "--pred", self.pred, "--metrics", "lpips", check=False)
        self.assertEqual(p.returncode, 1)
        self.assertIn("--lpips-weights", p.stderr)

    def test_video_frames_are_compared_in_order(self):
        video = os.path.join(self.tmp.name, "clip.avi")
        writer = cv2.VideoWriter(video, cv2.VideoWriter_fourcc(*"MJPG"), 5, (200, 200))
        for a, _ in self.pairs:
            writer.write(cv2.cvtColor(a, cv2.COLOR_RGB2BGR))
        writer.release()
        out = json.loads(wm_metrics("--ref", video, "--pred", video, "--per-frame").stdout)
        self.assertEqual(out["frames"], 3)
        self.assertEqual(out["ssim"], 1.0)
        vs_ref = json.loads(wm_metrics("--ref", self.ref, "--pred", video).stdout)
        self.assertGreater(vs_ref["psnr"], 25)  # MJPG is lossy but close to the frames

    # Frames stream through in chunks: peak memory must not grow with the number of frames.
    # 600 frames of 256x256 RGB held as doubles would take 2 x 900 MiB.
    def test_memory_stays_bounded_on_long_folders(self):
        frame = cv2.GaussianBlur(np.random.default_rng(1).integers(0, 256, (256, 256, 3),
                                                                   dtype=np.uint8), (9, 9), 0)
        peak = {}
        for count in (60, 600):
            folder = os.path.join(self.tmp.name, f"long{count}")
            os.makedirs(folder)
            for i in range(count):
                cv2.imwrite(os.path.join(folder, f"{i:04d}.png"), np.roll(frame, i, axis=0))
            with tempfile.TemporaryFile() as stdout:  # a file: a full pipe would block wait4
                proc = subprocess.Popen([os.path.join(BIN, "wm-metrics"), "--ref", folder,
                                         "--pred", folder, "--metrics", "psnr,ssim",
                                         "--threads", "2"], stdout=stdout)
                _, status, usage = os.wait4(proc.pid, 0)
                self.assertEqual(status, 0)
                stdout.seek(0)
                out = json.loads(stdout.read())
            self.assertEqual(out["frames"], count)
            peak[count] = usage.ru_maxrss / 1024  # MiB
        self.assertLess(peak[600] - peak[60], 100, peak)


if __name__ == "__main__":
    unittest.main(verbosity=2)
