#!/usr/bin/python3
"""Issue 20, goal 2: how far can a warp go? The motion model makes each frame by warping the last
one (docs/motion.md); here the flow is not predicted but measured on the real frames (OpenCV's
DIS optical flow, no training), so what is left is the model class's own error: disocclusions a
warp cannot fill, and resampling. Scored as bench/warp_predictor.py scores (val episodes 0..7,
8 steps from frame 0; arm / object MSE over copy_last's):

  recursive  each imagined frame = the last imagined frame warped by the real flow t -> t+1
             (what the motion model does, with a perfect flow)
  from_first each imagined frame = the real frame 0 warped once by the real flow 0 -> t+1
             (no accumulated resampling)

  bench/warp_oracle.py --val data/demo/shards/val [--upscale 4] [--strip OUT.png] [--spread U ..]

--upscale computes the flow on frames enlarged by that factor (DIS is coarse at 64 px).
--spread also prints how far DIS's flow at each other enlargement U lies from it on the next
frame's arm pixels (the reference's own uncertainty, for reading warp_predictor.py
--flow-report's errors against it).
"""
import argparse
import os
import sys

import cv2
import numpy as np
import torch

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "tests", "motion"))
import dynamics_token_recipes as recipes  # noqa: E402
import tokenizer_goal1 as goal1  # noqa: E402
import warp_predictor as wp  # noqa: E402
from warp_twin import warp  # noqa: E402


def rollouts(frames, horizon, upscale):
    """{name: [H, 3, S, S] in [-1, 1]} of the two oracle rollouts from frame 0."""
    real = goal1.to_uint8(frames[:horizon + 1])
    recursive, current = [], frames[:1]
    from_first = []
    for t, step in enumerate(wp.step_flows(frames[:horizon + 1], upscale)):
        current = warp(current, step[None]).clamp(-1, 1)
        recursive.append(current[0])
        whole = wp.backward_flow(real[t + 1], real[0], upscale)[None]
        from_first.append(warp(frames[:1], whole).clamp(-1, 1)[0])
    return {"recursive": torch.stack(recursive), "from_first": torch.stack(from_first)}


def spread(episodes, upscale, others):
    """Mean end-point error (px) on the next frame's arm pixels between DIS's per-step flow at
    `upscale` and at each of `others`, over the episodes' first HORIZON steps."""
    H, err = recipes.HORIZON, {u: [] for u in others}
    for frames, seg, _ in episodes:
        ref = wp.step_flows(frames[:H + 1], upscale)
        arm = torch.from_numpy(seg[1:H + 1] == 1)
        for u in others:
            distance = (wp.step_flows(frames[:H + 1], u) - ref).norm(dim=1)
            err[u] += [float(d[a].mean()) for d, a in zip(distance, arm) if a.any()]
    return ", ".join(f"DIS at {u}x {np.mean(v):.2f} px" for u, v in err.items())


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--val", required=True)
    ap.add_argument("--upscale", type=int, default=4)
    ap.add_argument("--strip", help="PNG: real, recursive, from_first rows, val episodes 0-2")
    ap.add_argument("--spread", type=int, nargs="+", metavar="U",
                    help="DIS's flow at these enlargements against --upscale's, on arm pixels")
    args = ap.parse_args()
    cv2.setNumThreads(1)
    H = recipes.HORIZON
    found, rows = {}, []
    episodes = recipes.load(args.val)[:recipes.ROLLOUTS]
    for k, (frames, seg, _) in enumerate(episodes):
        preds = {n: goal1.to_uint8(x) for n, x in rollouts(frames, H, args.upscale).items()}
        real, scored = wp.window_scores(frames, seg, preds)
        for name, s in scored.items():
            found.setdefault(name, []).append(s)
        if k < 3:
            rows += [np.concatenate(list(r), 1)
                     for r in (real, preds["recursive"], preds["from_first"])]
    mean = wp.means(found)
    for name in ("recursive", "from_first"):
        print(f"{name}: {wp.summary(mean, name)}")
    if args.strip:
        wp.write_strip(args.strip, rows)
    if args.spread:
        print(f"DIS's flow against DIS at {args.upscale}x on arm pixels:",
              spread(episodes, args.upscale, args.spread))


if __name__ == "__main__":
    main()
