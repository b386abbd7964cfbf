#!/usr/bin/python3
"""Issue 20, goal 2: an arm drawn from a pose, not moved from the given frame's pixels.

Session 29 found that the layered motion model misses the step-8 arm mark where the given frame
does not show the arm (docs/motion.md, "The arm the given frame does not show"): no motion of
the given frame's layers draws what is not in them. This model instead infers a pose vector
from the given frame (fingertips, shadow), moves it with the actions and draws the arm from it:

  p_0 = encoder(x_0),  p_{t+1} = p_t + A a_t + g(p_t, a_t)   (A linear, g a zero-initialised MLP)
  rgb_t, alpha_t = renderer(p_t)                             (a spatial-broadcast decoder)
  background = x_0 (1 - m) + fill m                           (m, fill: a U-Net of x_0, erasing
                                                               the given frame's arm)
  x_t = rgb_t alpha_t + (1 - alpha_t) background

Trained on the frames alone (no labels, no states): the L1 of the rollout's frames and of the
given frame redrawn from p_0, plus --consistency W times the squared distance between the pose
rolled out to step k and the encoder's pose of the real frame k. Scored as
bench/layer_predictor.py scores the layered twin (8-step rollouts from frame 0 of val episodes
0..7; --per-episode: the step-8 arm per episode, and over the episodes whose given frame shows
the arm and the others).

  bench/pose_arm.py --train data/demo/shards/train --val data/demo/shards/val \
      [--steps 1500] [--unroll 4] [--pose-dim 8] [--width 64] [--consistency 0.1] \
      [--motion-prior W [--prior-steps 0.3]] [--moved-weight W] [--erase-label] \
      [--autoencode W] [--mask-l1 0.01] [--seed S] [--strip OUT.png] [--per-episode [PNG]] \
      [--layers PNG] [--save NET.pt | --load NET.pt]

Measured in session 30, not kept (docs/motion.md, "An arm drawn from a pose"): in 1500 steps
the pose-drawn arm never starts; every label-free run ends copying the given frame exactly, and
with --erase-label (the given frame's arm erased by its true mask, a diagnostic) the fill's
U-Net paints a blurred static arm instead. --layers shows what the renderer draws.
Session 31 found why (bench/pose_autoencoder.py): the renderer's colour starts black
(tanh(-3), saturated), so the alpha takes the blame and dies within 20 steps; and while the
pose says nothing yet, the L1's best picture is no arm. The defaults here are left as measured.
"""
import time

import torch
from torch import nn

import warp_predictor as wp
import layer_predictor as lp
import layer_variants
from layer_twin import LayerNet
from pose_twin import PoseEncoder, coordinates, over


class Renderer(nn.Module):
    """A pose -> the arm's colour [B, 3, S, S] in [-1, 1] and alpha [B, 1, S, S]: the pose
    broadcast to every pixel beside its coordinates, then a per-pixel MLP (1x1 convolutions;
    Watters et al. 2019's spatial-broadcast decoder): the same function of (pose, position)
    everywhere, so an arm seen at one place can be drawn at another."""

    def __init__(self, pose_dim, width, image_size, alpha_bias=-3.0):
        super().__init__()
        w = width
        self.mlp = nn.Sequential(nn.Conv2d(pose_dim + 2, w, 1), nn.ReLU(),
                                 nn.Conv2d(w, w, 1), nn.ReLU(), nn.Conv2d(w, w, 1), nn.ReLU(),
                                 nn.Conv2d(w, 4, 1))
        nn.init.constant_(self.mlp[-1].bias, -3.0)  # start transparent: the given frame copied
        self.mlp[-1].bias.data[3] = alpha_bias  # (--alpha-bias 0: half opaque)
        self.register_buffer("grid", coordinates(image_size), persistent=False)

    def forward(self, pose):
        b, s = pose.shape[0], self.grid.shape[-1]
        x = torch.cat([pose[:, :, None, None].expand(-1, -1, s, s),
                       self.grid.expand(b, -1, -1, -1)], 1)
        out = self.mlp(x)
        return torch.tanh(out[:, :3]), torch.sigmoid(out[:, 3:])


