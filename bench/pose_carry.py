#!/usr/bin/python3
"""A carry on the pose kind's erased background (docs/motion.md, "A carry on the erased
background", session 45; not kept). The background holds the table, the goal disc and the block;
of these only the block moves, with the gripper. A small CNN marks what the gripper holds (from
the background and the drawn arm's alpha at this pose and the next) and an MLP of the two poses
gives the step's translation; the marked pixels move (--fill: the hole they leave is filled).
Trained on a frozen wm-motion pose run's encoder, renderer and eraser over windows of real
poses; scored on val rollouts of the run's own dynamics (block MSE per episode, strips of real,
run, carried rows and the mask). --oracle takes the mask from the block's segmentation label
(an upper bound: only the translation is learned).

  bench/pose_carry.py --run RUN --train TRAIN --val VAL --out PREFIX [--oracle] [--steps 1500]
      [--start 14 --horizon 10] [--eval-only]
"""
import argparse
import json
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
for sub in ("tests/motion", "tests/tokenize", "scripts"):
    sys.path.insert(0, os.path.join(HERE, "..", sub))
sys.path.insert(0, HERE)
import cv2  # noqa: E402
import numpy as np  # noqa: E402
import torch  # noqa: E402
from torch import nn  # noqa: E402
from torch.nn import functional as F  # noqa: E402

import dynamics_token_recipes as recipes  # noqa: E402
import motion_run  # noqa: E402
import warp_predictor as wp  # noqa: E402
from pose_twin import coordinates, erase  # noqa: E402
from tokenizer_goal1 import to_uint8  # noqa: E402


class Carry(nn.Module):
    def __init__(self, pose_dim, c=16):
        super().__init__()
        def conv(i, o, s=1):
            return nn.Sequential(nn.Conv2d(i, o, 3, s, 1), nn.ReLU())
        self.down = nn.Sequential(conv(7, c), conv(c, c, 2), conv(c, c, 2), conv(c, c, 2))
        self.mid = nn.Sequential(conv(c, c), conv(c, c))
        self.up = nn.Sequential(nn.Upsample(scale_factor=8, mode="bilinear"), conv(c + 7, c),
                                nn.Conv2d(c, 4, 3, 1, 1))
        nn.init.constant_(self.up[-1].bias[:1], -2.0)
        self.move = nn.Sequential(nn.Linear(2 * pose_dim, 128), nn.ReLU(), nn.Linear(128, 2))
        nn.init.zeros_(self.move[-1].weight); nn.init.zeros_(self.move[-1].bias)
        self.register_buffer("grid", coordinates(64), persistent=False)

    def forward(self, bg, a0, a1, p0, p1, oracle=None):
        x = torch.cat([bg, a0, a1, self.grid.expand(bg.shape[0], -1, -1, -1)], 1)
        out = self.up[-1](self.up[1](torch.cat([self.up[0](self.mid(self.down(x))), x], 1)))
        m, fill = torch.sigmoid(out[:, :1]), torch.tanh(out[:, 1:])
        if oracle is not None:
            m = oracle
        d = self.move(torch.cat([p0, p1 - p0], 1))  # [B, 2] in grid units
        base = self.grid.permute(0, 2, 3, 1).expand(bg.shape[0], -1, -1, -1)
        where = base - d[:, None, None, :]
        moved = F.grid_sample(torch.cat([m * bg, m], 1), where, align_corners=True,
                              padding_mode="zeros")
        mb, mm = moved[:, :3], moved[:, 3:]
        if not self.fill:  # what moves leaves its old pixels behind: no damage while d = 0
            return (1 - mm) * bg + mb, m, d
        return (1 - mm) * ((1 - m) * bg + m * fill) + mb, m, d


def train(net, carry, episodes, args):
    opt = torch.optim.AdamW(carry.parameters(), lr=1e-3, weight_decay=0.01)
    episodes = [e for e in episodes if len(e[0]) > args.window + 1]
    rng = np.random.default_rng(args.seed)
    W, B = args.window, args.batch
    t0 = time.time()
    for step in range(args.steps):
        for g in opt.param_groups:
            g["lr"] = wp.learning_rate(step, args.steps, 1e-3)
        clips, segs = [], []
        for _ in range(B):
            f, seg, _ = episodes[rng.integers(len(episodes))]
            s = int(rng.integers(len(f) - W))
            clips.append(f[s:s + W + 1])
            segs.append(torch.from_numpy(seg[s:s + W + 1] == 2).float()[:, None])
        x = torch.stack(clips)  # [B, W+1, 3, S, S]
        block = torch.stack(segs)  # [B, W+1, 1, S, S]
        with torch.no_grad():
            poses = net.encoder(x.flatten(0, 1)).view(B, W + 1, -1)
            rgb, alpha = net.renderer(poses.flatten(0, 1))
            rgb, alpha = rgb.view(B, W + 1, 3, 64, 64), alpha.view(B, W + 1, 1, 64, 64)
            bg = erase(net.eraser, x[:, 0])
        loss = 0
        for k in range(W):
            bg, m, d = carry(bg, alpha[:, k], alpha[:, k + 1], poses[:, k], poses[:, k + 1],
                             block[:, k] if args.oracle else None)
            pred = rgb[:, k + 1] * alpha[:, k + 1] + (1 - alpha[:, k + 1]) * bg
            loss = loss + (pred - x[:, k + 1]).abs().mean()
        loss = loss / W + args.mask_l1 * m.mean()
        opt.zero_grad(); loss.backward()
        torch.nn.utils.clip_grad_norm_(carry.parameters(), 1.0); opt.step()
        if step % 100 == 0:
            print(f"step {step} loss {loss.item():.4f} mask {m.mean().item():.4f} "
                  f"|d| {d.norm(dim=1).mean().item() * 32:.2f}px {time.time() - t0:.0f}s",
                  flush=True)


