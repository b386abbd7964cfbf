#!/usr/bin/python3
"""wm-metrics end to end, process start to result, against scikit-image run as a user's script
would run it, in one run (issue 23 item 7):

  startup   wm-metrics --version, and PSNR + SSIM of one pair of 256x256 PNGs (median of --runs
            starts), beside wm-metrics-full, which loads LibTorch, OpenCV and PCL as the single
            wm-metrics did before the split
  folder    PSNR + SSIM of --pairs 256x256 RGB PNG pairs in two folders: one wm-metrics call
            (all cores, and --threads 1) vs one /usr/bin/python3 process that imports
            scikit-image, reads the PNGs (skimage.io) and computes the same means with
            OMP/MKL/OpenBLAS threads = 1; best of --repeats; the means must agree to 1e-6
  per file  the same pairs as one wm-metrics call per pair, as a script looping over files runs it

Run: /usr/bin/python3 bench/metrics_startup_bench.py [--bin build/bin] [--pairs 120] [--runs 20]
     [--repeats 3]
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

import cv2

from metrics_bench import make_pairs  # the same astronaut crops as the throughput benchmark

ONE_THREAD = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1",
              "MKL_NUM_THREADS": "1"}

SKIMAGE_SCRIPT = """
import sys, glob, os, json
import numpy as np
from skimage import io
from skimage.metrics import peak_signal_noise_ratio, structural_similarity
ref, pred = (sorted(glob.glob(os.path.join(d, "*.png"))) for d in sys.argv[1:3])
psnr, ssim = [], []
for a, b in zip(ref, pred):
    a, b = io.imread(a), io.imread(b)
    psnr.append(peak_signal_noise_ratio(a, b, data_range=255))
    ssim.append(structural_similarity(a, b, gaussian_weights=True, sigma=1.5,
                                      use_sample_covariance=False, data_range=255,
                                      channel_axis=-1))
print(json.dumps({"psnr": float(np.mean(psnr)), "ssim": float(np.mean(ssim))}))
"""


def timed(command, env=None):
    """(seconds, stdout) of one process, start to exit."""
    start = time.perf_counter()
    p = subprocess.run(command, capture_output=True, text=True, env=env)
    seconds = time.perf_counter() - start
    if p.returncode != 0:
        raise SystemExit(f"metrics_startup_bench.py: {command[0]} failed: {p.stderr}")
    return seconds, p.stdout


def median_ms(command, runs):
    return 1000 * statistics.median(timed(command)[0] for _ in range(runs))


def best(command, repeats, env=None):
    results = [timed(command, env) for _ in range(repeats)]
    return min(s for s, _ in results), json.loads(results[0][1])


def write_folders(tmp, pairs):
    ref, pred = os.path.join(tmp, "ref"), os.path.join(tmp, "pred")
    for folder in (ref, pred):
        os.makedirs(folder)
    for i, (a, b) in enumerate(pairs):
        cv2.imwrite(os.path.join(ref, f"{i:04d}.png"), cv2.cvtColor(a, cv2.COLOR_RGB2BGR))
        cv2.imwrite(os.path.join(pred, f"{i:04d}.png"), cv2.cvtColor(b, cv2.COLOR_RGB2BGR))
    return ref, pred


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bin", default=os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                                      "..", "build", "bin"))
    for option, default in (("--pairs", 120), ("--runs", 20), ("--repeats", 3)):
        parser.add_argument(option, type=int, default=default)
    args = parser.parse_args()
    light, full = (os.path.join(args.bin, name) for name in ("wm-metrics", "wm-metrics-full"))
    pairs = make_pairs(args.pairs, 256, seed=0)

    with tempfile.TemporaryDirectory() as tmp:
        ref, pred = write_folders(tmp, pairs)
        first = [os.path.join(ref, "0000.png"), os.path.join(pred, "0000.png")]
        one_pair = ["--ref", first[0], "--pred", first[1], "--metrics", "psnr,ssim"]
        print(f"startup, median of {args.runs} starts (ms)    wm-metrics  wm-metrics-full")
        for what, extra in (("--version", ["--version"]), ("one 256x256 PNG pair", one_pair)):
            print(f"  {what:40s} {median_ms([light, *extra], args.runs):10.1f} "
                  f"{median_ms([full, *extra], args.runs):16.1f}")

        folder = ["--ref", ref, "--pred", pred, "--metrics", "psnr,ssim"]
        sk_s, sk = best([sys.executable, "-c", SKIMAGE_SCRIPT, ref, pred], args.repeats,
                        ONE_THREAD)
        print(f"\n{args.pairs} pairs of 256x256 RGB PNG, PSNR + SSIM, process start to result "
              f"(best of {args.repeats})")
        print(f"  scikit-image, python3, 1 thread, skimage.io: {sk_s:7.3f} s")
        for name, command in (("wm-metrics, all cores", [light, *folder]),
                              ("wm-metrics --threads 1", [light, *folder, "--threads", "1"]),
                              ("wm-metrics-full, all cores", [full, *folder])):
            seconds, ours = best(command, args.repeats)
            print(f"  {name:44s} {seconds:7.3f} s  {sk_s / seconds:5.1f}x scikit-image")
            for metric in ("psnr", "ssim"):
                if abs(ours[metric] - sk[metric]) > 1e-6:
                    raise SystemExit(f"metrics_startup_bench.py: {metric} differs: {ours} vs {sk}")

        start = time.perf_counter()
        for i in range(args.pairs):
            timed([light, "--ref", os.path.join(ref, f"{i:04d}.png"),
                   "--pred", os.path.join(pred, f"{i:04d}.png"), "--metrics", "psnr,ssim"])
        loop_s = time.perf_counter() - start
        print(f"  one wm-metrics call per pair ({args.pairs} calls): {loop_s:7.3f} s  "
              f"{sk_s / loop_s:5.1f}x scikit-image")
        print(f"  means agree to 1e-6: PSNR {sk['psnr']:.6f} dB, SSIM {sk['ssim']:.9f}")


if __name__ == "__main__":
    main()
