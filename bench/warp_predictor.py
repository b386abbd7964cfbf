#!/usr/bin/python3
"""Issue 20, goal 2, a different model family (docs/dynamics.md, "Stable tokens, copy prior,
arrival"): an action-conditioned *pixel warp* predictor in the spirit of STP/CDNA (Finn et al.
2016), trained for minutes on one CPU thread on the demo's data, to see whether predicting where
pixels move (instead of which code a cell takes) makes the arm follow the actions.

  x_{t+1} = (1 - g) * warp(x_t, flow) + g * tanh(rgb),   [flow, rgb, g] = UNet(x_t, x_{t-1}, a_t)

The head starts at zero (flow 0, gate sigmoid(-3)): an untrained model copies the last frame.
Trained on single steps (L1), or with `--unroll U` on U-step imagined chains. Scored as
bench/dynamics_token_recipes.py scores token rollouts: 8 open-loop steps from frame 0 of val
episodes 0..7, PSNR / arm / object MSE against copy_last, and PSNR with the actions reversed.

  bench/warp_predictor.py --train data/demo/shards/train --val data/demo/shards/val \
      [--steps 600] [--unroll 1] [--strip OUT.png]
"""
import argparse
import os
import sys
import time

import cv2
import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import dynamics_token_recipes as recipes  # noqa: E402
import tokenizer_goal1 as goal1  # noqa: E402

BATCH, LR, WARMUP = 16, 1e-3, 50


class WarpNet(nn.Module):
    def __init__(self, c=48, action_dim=7):
        super().__init__()
        self.e1 = nn.Sequential(nn.Conv2d(6, c, 4, 2, 1), nn.ReLU())  # 32x32
        self.e2 = nn.Sequential(nn.Conv2d(c, c, 4, 2, 1), nn.ReLU())  # 16x16
        self.e3 = nn.Sequential(nn.Conv2d(c, c, 4, 2, 1), nn.ReLU())  # 8x8
        self.action = nn.Linear(action_dim, c)
        self.mid = nn.Sequential(nn.Conv2d(c, c, 3, 1, 1), nn.ReLU(), nn.Conv2d(c, c, 3, 1, 1),
                                 nn.ReLU())
        self.d3 = nn.Sequential(nn.ConvTranspose2d(c, c, 4, 2, 1), nn.ReLU())
        self.d2 = nn.Sequential(nn.ConvTranspose2d(2 * c, c, 4, 2, 1), nn.ReLU())
        self.d1 = nn.Sequential(nn.ConvTranspose2d(2 * c, c, 4, 2, 1), nn.ReLU())
        self.head = nn.Conv2d(c + 6, 6, 3, 1, 1)
        nn.init.zeros_(self.head.weight)  # starts as copy-last
        nn.init.zeros_(self.head.bias)

    def forward(self, x, previous, action):
        inp = torch.cat([x, previous], 1)
        h1 = self.e1(inp)
        h2 = self.e2(h1)
        h3 = self.mid(self.e3(h2) + self.action(action)[:, :, None, None])
        u = self.d1(torch.cat([self.d2(torch.cat([self.d3(h3), h2], 1)), h1], 1))
        out = self.head(torch.cat([u, inp], 1))
        flow, rgb, gate = out[:, :2] * 0.1, out[:, 2:5], torch.sigmoid(out[:, 5:6] - 3)
        _, _, h, w = x.shape
        ys, xs = torch.meshgrid(torch.linspace(-1, 1, h), torch.linspace(-1, 1, w), indexing="ij")
        grid = torch.stack([xs, ys], -1)[None] + flow.permute(0, 2, 3, 1)
        warped = F.grid_sample(x, grid, align_corners=True, padding_mode="border")
        return (1 - gate) * warped + gate * torch.tanh(rgb)


def learning_rate(step, steps):
    return LR * min(1, (step + 1) / WARMUP) * (0.1 + 0.45 * (1 + np.cos(np.pi * step / steps)))


def batch(episodes, norm, rng, unroll):
    """[B, unroll + 2, 3, S, S] clips (frame t-1, t, t+1..t+unroll; t-1 = t at t = 0) and the
    normalised actions a_t..a_{t+unroll-1}."""
    clips, actions = [], []
    for _ in range(BATCH):
        k = rng.integers(len(episodes))
        frames, _, acts = episodes[k]
        t = int(rng.integers(len(frames) - unroll))
        clips.append(torch.cat([frames[max(t - 1, 0):max(t - 1, 0) + 1], frames[t:t + unroll + 1]]))
        actions.append(norm(acts[t:t + unroll]))
    return torch.stack(clips), torch.tensor(np.stack(actions))