@torch.no_grad()
def carried_rollout(net, carry, first, actions, horizon, blocks=None):
    """PoseNet.imagine with the background carried at each step; the carry's masks."""
    bg = erase(net.eraser, first)
    p = net.encoder(first)
    _, a = net.renderer(p)
    frames, masks = [], []
    for t in range(horizon):
        p1 = net.dynamics.step(p, actions[:, t])
        rgb1, a1 = net.renderer(p1)
        bg, m, _ = carry(bg, a, a1, p, p1, None if blocks is None else blocks[t:t + 1])
        masks.append(m)
        frames.append(rgb1 * a1 + (1 - a1) * bg)
        p, a = p1, a1
    return torch.stack(frames, 1), masks


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--run", required=True); ap.add_argument("--train", required=True)
    ap.add_argument("--val", required=True); ap.add_argument("--out", required=True)
    ap.add_argument("--steps", type=int, default=1500)
    ap.add_argument("--batch", type=int, default=8)
    ap.add_argument("--window", type=int, default=8); ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--mask-l1", type=float, default=1e-4)
    ap.add_argument("--horizon", type=int, default=8)
    ap.add_argument("--start", type=int, default=0)
    ap.add_argument("--strip-episodes", type=int, nargs="*", default=[0, 1, 4])
    ap.add_argument("--eval-only", action="store_true")
    ap.add_argument("--fill", action="store_true")
    ap.add_argument("--oracle", action="store_true")
    args = ap.parse_args()
    torch.set_num_threads(1); torch.manual_seed(args.seed)
    net, norm = motion_run.load_run(args.run, "pose")
    for p in net.parameters():
        p.requires_grad_(False)
    train_eps, val_eps = recipes.load(args.train), recipes.load(args.val)
    carry = Carry(net.encoder.head[-1].out_features)
    carry.fill = args.fill
    if args.eval_only:
        carry.load_state_dict(torch.load(args.out + ".pt"))
    else:
        train(net, carry, train_eps, args)
        torch.save(carry.state_dict(), args.out + ".pt")
    evaluate(net, carry, val_eps, norm, args)


def evaluate(net, carry, val_eps, norm, args):
    H, S0 = args.horizon, args.start
    found = {"base": [], "carry": [], "copy_last": []}
    rows = []
    for k, (frames, seg, acts) in enumerate(val_eps):
        if len(frames) <= S0 + H:
            continue
        frames, seg, acts = frames[S0:], seg[S0:], acts[S0:]
        a = torch.tensor(norm(acts[:H]))[None]
        with torch.no_grad():
            base = net.imagine(frames[:1], a)
        blocks = (torch.from_numpy(seg[:H] == 2).float()[:, None] if args.oracle else None)
        car, masks = carried_rollout(net, carry, frames[:1], a, H, blocks)
        real, sc = wp.window_scores(frames, seg, {"base": to_uint8(base[0]),
                                                  "carry": to_uint8(car[0])})
        for n, sco in sc.items():
            found[n].append(sco)
        print(k, {n: round(sco["obj"], 1) for n, sco in sc.items()},
              "mask max %.2f" % max(float(m.max()) for m in masks), flush=True)
        if k in args.strip_episodes:
            mk = [np.repeat((m[0, 0].numpy() * 255)[..., None], 3, 2) for m in masks]
            rows += [np.concatenate(list(r), 1) for r in
                     (real, to_uint8(base[0]), to_uint8(car[0]), np.stack(mk))]
    r = wp.means(found)
    print(json.dumps(r))
    if rows:
        img = np.concatenate(rows, 0).clip(0, 255).astype(np.uint8)[..., ::-1]
        cv2.imwrite(args.out + f"_s{S0}.png", cv2.resize(img, None, fx=2, fy=2,
                                                       interpolation=cv2.INTER_NEAREST))


main()
