#!/usr/bin/python3
"""The two programs behind wm-metrics (docs/metrics.md, "Two programs"): the light wm-metrics
links no LibTorch, OpenCV codecs or PCL, and every command gives the same stdout, stderr and exit
code through it as through wm-metrics-full, the whole program as wm-metrics was before the split:
PNG and JPEG it decodes itself; lpips, PNGs it cannot decode as OpenCV does, videos, damaged files
and `seg` it hands over. No timing here: bench/metrics_startup_bench.py measures the start."""
import functools
import os
import shutil
import subprocess
import tempfile
import unittest

import cv2
import numpy as np
from PIL import Image

SRC = os.environ.get("WM_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
BIN = os.environ.get("WM_BIN_DIR", os.path.join(SRC, "build", "bin"))
LIGHT, FULL = os.path.join(BIN, "wm-metrics"), os.path.join(BIN, "wm-metrics-full")


def linked_libraries(program):
    return subprocess.run(["ldd", program], capture_output=True, text=True, check=True).stdout


def run(program, args):
    # argv[0] is the same for both: usage messages name the program as it was called
    p = subprocess.run(["wm-metrics", *args], executable=program, capture_output=True, text=True)
    return p.returncode, p.stdout, p.stderr


def started_programs(args):
    """The executables one wm-metrics command runs, from strace's execve lines."""
    p = subprocess.run(["strace", "-f", "-qq", "-e", "trace=execve", "-e", "signal=none", LIGHT,
                        *args], capture_output=True, text=True)
    return [os.path.basename(line.split('"')[1]) for line in p.stderr.splitlines()
            if line.startswith(("execve(", "[pid")) and "execve(" in line and "= 0" in line]


class LightProgram(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        tmp = tempfile.TemporaryDirectory()
        cls.addClassCleanup(tmp.cleanup)
        cls.path = functools.partial(os.path.join, tmp.name)  # path("ref.png") in the fixtures
        rng = np.random.default_rng(0)
        # 184 x 176: MS-SSIM's five scales need 176 pixels a side
        ref = cv2.GaussianBlur(rng.integers(0, 256, (184, 176, 3), dtype=np.uint8), (5, 5), 0)
        pred = np.clip(ref + rng.normal(0, 6, ref.shape), 0, 255).astype(np.uint8)
        cls.frames = {"ref": ref, "pred": pred}
        for side, rgb in cls.frames.items():
            bgr = cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR)
            cv2.imwrite(cls.path(f"{side}.png"), bgr)
            cv2.imwrite(cls.path(f"{side}.jpg"), bgr)
            cv2.imwrite(cls.path(f"{side}_grey.png"), bgr[..., 0])
            cv2.imwrite(cls.path(f"{side}_rgba.png"), cv2.cvtColor(bgr, cv2.COLOR_BGR2BGRA))
            cv2.imwrite(cls.path(f"{side}_16bit.png"), bgr.astype(np.uint16) * 257)
            Image.fromarray(rgb[..., :2].copy(), "LA").save(cls.path(f"{side}_grey_alpha.png"))
            Image.fromarray(rgb).quantize(64).save(cls.path(f"{side}_palette.png"))
            Image.fromarray(rgb[..., 0]).convert("1").save(cls.path(f"{side}_1bit.png"))
            cv2.imwrite(cls.path(f"{side}.bmp"), bgr)
            os.makedirs(cls.path(f"{side}_folder"))
            for i in range(3):
                cv2.imwrite(cls.path(f"{side}_folder", f"{i:02d}.png"), np.roll(bgr, i, axis=1))
        writer = cv2.VideoWriter(cls.path("clip.avi"), cv2.VideoWriter_fourcc(*"MJPG"), 5, (176, 184))
        for i in range(3):
            writer.write(np.roll(cv2.cvtColor(ref, cv2.COLOR_RGB2BGR), i, axis=1))
        writer.release()
        with open(cls.path("ref.png"), "rb") as f:
            cut = f.read()[:200]
        with open(cls.path("damaged.png"), "wb") as f:
            f.write(cut)
        cls.weights = cls.path("lpips-rand.wmt")
        subprocess.run(["/usr/bin/python3", os.path.join(SRC, "scripts", "export_lpips_weights.py"),
                        "--random-seed", "0", "--out", cls.weights], check=True,
                       capture_output=True)

    def assert_same_as_full(self, args, exit_code=0):
        light, full = run(LIGHT, args), run(FULL, args)
        self.assertEqual(light, full, args)
        self.assertEqual(light[0], exit_code, light[2])
        return light

    def test_light_program_links_no_torch_opencv_codecs_or_pcl(self):
        libraries = linked_libraries(LIGHT)
        self.assertEqual(libraries.count("torch"), 0, libraries)
        for heavy in ("libopencv_imgcodecs", "libopencv_videoio", "libpcl_", "libc10"):
            self.assertNotIn(heavy, libraries)
        self.assertIn("libtorch", linked_libraries(FULL))  # the split is real: lpips lives there

    def test_png_and_jpeg_are_decoded_here_with_full_program_results(self):
        for name in ("", "_grey", "_rgba", "_16bit"):
            args = ["--ref", self.path(f"ref{name}.png"), "--pred", self.path(f"pred{name}.png"),
                    "--metrics", "mse,psnr,ssim,ms_ssim"]
            self.assert_same_as_full(args)
            self.assertEqual(started_programs(args), ["wm-metrics"], name)
        for args in (["--ref", self.path("ref.jpg"), "--pred", self.path("pred.jpg")],
                     ["--ref", self.path("ref_folder"), "--pred", self.path("pred_folder"),
                      "--per-frame", "--format", "csv"],
                     ["--ref", self.path("ref_folder"), "--pred", self.path("pred_folder"),
                      "--mask", self.path("ref_grey.png")]):
            self.assert_same_as_full(args)
            self.assertEqual(started_programs(args), ["wm-metrics"], args)

    def test_lpips_through_the_light_program_equals_the_full_program(self):
        args = ["--ref", self.path("ref_folder"), "--pred", self.path("pred_folder"),
                "--metrics", "psnr,lpips", "--lpips-weights", self.weights, "--per-frame",
                "--threads", "1"]
        out = self.assert_same_as_full(args)[1]
        self.assertIn('"lpips"', out)
        self.assertEqual(started_programs(args), ["wm-metrics", "wm-metrics-full"])

    def test_inputs_opencv_reads_differently_are_handed_over(self):
        for name in ("_grey_alpha.png", "_palette.png", "_1bit.png", ".bmp"):
            args = ["--ref", self.path(f"ref{name}"), "--pred", self.path(f"pred{name}")]
            self.assert_same_as_full(args)
            self.assertEqual(started_programs(args), ["wm-metrics", "wm-metrics-full"], name)
        # grey+alpha is RGB to OpenCV: it pairs with a colour PNG
        self.assert_same_as_full(["--ref", self.path("ref.png"),
                                  "--pred", self.path("pred_grey_alpha.png")])
        self.assert_same_as_full(["--ref", self.path("clip.avi"), "--pred", self.path("clip.avi"),
                                  "--per-frame"])

    def test_errors_are_the_full_programs(self):
        for args in (["--ref", self.path("damaged.png"), "--pred", self.path("ref.png")],
                     ["--ref", self.path("ref.png"), "--pred", self.path("absent.png")],
                     ["--ref", self.path("ref.png"), "--pred", self.path("ref_grey.png")],
                     ["--ref", self.path("ref_folder"), "--pred", self.path("ref.png")],
                     ["--ref", self.path("ref.png"), "--pred", self.path("ref.png"),
                      "--metrics", "lpips"],
                     ["--ref", self.path("ref.png"), "--pred", self.path("ref.png"),
                      "--metrics", "fvd_style", "--feature-net", self.path("absent")]):
            self.assert_same_as_full(args, exit_code=1)
        for args in (["--metrics", "psnr"], ["--ref", self.path("ref.png")], ["--bogus"],
                     ["seg", "--ref", self.path("ref_folder")]):
            self.assert_same_as_full(args, exit_code=2)

    def test_help_version_and_subcommands_are_the_full_programs(self):
        for args in (["--help"], ["--version"], ["value", "--help"], ["scaling", "--help"],
                     ["seg", "--help"]):
            self.assert_same_as_full(args)
        self.assertEqual(started_programs(["--version"]), ["wm-metrics"])
        self.assertEqual(started_programs(["seg", "--help"]), ["wm-metrics", "wm-metrics-full"])

    def test_a_missing_full_program_is_one_clear_error(self):
        with tempfile.TemporaryDirectory() as alone:
            light = shutil.copy(LIGHT, alone)  # a copy: /proc/self/exe sees through links
            p = subprocess.run([light, "--ref", self.path("clip.avi"), "--pred",
                                self.path("clip.avi")], capture_output=True, text=True)
        self.assertEqual(p.returncode, 1)
        self.assertIn("cannot start wm-metrics-full", p.stderr)
        self.assertEqual(len(p.stderr.splitlines()), 1, p.stderr)


if __name__ == "__main__":
    unittest.main(verbosity=2)
