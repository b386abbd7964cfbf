#!/usr/bin/python3
"""LPIPS throughput: wm::metrics::Lpips (lpips_ref_tool, LibTorch) vs the PyTorch reference
(scripts/export_lpips_weights.py:reference_lpips) on the same weights, the same uint8 image pairs
and the same torch thread count. A "frame" is one image pair (prediction vs ground truth).

  python3 bench/lpips_bench.py [--bin build/bin] [--weights W.wmt] [--threads N] [--repeat R]
                               [--rounds K]

Without --weights it writes fixed random weights (--random-seed 0); the network and its cost are
the same as with the real LPIPS weights. Both sides time --repeat passes after one warm-up pass;
each pass converts the uint8 images and runs batch 16 (the C++ side also copies them in). The
sides alternate for --rounds rounds and each keeps its best, as other jobs may share the cores.
Exit codes: 0 ok, 1 a run failed.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "scripts"))
import export_lpips_weights as ew  # noqa: E402


def bench_cpp(tool, weights, a, b, tmp, threads, repeat):
    pa, pb = os.path.join(tmp, "a.npy"), os.path.join(tmp, "b.npy")
    np.save(pa, a)
    np.save(pb, b)
    out = subprocess.run([tool, "--weights", weights, "--a", pa, "--b", pb, "--batch-size",
                          str(len(a)), "--threads", str(threads), "--repeat", str(repeat)],
                         check=True, capture_output=True, text=True).stdout
    r = json.loads(out)
    return r["pairs_per_second"], np.array(r["distances"])


def bench_torch(net, a, b, repeat):
    import torch

    def run():
        with torch.no_grad():
            x0 = torch.from_numpy(a).permute(0, 3, 1, 2).float() / 127.5 - 1
            x1 = torch.from_numpy(b).permute(0, 3, 1, 2).float() / 127.5 - 1
            return net(x0, x1).sum(1)

    run()
    start = time.perf_counter()
    for _ in range(repeat):
        d = run()
    return len(a) * repeat / (time.perf_counter() - start), d.double().numpy()


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--bin", default=os.path.join(HERE, "..", "build", "bin"))
    ap.add_argument("--weights")
    ap.add_argument("--threads", type=int, default=os.cpu_count())
    ap.add_argument("--repeat", type=int, default=10)
    ap.add_argument("--batch", type=int, default=16)
    ap.add_argument("--rounds", type=int, default=3, help="alternating runs; best of each kept")
    args = ap.parse_args()
    import torch
    torch.set_num_threads(args.threads)
    tool = os.path.join(args.bin, "lpips_ref_tool")
    rng = np.random.default_rng(0)
    with tempfile.TemporaryDirectory() as tmp:
        weights = args.weights
        if weights is None:
            weights = os.path.join(tmp, "lpips-rand0.wmt")
            subprocess.run([sys.executable, os.path.join(HERE, "..", "scripts",
                                                         "export_lpips_weights.py"),
                            "--random-seed", "0", "--out", weights], check=True,
                           capture_output=True)
        net = ew.reference_lpips(ew.read_archive(weights)[0])
        print(f"LPIPS v0.1 alex, batch {args.batch}, {args.threads} torch threads, "
              f"torch {torch.__version__}; frames/s = image pairs per second")
        print(f"{'size':>9} {'C++ (LibTorch)':>16} {'PyTorch ref':>12} {'ratio':>6} {'max|diff|':>10}")
        for size in (64, 256):
            a = rng.integers(0, 256, (args.batch, size, size, 3), dtype=np.uint8)
            b = rng.integers(0, 256, (args.batch, size, size, 3), dtype=np.uint8)
            cpp = ref = 0.0
            for _ in range(args.rounds):  # alternate, keep each side's best: machines are shared
                c, dc = bench_cpp(tool, weights, a, b, tmp, args.threads, args.repeat)
                r, dr = bench_torch(net, a, b, args.repeat)
                cpp, ref = max(cpp, c), max(ref, r)
            print(f"{size:>4}x{size:<4} {cpp:>16.1f} {ref:>12.1f} {cpp / ref:>6.2f} "
                  f"{np.abs(dc - dr).max():>10.2e}")
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except (subprocess.CalledProcessError, OSError, ValueError) as e:
        print(f"lpips_bench: {e}", file=sys.stderr)
        sys.exit(1)
