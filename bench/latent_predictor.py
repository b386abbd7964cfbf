#!/usr/bin/python3
"""Issue 20, goal 2: a change of model class for the motion model, tried in Python first
(docs/motion.md, "A latent-state predictor"). Every warp variant in bench/warp_predictor.py
imagines a frame by resampling the last imagined one, so the arm blurs a little more each step
and smears within 6-10 steps of a closed loop. Here the state lives in a latent: a conv encoder
maps the start frame to an 8x8 spatial latent, an action-conditioned residual conv steps it, and
each imagined frame is decoded afresh from the latent and the start frame (U-Net skips from the
start frame's encoding, a painted colour composited over the start frame by a gate), so no
frame is made by resampling another and nothing accumulates in pixel space. Trained on
`--unroll` latent steps per window (the loss on every decoded frame, plus the start frame's own
reconstruction), scored as bench/warp_predictor.py scores (its score() and summary()).

  bench/latent_predictor.py --train data/demo/shards/train --val data/demo/shards/val \\
      [--steps 1500] [--unroll 8] [--decoded 2] [--channels 32] [--latent 32] [--seed 0] \\
      [--strip OUT.png] [--long-strip OUT.png]

--long-strip writes val episodes 0-2 imagined for 24 steps under the logged actions (real
row above imagined row), to see whether the arm stays sharp past the 8-step horizon.
"""
import os
import sys
import time

import numpy as np
import torch
from torch import nn

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "tests", "motion"))
import tokenizer_goal1 as goal1  # noqa: E402
import warp_predictor as wp  # noqa: E402
from warp_twin import down, up, warp  # noqa: E402


class LatentPredictor(nn.Module):
    """frame_0 -> z_0 [L, 8, 8]; z_{t+1} = z_t + step(z_t, a_t); frame_t = decode(z_t, frame_0)."""

    def __init__(self, action_dim, channels, latent, warp, gate_bias=-3.0, flow_scale=4.0):
        super().__init__()
        c, self.gate_bias, self.flow_scale = channels, gate_bias, flow_scale
        # The start frame's encoder: its features at 32, 16 and 8 px are the decoder's skips.
        self.down1, self.down2, self.down3 = down(3, c), down(c, 2 * c), down(2 * c, 2 * c)
        self.to_latent = nn.Conv2d(2 * c, latent, 3, 1, 1)
        # The step: the action modulates the latent's features (FiLM), as the warp net's action
        # Jacobian multiplies it in: an additive action alone barely moved the arm there.
        self.step_in = nn.Conv2d(latent, 2 * c, 3, 1, 1)
        self.film = nn.Linear(action_dim, 4 * c)
        self.step_out = nn.Sequential(nn.ReLU(), nn.Conv2d(2 * c, 2 * c, 3, 1, 1), nn.ReLU(),
                                      nn.Conv2d(2 * c, latent, 3, 1, 1))
        nn.init.zeros_(self.step_out[-1].weight)  # starts as "nothing moves"
        nn.init.zeros_(self.step_out[-1].bias)
        self.from_latent = nn.Sequential(nn.Conv2d(latent + 2 * c, 2 * c, 3, 1, 1), nn.ReLU())
        self.up3, self.up2, self.up1 = up(2 * c, 2 * c), up(4 * c, c), up(2 * c, c)
        # Painted colour (3), gate (1) and, with `warp`, a flow (2) applied to the start frame.
        self.warp = warp
        self.head = nn.Conv2d(c + 3, 6 if warp else 4, 3, 1, 1)
        nn.init.zeros_(self.head.weight)
        nn.init.zeros_(self.head.bias)

    def encode(self, first):
        """-> (z_0, the start frame's skips)."""
        h1 = self.down1(first)
        h2 = self.down2(h1)
        h3 = self.down3(h2)
        return self.to_latent(h3), (first, h1, h2, h3)

    def step(self, z, action):
        scale, shift = self.film(action)[:, :, None, None].chunk(2, 1)
        return z + self.step_out(self.step_in(z) * (1 + scale) + shift)

    def decode(self, z, skips):
        first, h1, h2, h3 = skips
        u = self.up3(self.from_latent(torch.cat([z, h3], 1)))
        u = self.up1(torch.cat([self.up2(torch.cat([u, h2], 1)), h1], 1))
        out = self.head(torch.cat([u, first], 1))
        gate = torch.sigmoid(out[:, 3:4] + self.gate_bias)
        painted = torch.tanh(out[:, :3])
        source = warp(first, out[:, 4:6] * self.flow_scale) if self.warp else first
        return (1 - gate) * source + gate * painted, painted

    def forward(self, first, actions, decoded=None):
        """([B, len(decoded), 3, S, S] composited frames, the same of painted colours): the frames
        0..H (0: the start frame's reconstruction, h: imagined after actions[:, :h]) listed in
        `decoded`, all H + 1 when None."""
        z, skips = self.encode(first)
        decoded = range(actions.shape[1] + 1) if decoded is None else decoded
        frames = [self.decode(z, skips)] if 0 in decoded else []
        for h in range(actions.shape[1]):
            z = self.step(z, actions[:, h])
            if h + 1 in decoded:
                frames.append(self.decode(z, skips))
        return torch.stack([f for f, _ in frames], 1), torch.stack([p for _, p in frames], 1)