def fit(net, episodes, norm, steps, unroll, seed=0):
    opt = torch.optim.AdamW(net.parameters(), LR, betas=(0.9, 0.9))
    rng = np.random.default_rng(seed)
    for step in range(steps):
        for group in opt.param_groups:
            group["lr"] = learning_rate(step, steps)
        clips, actions = batch(episodes, norm, rng, unroll)
        previous, current, loss = clips[:, 0], clips[:, 1], 0
        for u in range(unroll):
            predicted = net(current, previous, actions[:, u])
            loss = loss + (predicted - clips[:, u + 2]).abs().mean() / unroll
            previous, current = current, predicted
        opt.zero_grad()
        loss.backward()
        nn.utils.clip_grad_norm_(net.parameters(), 1.0)
        opt.step()


@torch.no_grad()
def score(net, episodes, norm):
    def psnr(a, b):
        return 10 * np.log10(255.0 ** 2 / max(1e-10, float(np.mean((a - b) ** 2))))
    H = recipes.HORIZON
    found = {k: {"psnr": [], "arm": [], "obj": []} for k in ("model", "reversed", "copy_last")}
    rows = []
    for k in range(recipes.ROLLOUTS):
        frames, seg, acts = episodes[k]
        normed = torch.tensor(norm(acts[:H]))
        preds = {}
        for name, a in (("model", normed), ("reversed", torch.flip(normed, [0]))):
            current, previous, out = frames[:1], frames[:1], []
            for h in range(H):
                predicted = net(current, previous, a[h:h + 1]).clamp(-1, 1)
                out.append(predicted)
                previous, current = current, predicted
            preds[name] = goal1.to_uint8(torch.cat(out))
        real = goal1.to_uint8(frames[1:H + 1])
        preds["copy_last"] = np.repeat(goal1.to_uint8(frames[:1]), H, 0)
        for name, p in preds.items():
            found[name]["psnr"].append(np.mean([psnr(a, b) for a, b in zip(real, p)]))
            for key, label in (("arm", 1), ("obj", 2)):
                found[name][key].append(np.nanmean(goal1.region_mse(real, p, seg[1:H + 1], label)))
        if k < 3:
            rows += [np.concatenate(list(r), 1) for r in (real, preds["model"], preds["reversed"])]
    return {n: {k: float(np.nanmean(v)) for k, v in d.items()} for n, d in found.items()}, rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--train", required=True)
    ap.add_argument("--val", required=True)
    ap.add_argument("--steps", type=int, default=600)
    ap.add_argument("--unroll", type=int, default=1)
    ap.add_argument("--strip", help="PNG: real, predicted, reversed-actions rows, val episodes 0-2")
    args = ap.parse_args()
    torch.set_num_threads(1)
    torch.manual_seed(0)
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scripts"))
    train, val = recipes.load(args.train), recipes.load(args.val)
    actions = np.concatenate([a for _, _, a in train])
    mean, std = actions.mean(0), actions.std(0) + 1e-6

    def norm(a):
        return ((a - mean) / std).astype(np.float32)
    net = WarpNet(action_dim=actions.shape[1])
    start = time.time()
    fit(net, train, norm, args.steps, args.unroll)
    seconds = time.time() - start
    r, rows = score(net.eval(), val, norm)
    m, c = r["model"], r["copy_last"]
    print(f"warp predictor, {args.steps} steps, unroll {args.unroll}, {seconds:.0f} s: "
          f"rollout PSNR {m['psnr']:.2f} (copy_last {c['psnr']:.2f}), PSNR - reversed actions' "
          f"{m['psnr'] - r['reversed']['psnr']:+.2f}, arm / copy_last {m['arm'] / c['arm']:.2f}, "
          f"object / copy_last {m['obj'] / c['obj']:.2f}")
    if args.strip:
        img = np.concatenate(rows, 0).clip(0, 255).astype(np.uint8)[..., ::-1]
        cv2.imwrite(args.strip, cv2.resize(img, None, fx=2, fy=2,
                                           interpolation=cv2.INTER_NEAREST))


if __name__ == "__main__":
    main()