class PoseArmNet(nn.Module):
    def __init__(self, action_dim, pose_dim=8, channels=32, width=64, image_size=64,
                 alpha_bias=-3.0):
        super().__init__()
        self.encoder = PoseEncoder(pose_dim, channels, image_size)
        self.renderer = Renderer(pose_dim, width, image_size, alpha_bias)
        self.action_map = nn.Linear(action_dim, pose_dim, bias=False)
        self.correction = nn.Sequential(nn.Linear(pose_dim + action_dim, 128), nn.ReLU(),
                                        nn.Linear(128, pose_dim))
        nn.init.zeros_(self.correction[-1].weight)
        nn.init.zeros_(self.correction[-1].bias)
        # what to erase of the given frame and what to put there: the layered twin's U-Net with
        # one layer (its mask and fill), never moved
        self.eraser = LayerNet(action_dim, layers=1, channels=channels, image_size=image_size)
        self.erase_label = None  # a FrameLookup of the arm's true mask (--erase-label)
        self.flat_fill = False

    def step(self, pose, action):
        return pose + self.action_map(action) + self.correction(torch.cat([pose, action], 1))

    def draw(self, pose, background):
        rgb, alpha = self.renderer(pose)
        self.alphas.append(alpha[:, 0])
        return over(rgb, alpha, background)

    def forward(self, first, actions, keep_given=False):
        """Frames [B, H, 3, S, S] after `first` under normalised actions [B, H, D]; the poses
        [B, H + 1, P] in self.poses; `keep_given`: the given frame redrawn first (training)."""
        if self.erase_label is None:
            masks, fill = self.eraser.sprites(first)
        else:  # --erase-label: the given frame's arm erased, and hidden from the fill's U-Net
            arm = self.erase_label(first)
            masks, fill = self.eraser.sprites(first * (1 - arm))
            masks = 1 - (1 - masks) * (1 - arm)
            if self.flat_fill:  # only the renderer can draw an arm
                outside = 1 - masks
                fill = ((first * outside).sum((2, 3), keepdim=True) /
                        outside.sum((2, 3), keepdim=True).clamp_min(1)).expand_as(first)
        self.last_masks = masks
        background = first * (1 - masks) + fill * masks
        self.background = background
        pose = self.encoder(first)
        self.alphas = []  # [B, S, S] per frame drawn, for fit()'s motion prior
        poses, out = [pose], [self.draw(pose, background)] if keep_given else []
        for t in range(actions.shape[1]):
            pose = self.step(pose, actions[:, t])
            poses.append(pose)
            out.append(self.draw(pose, background))
        self.poses = torch.stack(poses, 1)
        return torch.stack(out, 1)


def fit(net, episodes, norm, args):
    opt = torch.optim.AdamW(net.parameters(), wp.LR, betas=(0.9, 0.9), weight_decay=0.01)
    rng = wp.np.random.default_rng(args.seed)
    for step in range(args.steps):
        for group in opt.param_groups:
            group["lr"] = wp.learning_rate(step, args.steps, args.max_lr)
        clips, actions, _, _, _, _ = wp.batch(episodes, norm, rng, args.unroll)
        pred = net(clips[:, 2], actions[:, 1:], keep_given=True)
        loss = lp.frame_loss(pred[:, 1:], clips, args.moved_weight)
        loss = loss + (pred[:, 0] - clips[:, 2]).abs().mean() + args.mask_l1 * net.last_masks.mean()
        if args.motion_prior > 0 and step < args.prior_steps * args.steps:
            # the arm drawn and the given frame's erased, together, start on what moves: from
            # a transparent arm and nothing erased (the given frame copied) no gradient leads out
            weight = args.motion_prior * (1 - step / (args.prior_steps * args.steps))
            drawn_or_erased = torch.cat([torch.stack(net.alphas, 1), net.last_masks], 1)
            loss = loss + weight * lp.motion_prior_loss(drawn_or_erased, clips)
        if args.consistency > 0:  # the rolled-out pose agrees with the pose the frame shows
            b, h = clips.shape[:2]
            seen = net.encoder(clips[:, 3:].flatten(0, 1)).view(b, h - 3, -1)
            loss = loss + args.consistency * (net.poses[:, 1:] - seen).pow(2).mean()
            if args.autoencode > 0:  # the renderer also learns from the poses the frames show
                redrawn = net.draw(seen.flatten(0, 1), net.background.repeat_interleave(h - 3, 0))
                loss = loss + args.autoencode * (redrawn - clips[:, 3:].flatten(0, 1)).abs().mean()
        wp.optimizer_step(net, opt, loss, step)


