#!/usr/bin/python3
"""Issue 20, goal 2: the layered motion model (wm-motion's model.kind layers; docs/motion.md,
"The layered kind") in Python, for experiments before they reach wm-motion. Trains the PyTorch
twin of motion/layer_net.cc (tests/motion/layer_twin.py) on one CPU thread with the recipe of
configs/motion/tiny.yaml and scores it as bench/warp_predictor.py scores the warp kind (8-step
open-loop rollouts from frame 0 of val episodes 0..7: PSNR, SSIM, PSNR minus the reversed
actions', arm / object MSE over copy_last's).

  bench/layer_predictor.py --train data/demo/shards/train --val data/demo/shards/val \
      [--steps 1500] [--unroll 4] [--layers 3] [--channels 32] [--seed S] [--strip OUT.png] \
      [--mask-noise 2] [--noise-ramp 0.5] [--mask-l1 0.01] [--mask-bias 0] \
      [--save NET.pt | --load NET.pt | --checkpoint RUN_DIR] [--masks OUT.png] [--ceiling]

--mask-noise SIGMA (Gaussian noise on the mask logits in training, grown from 0 over the first
--noise-ramp of the steps) and --mask-l1 W (W x the layers' mean mask in the loss) are the
recipe's (docs/motion.md says what each does; 0 turns it off). --checkpoint scores a wm-motion
run of this kind through the twin instead of training (its weights and action statistics).
--masks writes, for val episodes 0-2, the given frame, each layer's mask, the fill and the
layers' cut-out. --ceiling (a diagnostic) also scores each rollout with its per-step maps fitted
to the real frames by Adam (the masks and fill kept): the representation's error without the
motion predictor's.
"""
import os
import time

import numpy as np
import torch
from torch import nn

import warp_predictor as wp
from dynamics_twin import read_archive
from layer_twin import AFFINE, LayerNet, apply, centroids
from warp_twin import down


class VariantLayerNet(LayerNet):
    """Experiments on the motion predictor: a wider motion CNN (`motion_channels`), the layers'
    current centroids as MLP inputs (`where`), and a linear part restricted to a similarity
    (scale and rotation) or a scale (`linear`)."""

    def __init__(self, action_dim, layers, channels, motion_channels, where, linear="affine",
                 **kw):
        super().__init__(action_dim, layers, channels, **kw)
        c, k = motion_channels, layers
        self.where, self.linear = where, linear
        self.motion_cnn = nn.Sequential(*[m for i in range(4) for m in down(6 if i == 0 else c, c)])
        extra = 2 * k if where else 0
        self.motion_mlp = nn.Sequential(nn.Linear(16 * c + k * AFFINE + extra, 256), nn.ReLU())

    def step_maps(self, current, first, maps, action):
        b, k, d = current.shape[0], self.layers, self.action_dim
        inputs = [self.motion_cnn(torch.cat([current, first], 1)).flatten(1),
                  (maps[:, :, :2, :] - torch.eye(3)[:2]).flatten(1) * 0.05]
        if self.where:
            s = current.shape[-1]
            inputs.append((apply(maps, centroids(self.last_masks)) / (s - 1) * 2 - 1).flatten(1))
        out = self.motion_head(self.motion_mlp(torch.cat(inputs, 1))).view(b, k, AFFINE, d + 1)
        inc = out[..., 0] + (out[..., 1:] * action.view(b, 1, 1, d)).sum(-1)
        lin = 0.2 * torch.tanh(inc[..., :4])
        if self.linear != "affine":  # [[s, -r], [r, s]]: no shear; "scale": no rotation either
            scale, turn = lin[..., 0], lin[..., 1] * (self.linear == "similarity")
            lin = torch.stack([scale, -turn, turn, scale], -1)
        return torch.cat([lin, inc[..., 4:] * self.flow_scale], -1)

def fit(net, episodes, norm, steps, args):
    opt = torch.optim.AdamW(net.parameters(), wp.LR, betas=(0.9, 0.9), weight_decay=0.01)
    rng = np.random.default_rng(args.seed)
    for step in range(steps):
        for group in opt.param_groups:
            group["lr"] = wp.learning_rate(step, steps, args.max_lr)
        net.mask_noise = args.mask_noise * min(1.0, step / max(1, args.noise_ramp * steps))
        clips, actions, _, _, _, _ = wp.batch(episodes, norm, rng, args.unroll)
        pred = net(clips[:, 2], actions[:, 1:])
        loss = (pred - clips[:, 3:]).abs().mean()
        if args.mask_l1 > 0:  # what need not move stays in the background, copied exactly
            loss = loss + args.mask_l1 * net.last_masks.mean(dim=(0, 2, 3)).sum()
        wp.optimizer_step(net, opt, loss, step)


