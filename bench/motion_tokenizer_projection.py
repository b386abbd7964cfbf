#!/usr/bin/python3
"""Issue 20: does projecting the motion model's imagined frames through the tokenizer (encode,
quantise, decode with the real frame 0 as anchor) pull them back to sharp, plausible frames?
Test time only: loads the demo's trained motion model (`wm-motion`, via its PyTorch twin) and
tokenizer (`wm-tokenize`, via its twin) and scores 8-step open-loop rollouts from frame 0 of val
episodes 0..7 as bench/warp_predictor.py does, for four ways of using the projection:

  plain         the motion model alone (equals the demo's `wm-eval` row)
  project       each imagined frame shown projected; the model keeps rolling out its own frames
  project_feed  the projected frame is also the next step's input
  blend_feed    the mean of the imagined and the projected frame, shown and fed back

  bench/motion_tokenizer_projection.py [--demo data/demo] [--strips DIR]

Measured 2026-11-26 in docs/motion.md ("WHALE's retracing for the pixel model, projecting
through the tokenizer, an adversarial loss").
"""
import argparse
import os
import sys

import cv2
import numpy as np
import torch

HERE = os.path.dirname(os.path.abspath(__file__))
for sub in ("", "../tests/motion", "../tests/tokenize", "../tests/train"):
    sys.path.insert(0, os.path.join(HERE, sub))
import dynamics_token_recipes as recipes  # noqa: E402
import tokenizer_goal1 as goal1  # noqa: E402
import vqvae_twin  # noqa: E402
import warp_predictor  # noqa: E402
from motion_run import load_run  # noqa: E402

MODES = ("plain", "project", "project_feed", "blend_feed")
HORIZON, ROLLOUTS = 8, 8


@torch.no_grad()
def rollout(net, tokenizer, first, actions, mode):
    def project(frame):
        return vqvae_twin.decode(tokenizer, vqvae_twin.encode(tokenizer, frame), first)
    current = previous = first
    shown_frames = []
    for h in range(actions.shape[1]):
        imagined = net(current, previous, actions[:, h])[0].clamp(-1, 1)
        shown = imagined if mode == "plain" else project(imagined)
        if mode == "blend_feed":
            shown = 0.5 * (imagined + shown)
        shown_frames.append(shown)
        previous, current = current, (shown if mode.endswith("_feed") else imagined)
    return torch.stack(shown_frames, 1)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--demo", default="data/demo")
    ap.add_argument("--strips", help="directory for one PNG per mode (real / imagined rows)")
    args = ap.parse_args()
    torch.set_num_threads(1)
    net, norm = load_run(os.path.join(args.demo, "run", "motion"), "warp")
    tokenizer = vqvae_twin.load_checkpoint(os.path.join(args.demo, "run", "tokenizer"))[0]
    val = recipes.load(os.path.join(args.demo, "shards", "val"))
    for mode in MODES:
        found = {k: [] for k in ("model", "reversed", "copy_last")}
        rows = []
        for frames, seg, acts in val[:ROLLOUTS]:
            a = torch.tensor(norm(acts[:HORIZON]))[None]
            real = goal1.to_uint8(frames[1:HORIZON + 1])
            preds = {"model": goal1.to_uint8(rollout(net, tokenizer, frames[:1], a, mode)[0]),
                     "reversed": goal1.to_uint8(
                         rollout(net, tokenizer, frames[:1], torch.flip(a, [1]), mode)[0]),
                     "copy_last": np.repeat(goal1.to_uint8(frames[:1]), HORIZON, 0)}
            for name, pred in preds.items():
                found[name].append(warp_predictor.scores(real, pred, seg[1:HORIZON + 1]))
            if len(rows) < 6:
                rows += [np.concatenate(list(r), 1) for r in (real, preds["model"])]
        mean = {n: {m: float(np.nanmean([s[m] for s in v])) for m in v[0]}
                for n, v in found.items()}
        m, c = mean["model"], mean["copy_last"]
        print(f"{mode:12s} PSNR {m['psnr']:.2f} (copy_last {c['psnr']:.2f}), SSIM {m['ssim']:.3f}, "
              f"- reversed {m['psnr'] - mean['reversed']['psnr']:+.2f}, arm {m['arm'] / c['arm']:.2f}"
              f" (step 8: {m['arm8'] / c['arm8']:.2f}), object {m['obj'] / c['obj']:.2f}")
        if args.strips:
            img = np.concatenate(rows, 0).clip(0, 255).astype(np.uint8)[..., ::-1]
            cv2.imwrite(os.path.join(args.strips, f"projection_{mode}.png"),
                        cv2.resize(img, None, fx=2, fy=2, interpolation=cv2.INTER_NEAREST))


if __name__ == "__main__":
    main()