@torch.no_grad()
def write_layers(path, net, episodes, norm, steps=(0, 2, 4, 6, 8)):
    """Per val episode 0-7 a row: the given frame, the background behind the drawn arm, and the
    arm the renderer draws at `steps` of the logged actions' rollout, on white."""
    rows = []
    for frames, _, acts in episodes[:8]:
        net(frames[:1], torch.tensor(norm(acts[:max(steps)]))[None])
        tiles = [frames[0], net.background[0]]
        for t in steps:
            rgb, alpha = net.renderer(net.poses[:, t])
            tiles.append(over(rgb, alpha, 1)[0])
        rows.append(wp.np.concatenate([wp.goal1.to_uint8(t[None])[0] for t in tiles], 1))
    wp.write_strip(path, rows)


def main():
    ap = wp.arguments(__doc__, steps=1500, unroll=4, channels=32)
    ap.add_argument("--pose-dim", type=int, default=8)
    ap.add_argument("--width", type=int, default=64, help="the renderer's per-pixel MLP width")
    ap.add_argument("--consistency", type=float, default=0.1, metavar="W")
    ap.add_argument("--mask-l1", type=float, default=0.01, metavar="W")
    lp.add_prior_arguments(ap, "the drawn arms' and the erased mask's union")
    ap.add_argument("--erase-label", action="store_true",
                    help="(a diagnostic) the given frame's arm, by its true segmentation, is "
                    "always erased and the fill's U-Net does not see it: the model can no "
                    "longer copy the given frame's arm")
    ap.add_argument("--flat-fill", action="store_true",
                    help="(with --erase-label) the fill is the given frame's mean colour outside "
                    "what is erased: no U-Net paints the arm back")
    ap.add_argument("--alpha-bias", type=float, default=-3.0,
                    help="the renderer's initial alpha logit (-3: transparent, 0: half)")
    ap.add_argument("--autoencode", type=float, default=0.0, metavar="W",
                    help="(with --consistency) W x the L1 of each real frame redrawn from the "
                    "pose the encoder reads off it")
    ap.add_argument("--layers", metavar="PNG", help="per val episode 0-7: the given frame, the "
                    "background, the arm drawn at steps 0, 2, 4, 6 and 8 (on white)")
    ap.add_argument("--per-episode", metavar="PNG", nargs="?", const="")
    ap.add_argument("--save")
    ap.add_argument("--load")
    args = ap.parse_args()
    train, val, actions, norm = wp.setup(args)
    torch.set_flush_denormal(True)  # as wm-motion: saturated masks underflow (and slow down)
    net = PoseArmNet(actions.shape[1], args.pose_dim, args.channels, args.width,
                     alpha_bias=args.alpha_bias)
    net.flat_fill = args.flat_fill
    if args.erase_label:
        net.erase_label = layer_variants.FrameLookup()
        for episodes in (train, val):
            layer_variants.add_block_labels(net.erase_label, episodes, label=1)
    start = time.time()
    if args.load:
        net.load_state_dict(torch.load(args.load))
    else:
        fit(net, train, norm, args)
    seconds = time.time() - start
    net.eval()
    with torch.no_grad():
        r, rows = wp.score(net, val, norm, lambda first, a, _: net(first, a))
    print(f"pose arm ({args.load or f'{args.steps} steps, unroll {args.unroll}, {seconds:.0f} s'})"
          f": {wp.summary(r)}")
    if args.per_episode is not None:
        lp.per_episode(net, val, norm, args.per_episode)
    if args.strip:
        wp.write_strip(args.strip, rows)
    if args.layers:
        write_layers(args.layers, net, val, norm)
    if args.save:
        torch.save(net.state_dict(), args.save)


if __name__ == "__main__":
    main()
