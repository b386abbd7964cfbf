#!/usr/bin/python3
"""Issue 20, goal 2: do two pose dynamics learned on one frozen autoencoder draw the arm
differently, beyond the episodes' spread? (Saved by bench/pose_autoencoder.py --load NET.pt
--save-dynamics A.pt.)

Over every episode of --val (say 300 generated with another data seed: the demo's 16 val
episodes cannot separate dynamics that differ by 0.03x), each dynamics' open-loop rollouts from
frame 0 and from frames 8, 16, 24 are drawn over the given frame's background (bench/pose_gap.py's
`open`) and scored as arm- and block-region MSE over copy_last's (ratios of sums) and PSNR (each
window's, averaged), over all 8 steps and at step 8, with the 95% paired-bootstrap interval of
B's minus A's (episodes resampled).

  bench/pose_dynamics_paired.py --train DIR --val DIR --autoencoder NET.pt --a A.pt --b B.pt \
      [--width 256] [--pose-dim 16] [--channels 16] [--renderer-width 64]

Session 49 (docs/motion.md, "A faster learning rate for the pose's dynamics"): a peak of 0.006
against 0.001 (256 wide, 3000 steps) on 300 episodes of data seed 7, from frame 0 over the 8
steps: arm -0.041 [-0.059, -0.023] and -0.034 [-0.052, -0.015] of copying's, PSNR +0.18 and
+0.34 dB, the block +0.053 [+0.015, +0.097] and the same, at the two autoencoders' seeds.
"""
import argparse

import numpy as np
import torch

import warp_predictor as wp
from pose_autoencoder import PoseAutoencoder
import pose_gap
from pose_twin import PoseDynamics

HORIZON, LAST_START = 8, 24


def arguments():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--train", required=True, help="the autoencoder's training shards (the "
                    "action normaliser is fitted on them)")
    ap.add_argument("--val", required=True, help="the episodes scored")
    ap.add_argument("--autoencoder", required=True, help="pose_autoencoder.py --save's NET.pt")
    ap.add_argument("--a", required=True, help="the first dynamics (--save-dynamics)")
    ap.add_argument("--b", required=True, help="the second")
    ap.add_argument("--width", type=int, default=256, help="both dynamics' correction width")
    ap.add_argument("--pose-dim", type=int, default=16)
    ap.add_argument("--channels", type=int, default=16)
    ap.add_argument("--renderer-width", type=int, default=64)
    ap.add_argument("--seed", type=int, default=0)
    return ap.parse_args()


REGIONS = {"arm": 1, "block": 2}


@torch.no_grad()
def window_errors(net, dynamics, episodes, norm):
    """-> {"first" | "later": {"arm" | "block" | "frame": [n windows, len(dynamics) + 1, H]}}:
    per window each dynamics' open-loop MSE per step in the arm's and the block's region (0
    where the real frame shows none) and over the frame, then copy_last's."""
    found = {"first": [], "later": []}
    for frames, seg, acts in episodes:
        poses = net.encoder(frames)
        for t in pose_gap.window_starts(len(frames), HORIZON, LAST_START):
            real = wp.goal1.to_uint8(frames[t + 1:t + HORIZON + 1])
            background = net.background(frames[t:t + 1])
            a = torch.tensor(norm(acts[t:t + HORIZON]))
            rollouts = [pose_gap.drawn(net, dyn(poses[t:t + 1], a[None])[0], background)
                        for dyn in dynamics]
            rollouts.append(pose_gap.copied(frames[t:], HORIZON))
            s = seg[t + 1:t + HORIZON + 1]
            errors = {name: np.nan_to_num([wp.goal1.region_mse(real, d, s, label)
                                           for d in rollouts])
                      for name, label in REGIONS.items()}
            errors["frame"] = np.stack([((real - d) ** 2).reshape(HORIZON, -1).mean(1)
                                        for d in rollouts])
            found["later" if t else "first"].append(errors)
    return {kind: {name: np.stack([w[name] for w in windows]) for name in windows[0]}
            for kind, windows in found.items() if windows}


def bootstrap(statistic, n, rng, draws=2000):
    """The 95% interval of statistic(indices) over episodes resampled with replacement."""
    return np.percentile([statistic(rng.integers(n, size=n)) for _ in range(draws)], [2.5, 97.5])


def report(kind, errors, rng):
    """Arm and block as ratios of sums over copy_last's, PSNR as the mean over windows of the
    PSNR of their mean frame MSE; B - A with its paired interval, over all steps and step 8."""
    for steps, name in ((slice(None), "all steps"), (slice(HORIZON - 1, None), "step 8")):
        parts = []
        for region in REGIONS:
            a, b, copy = errors[region][:, :, steps].sum(2).T
            lo, hi = bootstrap(lambda i: (b[i].sum() - a[i].sum()) / copy[i].sum(), len(a), rng)
            ra, rb = a.sum() / copy.sum(), b.sum() / copy.sum()
            parts.append(f"{region} / copy_last A {ra:.3f}, B {rb:.3f}, B - A {rb - ra:+.3f} "
                         f"[{lo:+.3f}, {hi:+.3f}]")
        # copy_last's is left out: still windows (the episode's task done) copy exactly
        psnr = 10 * np.log10(255.0 ** 2 / errors["frame"][:, :2, steps].mean(2))
        gain = psnr[:, 1] - psnr[:, 0]
        lo, hi = bootstrap(lambda i: gain[i].mean(), len(gain), rng)
        parts.append(f"PSNR A {psnr[:, 0].mean():.2f}, B {psnr[:, 1].mean():.2f}, "
                     f"B - A {gain.mean():+.2f} [{lo:+.2f}, {hi:+.2f}]")
        print(f"from {kind} ({len(gain)} windows), {name}:\n    " + "\n    ".join(parts))


def main():
    args = arguments()
    _, episodes, actions, norm = wp.setup(args)
    net = PoseAutoencoder(args.pose_dim, args.channels, args.renderer_width, "deconv")
    net.load_state_dict(torch.load(args.autoencoder))
    net.eval()
    dynamics = []
    for path in (args.a, args.b):
        dyn = PoseDynamics(args.pose_dim, actions.shape[1], args.width)
        dyn.load_state_dict(torch.load(path))
        dynamics.append(dyn)
    rng = np.random.default_rng(args.seed)
    starts = {"first": "frame 0", "later": "frames 8, 16, 24"}
    for kind, errors in window_errors(net, dynamics, episodes, norm).items():
        report(starts[kind], errors, rng)


if __name__ == "__main__":
    main()
