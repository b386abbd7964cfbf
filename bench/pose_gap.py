#!/usr/bin/python3
"""Issue 20, goal 2: where does the pose kind's rollout lose the arm that its own poses draw?
(`bench/pose_autoencoder.py --gap`, after its dynamics is learned.)

The arm drawn from the poses the encoder reads off the real frames errs about half as much as
the one drawn from the dynamics' open-loop poses (docs/motion.md, "Longer refits"). Per step of
the horizon, over windows from frames 0, 8, 16 and 24 of every val episode (episode starts
apart, with the arm in the first frame or above it: the hard cases, session 34), this
compares the arm drawn over the given frame's background from
  own:  the encoder's poses of the real frames (the ceiling),
  one:  the dynamics' one-step poses, each from the encoder's pose of the real frame before,
  open: the dynamics' open-loop poses from the first frame (the rollout),
as arm-region MSE over copy_last's (ratio of sums), and the pose error of `one` and `open`
(squared, over each number's spread). If `one` is near `own`, the loss is in compounding; if
it is near `open`, a single step is already unpredictable from the pose and the action.
"""
import numpy as np
import torch

import warp_predictor as wp
from pose_twin import over

DRAWN = ("own", "one", "open")
# frame 0 with the arm in view or not (only its shadow: where the arm is then is a guess)
STARTS = {"shown": "frame 0, the arm in it", "hidden": "frame 0, the arm above it",
          "later": "frames 8, 16, 24"}


def window_starts(length, horizon=8, last_start=24):
    """The frames 0, 8, ..., `last_start` that a window of `horizon` steps fits after, in an
    episode of `length` frames."""
    return range(0, min(length - horizon, last_start + 1), 8)


def drawn(net, poses, background):
    """The arm drawn at each of `poses` over `background`, as [0, 255] levels."""
    return wp.goal1.to_uint8(over(*net.renderer(poses), background))


def copied(frames, n):
    """copy_last's n frames: the first of `frames` repeated, as [0, 255] levels."""
    return np.repeat(wp.goal1.to_uint8(frames[:1]), n, 0)


def window(net, dyn, frames, poses, seg, acts):
    """One window of len(acts) steps (`poses`: the encoder's of `frames`) -> ({drawn: per-step
    arm MSE}, copy_last's, {one, open: per-step squared pose error [H, P]})."""
    predicted = {"own": poses[1:], "open": dyn(poses[:1], acts[None])[0],
                 "one": dyn.step(poses[:-1], acts)}
    background = net.background(frames[:1])
    real = wp.goal1.to_uint8(frames[1:])
    arm = {name: np.array(wp.goal1.region_mse(real, drawn(net, p, background), seg[1:], 1))
           for name, p in predicted.items()}
    copy = np.array(wp.goal1.region_mse(real, copied(frames, len(real)), seg[1:], 1))
    pose_error = {name: (predicted[name] - poses[1:]).pow(2).numpy() for name in ("one", "open")}
    return arm, copy, pose_error


@torch.no_grad()
def gap_by_step(net, dyn, episodes, norm, horizon=8, last_start=24):
    """-> {start kind: {"arm": {drawn: [H] ratio}, "pose": {one/open: [H]}, "windows": n}}."""
    poses = [net.encoder(f) for f, _, _ in episodes]
    spread = torch.cat(poses).var(0).numpy() + 1e-6
    found = {k: {"arm": {d: np.zeros(horizon) for d in DRAWN}, "copy": np.zeros(horizon),
                 "pose": {d: np.zeros(horizon) for d in ("one", "open")}, "windows": 0}
             for k in STARTS}
    for (frames, seg, acts), episode_poses in zip(episodes, poses):
        for t in window_starts(len(frames), horizon, last_start):
            a = torch.tensor(norm(acts[t:t + horizon]))
            span = slice(t, t + horizon + 1)
            arm, copy, pose_error = window(net, dyn, frames[span], episode_poses[span],
                                           seg[span], a)
            into = found["later" if t else "shown" if (seg[0] == 1).any() else "hidden"]
            shown = ~np.isnan(copy)  # steps whose real frame shows the arm
            for name in DRAWN:
                into["arm"][name] += np.where(shown, arm[name], 0)
            into["copy"] += np.where(shown, copy, 0)
            for name, e in pose_error.items():
                into["pose"][name] += (e / spread).mean(1)
            into["windows"] += 1
    found = {kind: into for kind, into in found.items() if into["windows"]}
    for into in found.values():
        into["arm"] = {d: s / into["copy"] for d, s in into["arm"].items()}
        into["pose"] = {d: s / into["windows"] for d, s in into["pose"].items()}
    return found


def print_gap(found):
    for kind, into in found.items():
        print(f"  gap, windows from {STARTS[kind]} ({into['windows']}), "
              f"steps 1-{len(into['copy'])}:")
        for name in DRAWN:
            print(f"    arm / copy_last, {name:4s}: " +
                  " ".join(f"{v:.2f}" for v in into["arm"][name]))
        for name, v in into["pose"].items():
            print(f"    pose error, {name:4s}: " + " ".join(f"{x:.3f}" for x in v))
