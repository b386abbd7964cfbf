#!/usr/bin/python3
"""SSIM + PSNR throughput: scikit-image 0.19 (single-threaded) vs wm_metrics (metrics_bench, on
all hardware threads and on one) on the same 256x256 RGB uint8 pairs, in one run. Prints pairs/s
for each and the ratios, and checks that both give the same mean SSIM and PSNR. In memory, no
process start or PNG reading: bench/metrics_startup_bench.py measures wm-metrics end to end.

Run: /usr/bin/python3 bench/metrics_bench.py [--bin build/bin] [--pairs 64] [--repeats 3]
"""
import argparse
import json
import os
import subprocess
import tempfile
import time

for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[var] = "1"  # scikit-image single-threaded, as documented

import cv2  # noqa: E402
import numpy as np  # noqa: E402
import skimage.data  # noqa: E402
from skimage.metrics import peak_signal_noise_ratio, structural_similarity  # noqa: E402

cv2.setNumThreads(1)


def make_pairs(count, size, seed):
    """Crops of the astronaut photograph against noisy, blurred or JPEG-compressed copies."""
    rng = np.random.default_rng(seed)
    photo = skimage.data.astronaut()
    pairs = []
    for i in range(count):
        y, x = rng.integers(0, photo.shape[0] - size, 2)
        a = np.ascontiguousarray(photo[y:y + size, x:x + size])
        if i % 3 == 0:
            b = np.clip(a + rng.normal(0, 10, a.shape), 0, 255).astype(np.uint8)
        elif i % 3 == 1:
            b = cv2.GaussianBlur(a, (5, 5), 1.2)
        else:
            b = cv2.imdecode(cv2.imencode(".jpg", a, [cv2.IMWRITE_JPEG_QUALITY, 30])[1], 1)
        pairs.append((a, b))
    return pairs


def time_skimage(pairs, repeats):
    best, ssim, psnr = float("inf"), [], []
    for _ in range(repeats):
        start = time.perf_counter()
        ssim = [structural_similarity(a, b, gaussian_weights=True, sigma=1.5,
                                      use_sample_covariance=False, data_range=255, channel_axis=-1)
                for a, b in pairs]
        psnr = [peak_signal_noise_ratio(a, b, data_range=255) for a, b in pairs]
        best = min(best, time.perf_counter() - start)
    return len(pairs) / best, float(np.mean(ssim)), float(np.mean(psnr))


def main():
    root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bin", default=os.path.join(root, "build", "bin"))
    parser.add_argument("--pairs", type=int, default=64)
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()

    pairs = make_pairs(args.pairs, args.size, seed=0)
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "pairs.u8")
        np.stack([np.stack(p) for p in pairs]).tofile(path)  # [N, 2, H, W, 3]
        runs = [json.loads(subprocess.run(
            [os.path.join(args.bin, "metrics_bench"), "--pairs", path, "--count", str(args.pairs),
             "--height", str(args.size), "--width", str(args.size), "--channels", "3",
             "--repeats", str(max(args.repeats, 5)), "--threads", str(threads), "--json"],
            check=True, capture_output=True, text=True).stdout) for threads in (0, 1)]
    sk_rate, sk_ssim, sk_psnr = time_skimage(pairs, args.repeats)

    print(f"{args.pairs} pairs of {args.size}x{args.size}x3 uint8, SSIM + PSNR")
    print(f"  scikit-image {skimage.__version__}, 1 thread: {sk_rate:9.1f} pairs/s")
    for ours in runs:
        print(f"  wm_metrics, {ours['threads']} thread(s):      {ours['pairs_per_s']:9.1f} pairs/s"
              f"  {ours['pairs_per_s'] / sk_rate:5.1f}x")
    ours = runs[0]
    print("  goal >= 30x on all threads")
    d_ssim = abs(ours["mean"]["ssim"] - sk_ssim)
    d_psnr = abs(ours["mean"]["psnr"] - sk_psnr)
    print(f"  mean SSIM {sk_ssim:.9f} (|diff| {d_ssim:.1e}), mean PSNR {sk_psnr:.6f} dB "
          f"(|diff| {d_psnr:.1e})")
    if d_ssim > 1e-6 or d_psnr > 1e-6:
        raise SystemExit("metrics_bench.py: wm_metrics and scikit-image disagree")


if __name__ == "__main__":
    main()
