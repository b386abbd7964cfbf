#!/usr/bin/python3
"""Issue 20, goal 2: is the pose kind's step-8 arm limited by its dynamics or by their data? A
`wm-motion` pose-kind checkpoint's autoencoder is kept frozen (loaded through
tests/motion/pose_twin.py) and its PoseDynamics learned again on the poses that encoder reads off
the episodes of --train (which need not be the data the autoencoder saw), as the C++ trainer
learns them (256 open-loop rollouts of --horizon steps a step, the squared error of each pose
number over its spread), with optional changes; then scored on --val as every table of
docs/motion.md (val episodes 0-7 from frame 0), and wider: all val episodes from frame 0, and
from frames 0, 8, 16 and 24 (the step-8 arm as a ratio of sums over copy_last's).

  bench/pose_dynamics_refit.py --checkpoint RUN_DIR --train DIR --val DIR [--steps 3000] \
      [--hidden H] [--weight-decay 0.01] [--early F] [--noise S] [--keep] [--seed S] \
      [--ensemble K] [--threads N]

Measured in session 34 (docs/motion.md, "More training episodes for the pose's dynamics"): a
wider correction MLP, more steps, episode starts drawn more often and noise on the first pose
move the step-8 arm within a run's spread; 1000 training episodes instead of the demo's 200
lower it on both autoencoders tried.
"""
import argparse

import numpy as np
import torch
from torch import nn

import warp_predictor as wp
from motion_run import load_run
from pose_autoencoder import episode_poses, pick_windows
from pose_gap import window_starts
from pose_twin import PoseDynamics


class NoCorrection(nn.Module):
    """--hidden 0: p_t+1 = p_t + A a_t, the pose moved linearly."""

    def __init__(self, pose_dim):
        super().__init__()
        self.pose_dim = pose_dim

    def forward(self, x):
        return x.new_zeros(x.shape[0], self.pose_dim)


class AveragedDynamics(nn.Module):
    """--ensemble K: the mean of K dynamics' pose paths, each learned from its own seed."""

    def __init__(self, members):
        super().__init__()
        self.members = nn.ModuleList(members)

    def forward(self, pose, actions):
        return torch.stack([m(pose, actions) for m in self.members]).mean(0)


def new_dynamics(net, hidden, seed):
    """A PoseDynamics as the twin initialises it from `seed`, its correction `hidden` wide (0:
    none, the pose moved linearly)."""
    torch.manual_seed(seed)
    pose_dim = net.dynamics.action_map.out_features
    dynamics = PoseDynamics(pose_dim, net.dynamics.action_map.in_features, max(hidden, 1))
    if hidden == 0:
        dynamics.correction = NoCorrection(pose_dim)
    return dynamics


def fit(dynamics, poses, episodes, norm, args, seed):
    """The C++ trainer's dynamics phase (PoseDynamicsTraining), plus --early and --noise."""
    h = args.horizon
    scale = torch.cat(poses).std(0) + 1e-3
    starts = [(e, t) for e, p in enumerate(poses) for t in range(len(p) - h)]
    opt = torch.optim.AdamW(dynamics.parameters(), args.lr,
                            weight_decay=args.weight_decay)
    rng = np.random.default_rng(seed)
    torch.manual_seed(seed)  # the --noise draws
    for step in range(args.steps):
        for group in opt.param_groups:
            group["lr"] = wp.learning_rate(step, args.steps, args.lr)
        picks = pick_windows(starts, rng, args.early)
        first = torch.stack([poses[e][t] for e, t in picks])
        first = first + args.noise * scale * torch.randn_like(first)
        target = torch.stack([poses[e][t + 1:t + h + 1] for e, t in picks])
        acts = torch.stack([torch.from_numpy(norm(episodes[e][2][t:t + h])) for e, t in picks])
        loss = ((dynamics(first, acts) - target) / scale).pow(2).mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
        if step % 500 == 0:
            print(f"  step {step} loss {loss.item():.4f}", flush=True)


@torch.no_grad()
def step8_arm(imagine, episodes, norm, horizon=8, last_start=24):
    """The step-8 arm over copy_last's (ratio of sums) of the rollouts from frame 0 of every
    episode, and from frames 0, 8, ..., `last_start` where the episode is long enough (windows
    whose step 8 shows no arm are left out)."""
    rows = []
    for frames, seg, acts in episodes:
        for t in window_starts(len(frames), horizon, last_start):
            pred = imagine(frames[t:t + 1], torch.tensor(norm(acts[t:t + horizon]))[None])
            real = {"model": wp.goal1.to_uint8(pred[0])}
            _, s = wp.window_scores(frames[t:], seg[t:], real)
            rows.append((t, s["model"]["arm8"], s["copy_last"]["arm8"]))
    r = np.array(rows)
    kept = ~np.isnan(r[:, 1:]).any(1)
    first = kept & (r[:, 0] == 0)
    return r[first, 1].sum() / r[first, 2].sum(), r[kept, 1].sum() / r[kept, 2].sum()


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--checkpoint", required=True, help="a wm-motion pose-kind run directory")
    ap.add_argument("--train", required=True)
    ap.add_argument("--val", required=True)
    ap.add_argument("--steps", type=int, default=3000)
    ap.add_argument("--horizon", type=int, default=8)
    ap.add_argument("--lr", type=float, default=1e-3)
    ap.add_argument("--hidden", type=int, default=None,
                    help="the correction MLP's width (default: the run's; 0: none, the pose "
                    "moved linearly)")
    ap.add_argument("--weight-decay", type=float, default=0.01)
    ap.add_argument("--early", type=float, default=0.0, metavar="F",
                    help="that fraction of the rollouts starts at an episode's frame 0 or 1 "
                    "(where every scored rollout starts, with the largest actions)")
    ap.add_argument("--noise", type=float, default=0.0, metavar="S",
                    help="Gaussian noise of S x each pose number's spread on the first pose")
    ap.add_argument("--keep", action="store_true", help="score the run's own dynamics")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--ensemble", type=int, default=1, metavar="K",
                    help="learn K dynamics (seeds --seed, --seed + 1, ...) and roll out the mean "
                    "of their pose paths")
    ap.add_argument("--threads", type=int, default=1)
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    torch.set_flush_denormal(True)
    net, norm = load_run(args.checkpoint, "pose")
    net.requires_grad_(False)
    train, val = wp.recipes.load(args.train), wp.recipes.load(args.val)
    if not args.keep:
        poses, members = episode_poses(net, train), []
        hidden = net.dynamics.correction[0].out_features if args.hidden is None else args.hidden
        for seed in range(args.seed, args.seed + args.ensemble):
            members.append(new_dynamics(net, hidden, seed).requires_grad_(True))
            with torch.enable_grad():
                fit(members[-1], poses, train, norm, args, seed)
        net.dynamics = members[0] if args.ensemble == 1 else AveragedDynamics(members)
    net.eval()

    def imagine(first, acts, _=None):
        return net.imagine(first, acts).clamp(-1, 1)
    with torch.no_grad():
        r, _ = wp.score(net, val, norm, imagine)
    every_first, every_start = step8_arm(imagine, val, norm)
    learned = "the run's own" if args.keep else f"learned again on {len(train)} episodes" + (
        f", the mean of {args.ensemble}" if args.ensemble > 1 else "")
    print(f"pose dynamics ({learned}): {wp.summary(r)}\n  step-8 arm over all {len(val)} val "
          f"episodes from frame 0: {every_first:.3f}; from frames 0, 8, 16, 24: {every_start:.3f}")


if __name__ == "__main__":
    main()