def ceiling(net, episodes, norm, iterations=300):
    """score() of the layers' best case: each val rollout's increments fitted to its real frames
    (Adam on the L1, the trained masks and fill kept), so what is left is the representation's
    error, not the motion predictor's."""
    fitted = {}
    for k, (frames, _, acts) in enumerate(episodes[:wp.recipes.ROLLOUTS]):
        first, real = frames[:1], frames[1:wp.recipes.HORIZON + 1][None]
        a = torch.tensor(norm(acts[:wp.recipes.HORIZON]))[None]
        with torch.no_grad():
            inc = torch.stack([torch.zeros(net.layers, AFFINE)] * wp.recipes.HORIZON)[None]
        inc.requires_grad_(True)
        opt = torch.optim.Adam([inc], 0.05)
        for _ in range(iterations):
            loss = (net(first, a, fixed=torch.cat([inc[..., :4] * 0.1, inc[..., 4:] * 4], -1))
                    - real).abs().mean()
            opt.zero_grad()
            loss.backward()
            opt.step()
        fitted[k] = torch.cat([inc[..., :4] * 0.1, inc[..., 4:] * 4], -1).detach()
    calls = iter(range(2 * wp.recipes.ROLLOUTS))

    def imagine(first, a, _):  # score() asks for each episode's logged, then reversed actions
        return net(first, a, fixed=fitted[next(calls) // 2])
    with torch.no_grad():
        return wp.score(net, episodes, norm, imagine)


def from_checkpoint(run_dir):
    """The twin with a wm-motion run's weights, and its action normaliser."""
    tensors, meta = read_archive(os.path.join(run_dir, "checkpoint.wmt"))
    m = meta["config"]["model"]
    assert m["kind"] == "layers", "%s holds a %s model" % (run_dir, m["kind"])
    net = LayerNet(meta["action_dim"], m["layers"], m["channels"], m["flow_scale"],
                   image_size=m["image_size"])
    net.load_state_dict({k[len("model/"):]: torch.from_numpy(v) for k, v in tensors.items()
                         if k.startswith("model/")}, strict=True)
    stats = next(iter(meta["action_norms"].values()))
    mean, std = np.array(stats["mean"], np.float32), np.array(stats["std"], np.float32)
    return net, lambda a: ((a - mean) / std).astype(np.float32)


@torch.no_grad()
def write_masks(path, net, episodes):
    """Per val episode 0-2 a row: the given frame, each layer's mask (white = in the layer), the
    fill, and the given frame where some layer covers it."""
    rows = []
    for frames, _, _ in episodes[:3]:
        first = frames[:1]
        masks, fill = net.eval().sprites(first)
        covered = 1 - torch.prod(1 - masks, 1, keepdim=True)
        tiles = [first[0]] + [m.expand(3, -1, -1) * 2 - 1 for m in masks[0]]
        tiles += [fill[0], (first * covered + (1 - covered))[0]]
        rows.append(np.concatenate([wp.goal1.to_uint8(t[None])[0] for t in tiles], 1))
    wp.write_strip(path, rows)


def main():
    ap = wp.arguments(__doc__, steps=1500, unroll=4, channels=32)
    ap.add_argument("--layers", type=int, default=3)
    ap.add_argument("--mask-bias", type=float, default=0.0, help="initial mask logit")
    ap.add_argument("--mask-noise", type=float, default=2.0, metavar="SIGMA",
                    help="Gaussian noise on the mask logits in training: pushes masks to 0 or 1")
    ap.add_argument("--noise-ramp", type=float, default=0.5, metavar="FRACTION",
                    help="the mask noise grows linearly from 0 over this fraction of the steps")
    ap.add_argument("--mask-l1", type=float, default=0.01, metavar="W",
                    help="W times the layers' mean mask: static pixels stay in the background")
    ap.add_argument("--save", help="the trained net's state_dict (torch.save)")
    ap.add_argument("--load", help="a --save'd net: no training")
    ap.add_argument("--checkpoint", metavar="RUN_DIR",
                    help="a wm-motion run of kind layers: its weights and action statistics")
    ap.add_argument("--masks", metavar="PNG", help="the layers of val episodes 0-2")
    ap.add_argument("--motion-channels", type=int, default=0, metavar="C",
                    help="width of the motion CNN (default: --channels)")
    ap.add_argument("--linear", choices=("affine", "similarity", "scale"), default="affine",
                    help="what a step may do to a layer besides moving it")
    ap.add_argument("--where", action="store_true",
                    help="the layers' current centroids as inputs of the motion MLP")
    ap.add_argument("--ceiling", action="store_true",
                    help="also score each val rollout with its increments fitted to the real frames")
    args = ap.parse_args()
    train, val, actions, norm = wp.setup(args)
    torch.set_flush_denormal(True)  # as wm-motion: saturated masks underflow
    if args.motion_channels or args.where or args.linear != "affine":
        net = VariantLayerNet(actions.shape[1], args.layers, args.channels,
                              args.motion_channels or args.channels, args.where, args.linear,
                              mask_bias=args.mask_bias, mask_noise=args.mask_noise)
    else:
        net = LayerNet(actions.shape[1], args.layers, args.channels, mask_bias=args.mask_bias,
                       mask_noise=args.mask_noise)
    start = time.time()
    if args.checkpoint:
        net, norm = from_checkpoint(args.checkpoint)
    elif args.load:
        net.load_state_dict(torch.load(args.load))
    else:
        fit(net, train, norm, args.steps, args)
    seconds = time.time() - start
    net.eval()
    with torch.no_grad():
        r, rows = wp.score(net, val, norm, lambda first, a, _: net(first, a))
    trained = (args.checkpoint or args.load or
               f"{args.layers} layers, {args.channels} ch, {args.steps} steps, unroll {args.unroll}, "
               f"{seconds:.0f} s")
    print(f"layer predictor ({trained}): {wp.summary(r)}")
    if args.strip:
        wp.write_strip(args.strip, rows)
    if args.save:
        torch.save(net.state_dict(), args.save)
    if args.masks:
        write_masks(args.masks, net, val)
    if args.ceiling:
        r, rows = ceiling(net, val, norm)
        print(f"  fitted increments (the layers' ceiling): {wp.summary(r)}")
        if args.strip:
            wp.write_strip(args.strip.replace(".png", "_ceiling.png"), rows)


if __name__ == "__main__":
    main()
