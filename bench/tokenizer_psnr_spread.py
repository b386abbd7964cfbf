#!/usr/bin/python3
"""Why a tokenizer's `val.csv` PSNR can fall while its reconstructions get better.

`val.csv`'s PSNR (tokenize/validation.cc) is the mean over frames of each frame's PSNR, anchored
as FixedGapAnchors does (the frame train.anchor_max_gap back, 8 in the presets; frame 0 for
the first ones; none for frame 0). A decoder
that copies its anchor exactly where nothing moved scores 45-50 dB on those frames, and a few of
them lift the mean by several dB; the median and the pooled PSNR (from the mean MSE) do not
care. This scores C++ tokenizer runs (loaded into the twin, tests/tokenize/vqvae_twin.py) on
every frame of a shard dataset that way and prints the spread:

  bench/tokenizer_psnr_spread.py --val data/demo/shards/val --checkpoints RUN_A/tokenizer RUN_B/...
"""
import argparse
import os
import sys

import numpy as np
import torch

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import tokenizer_goal1 as goal1  # noqa: E402
from tokenizer_goal1 import twin  # noqa: E402

def frame_mse(model, frames, gap):
    """Per-frame MSE on [0, 255] levels of `frames` [T, 3, S, S] decoded from their own codes
    with val.csv's anchors, `gap` frames back."""
    anchors = frames[[max(t - gap, 0) for t in range(len(frames))]].clone()
    anchors[0] = 0  # frame 0 has no earlier frame: a blank anchor, as in training
    codes = twin.encode(model, frames, anchors)
    recon = goal1.to_uint8(twin.decode(model, codes, anchors)).astype(np.float64)
    real = goal1.to_uint8(frames).astype(np.float64)
    return ((recon - real) ** 2).reshape(len(frames), -1).mean(1)


def psnr(mse):
    return 10 * np.log10(255.0 ** 2 / mse)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--val", required=True, help="shard dataset (index.json)")
    ap.add_argument("--checkpoints", nargs="+", required=True, help="wm-tokenize train run dirs")
    args = ap.parse_args()
    torch.set_num_threads(1)
    val = goal1.load(args.val, False)
    print("run | frames | mean of per-frame PSNR | median | pooled | frames over 40 dB")
    for run in args.checkpoints:
        model, config, _ = twin.load_checkpoint(run)
        gap = config["train"]["anchor_max_gap"]  # the run's own, as its val.csv used
        mse = np.concatenate([frame_mse(model.eval(), frames, gap) for frames, _ in val])
        exact = mse == 0  # val.csv skips infinite PSNRs
        per_frame = psnr(np.where(exact, 1.0, mse))
        print(f"{run} | {len(mse)} | {per_frame[~exact].mean():.2f} | {np.median(per_frame):.2f} | "
              f"{psnr(mse.mean()):.2f} | {np.mean(per_frame > 40):.3f}")


if __name__ == "__main__":
    main()