def windows(episodes, norm, rng, unroll):
    """[B, unroll + 1, 3, S, S] frames t..t+unroll and the normalised actions a_t..a_{t+unroll-1}
    of random windows (episodes shorter than the window are not drawn from)."""
    clips, actions = [], []
    while len(clips) < wp.BATCH:
        frames, _, acts = episodes[rng.integers(len(episodes))]
        if len(frames) <= unroll:
            continue
        t = int(rng.integers(len(frames) - unroll))
        clips.append(frames[t:t + unroll + 1])
        actions.append(norm(acts[t:t + unroll]))
    return torch.stack(clips), torch.tensor(np.stack(actions))


def fit(net, episodes, norm, args):
    opt = torch.optim.AdamW(net.parameters(), args.max_lr, betas=(0.9, 0.9), weight_decay=0.01)
    rng = np.random.default_rng(args.seed)
    for step in range(args.steps):
        for group in opt.param_groups:
            group["lr"] = wp.learning_rate(step, args.steps, args.max_lr)
        clips, actions = windows(episodes, norm, rng, args.unroll)
        # Decoding dominates the cost (the latent steps are at 8x8): the start frame and
        # `--decoded` of the imagined frames, drawn per batch (the last always among them).
        picked = rng.choice(args.unroll - 1, args.decoded - 1, replace=False) + 1
        decoded = sorted({0, args.unroll, *picked.tolist()})
        frames, painted = net(clips[:, 0], actions, decoded)
        loss = (frames - clips[:, decoded]).abs().mean()
        if args.painted_loss > 0:  # the painted colour learns the whole frame, gate open or not
            loss = loss + args.painted_loss * (painted - clips[:, decoded]).abs().mean()
        wp.optimizer_step(net, opt, loss, step)


@torch.no_grad()
def imagine(net, first, actions):
    return net(first, actions)[0][:, 1:].clamp(-1, 1)


def long_strip(net, episodes, norm, path, horizon=24):
    rows = []
    for k in range(3):
        frames, _, acts = episodes[k]
        h = min(horizon, len(frames) - 1)
        pred = imagine(net, frames[:1], torch.tensor(norm(acts[:h]))[None])[0]
        rows += [np.concatenate(list(goal1.to_uint8(x)), 1) for x in (frames[1:h + 1], pred)]
    width = max(r.shape[1] for r in rows)
    wp.write_strip(path, [np.pad(r, ((0, 0), (0, width - r.shape[1]), (0, 0))) for r in rows])


def main():
    ap = wp.arguments(__doc__, steps=1500, unroll=8, channels=32)
    ap.add_argument("--latent", type=int, default=32)
    ap.add_argument("--decoded", type=int, default=2,
                    help="imagined frames decoded (and scored) per training window")
    ap.add_argument("--warp", action="store_true",
                    help="the start frame warped by a flow decoded from the latent, not copied")
    ap.add_argument("--painted-loss", type=float, default=0, metavar="W",
                    help="W times the L1 of the painted colour alone against the frame")
    ap.add_argument("--long-strip", help="PNG: real and imagined rows over 24 steps, val 0-2")
    args = ap.parse_args()
    train, val, raw, norm = wp.setup(args)
    net = LatentPredictor(raw.shape[1], args.channels, args.latent, args.warp)
    start = time.time()
    fit(net, train, norm, args)
    seconds = time.time() - start
    net.eval()
    r, rows = wp.score(net, val, norm, lambda first, a, _: imagine(net, first, a))
    print(f"latent predictor ({args.channels} ch, latent {args.latent} x 8 x 8), {args.steps} "
          f"steps, unroll {args.unroll}, {seconds:.0f} s: {wp.summary(r)}")
    if args.strip:
        wp.write_strip(args.strip, rows)
    if args.long_strip:
        long_strip(net, val, norm, args.long_strip)


if __name__ == "__main__":
    main()
