#!/usr/bin/python3
"""Issue 20, goal 2: can an arm be drawn from a pose at all, and can the pose be moved by the
actions? Session 30's pose arm (bench/pose_arm.py) never started drawing: its alpha went to 0
and it copied the given frame. Here the renderer is first learned alone, as an autoencoder:
pose = encoder(x_t), x_t ~ renderer(pose) composited over a background made from another frame
x_s of the same episode (s drawn independently of t):

  --background cross (no labels): a U-Net of x_s (the layered twin's, one mask and a fill)
      erases what moves. A background that kept x_s's arm would show it where x_t has none, so
      the U-Net learns to erase the arm and its shadow, and only the renderer can draw them.
  --background label (a diagnostic): x_s with its arm (true segmentation, grown by a pixel)
      painted its median colour.

Scored as the pose model's ceiling: for val episodes 0..7 the frames 1..8 drawn from the poses
the encoder reads off the real frames ("given": over the given frame's background; "own": over
each frame's own), against copy_last, as every table in docs/motion.md. With --dynamics-steps
N, a pose dynamics p_{t+1} = p_t + A a_t + g(p_t, a_t) is then learned on the frozen encoder's
poses (open-loop rollouts of --horizon steps) and its rollouts from x_0 scored as
bench/layer_predictor.py scores the layered twin.

  bench/pose_autoencoder.py --train data/demo/shards/train --val data/demo/shards/val \
      [--steps 2000] [--renderer broadcast|deconv|keypoint [--sigma 0.08] [--canvas C]] \
      [--background cross|label] [--pose-dim 8] [--width 64] [--loss l2|l1] [--l1-from F] \
      [--moved-weight W [--weigh-drawn]] [--alpha-l1 W] [--dynamics-steps N [--horizon 8] \
      [--dynamics-scale each|common] [--dynamics-width H] [--dynamics-lr LR] \
      [--dynamics-early F] [--dynamics-pixels N] [--save-dynamics PT] [--per-episode [PNG]] \
      [--gap [--gap-episodes DIR]]] \
      [--strip OUT.png] [--layers PNG] [--save NET.pt | --load NET.pt] [--seed S] \
      [--predictive W [--predictive-from F] [--predictive-norm each|total]]

Measured in session 31, not kept (docs/motion.md, "An arm drawn from a pose over a background
learned from other frames"): the cross background erases the arm and its shadow and keeps the
block, and the rollouts follow the actions and draw an arm entering the frame, but the drawn
arm is blurred or, when its moving pixels are weighed, drawn with the table repainted around it.
With --moved-weight 4 --weigh-drawn --alpha-l1 0.01 (pose 16, deconv, 2500 steps, L1 from 60%)
the arm is opaque and the block kept (step-8 arm 0.48x copy_last, block 0.90x; one run), but
it is a smooth shape without fingers, and the PSNR is below the layered recipe's. Session 32
repeated it (weights seed 1; the SEED=1 data): step-8 arm 0.42-0.50x in all four runs.

Session 32 (docs/motion.md, "Repeats of the drawn arm; an arm drawn from keypoints"): with
--renderer keypoint (bench/keypoints.py) the arm drawn from the real frames' keypoints is
truer (a gripper end, the shadow apart), but the keypoints are harder to predict, and the
rollouts lose to the upsampling pose's on the SEED=1 data and where the given frame hides the
arm. --dynamics-scale common is the keypoints' (their numbers share units); --dynamics-pixels
made them worse.

Session 46 (docs/motion.md, "An arm drawn from sprites; a wider renderer"): with --renderer
sprite --parts 4 (bench/sprite_renderer.py) the pose never starts: a static grey smear, no
motion (ceiling 20.95 dB, step-8 arm 0.86x, against the deconv's 23.72 dB and 0.32x).

Sessions 47-48 (docs/motion.md, "More episodes for the pose's dynamics; a pose learned to be
predictable"): --predictive W trains a pose dynamics with the autoencoder, its error's gradient
into the encoder. Normalised per pose number ("each") the pose collapses to a static ghost at
W 0.1 and 1; normalised by the mean spread ("total", the default) W 0.1 blurs the arm and
halves the controllability, W 0.01 rolls out worse than W 0 at both weight seeds (PSNR
-0.5/-0.9 dB, step-8 arm +0.04/+0.09 over 16 episodes). Not kept.

Session 49 (docs/motion.md, "A faster learning rate for the pose's dynamics"): the dynamics is
underfitted, the first step from frame 0 most. --dynamics-width 512, deeper or sub-stepped
corrections lower its pose error in proportion to their compute; --dynamics-lr 0.006 does as
much in the same steps (the C++ demo's train.dynamics_lr since). --gap-episodes scores --gap on
300 episodes of another data seed, bench/pose_dynamics_paired.py pairs two --save-dynamics fits.
"""
import time

import numpy as np
import torch
from torch import nn

import warp_predictor as wp
import layer_predictor as lp
import layer_variants
import keypoints
import pose_arm
import pose_gap
from layer_twin import LayerNet
from pose_twin import DeconvRenderer, PoseDynamics, erase, over
from sprite_renderer import SpriteRenderer

BATCH = 32


def differs(frames, others):
    """[B, 1, S, S] 1 where `frames` and `others` differ by over 30 levels in some channel."""
    return ((frames - others).abs().amax(1, keepdim=True) > 30 / 127.5).float()


def erased(frames, seg):
    """`frames` [T, 3, S, S] with the arm (label 1, grown by a pixel) painted each frame's median
    colour of the rest."""
    arm = torch.from_numpy((seg == 1).astype(np.float32))[:, None]
    arm = torch.nn.functional.max_pool2d(arm, 3, 1, 1)
    out = frames.clone()
    for k in range(len(frames)):
        rest = frames[k][:, arm[k, 0] == 0]
        colour = rest.median(1).values if rest.shape[1] else torch.zeros(3)
        out[k] = frames[k] * (1 - arm[k]) + colour[:, None, None] * arm[k]
    return out


class PoseAutoencoder(nn.Module):
    """frames drawn from their poses over the background of other frames of their episodes:
    with --background label that frame with its arm erased by the label; with cross a U-Net's
    (the layered twin's, one mask and a fill) of that frame. Drawn from another frame, a
    background that kept its arm would show it where the frame drawn has none, so the U-Net
    learns to erase what moves, and only the renderer can draw it: no labels."""

    def __init__(self, pose_dim, channels, width, renderer, image_size=64, sigma=0.08,
                 canvas=1.0, parts=4):
        super().__init__()
        self.encoder = pose_arm.PoseEncoder(pose_dim, channels, image_size)
        if renderer == "keypoint":  # the pose: pose_dim / 2 points (x, y)
            k = pose_dim // 2
            self.encoder = keypoints.KeypointEncoder(k, channels, image_size, canvas)
            self.renderer = keypoints.KeypointRenderer(k, width, image_size, sigma, canvas > 1)
        elif renderer == "deconv":
            self.renderer = DeconvRenderer(pose_dim, width, image_size)
        elif renderer == "sprite":
            self.renderer = SpriteRenderer(pose_dim, parts, image_size)
        else:
            self.renderer = pose_arm.Renderer(pose_dim, width, image_size, alpha_bias=-2.0)
            # pose_arm's colour starts black (tanh(-3), saturated), so the alpha took the blame
            # and died in 20 steps (measured); grey instead
            nn.init.zeros_(self.renderer.mlp[-1].bias[:3])
        self.eraser = LayerNet(1, layers=1, channels=channels, image_size=image_size)
        self.labelled = None  # FrameLookup of the label-erased frames (--background label)

    def background(self, sources):
        if self.labelled is not None:
            return self.labelled(sources)
        return erase(self.eraser, sources)

    def forward(self, frames, sources):
        rgb, alpha = self.renderer(self.encoder(frames))
        self.alpha, self.last_background = alpha, self.background(sources)
        return over(rgb, alpha, self.last_background)


def optimizer(net):
    """AdamW; a sprite renderer's pixels (--renderer sprite) 10x faster and not decayed (each is
    a logit that must move by a few units; decay would pull the alpha towards 0.5)."""
    sprites = [p for n, p in net.named_parameters() if n == "renderer.sprites"]
    rest = [p for n, p in net.named_parameters() if n != "renderer.sprites"]
    groups = [{"params": rest}] + ([{"params": sprites, "scale": 10.0, "weight_decay": 0.0}]
                                   if sprites else [])
    return torch.optim.AdamW(groups, wp.LR, betas=(0.9, 0.9), weight_decay=0.01)


def predictability(net, episodes, norm, rng, args):
    """--predictive: the squared error of the pose dynamics `net.predictor` rolled open loop over
    8 windows of --horizon steps against the poses the encoder reads off the windows' frames,
    over the pose numbers' mean variance in the batch (--predictive-norm total) or each one's
    own (each). Its gradient reaches the encoder
    through both ends, so the pose is read to be what the actions move (an embedding learned
    with its dynamics, as E2C's), not only what the renderer draws."""
    h = args.horizon
    long_enough = [e for e, (f, _, _) in enumerate(episodes) if len(f) > h]
    chosen = [long_enough[int(k)] for k in rng.integers(len(long_enough), size=8)]
    picks = [(e, int(rng.integers(len(episodes[e][0]) - h))) for e in chosen]
    poses = net.encoder(torch.cat([episodes[e][0][t:t + h + 1] for e, t in picks]))
    poses = poses.view(len(picks), h + 1, -1)
    acts = torch.stack([torch.from_numpy(norm(episodes[e][2][t:t + h])) for e, t in picks])
    error = (net.predictor(poses[:, 0], acts) - poses[:, 1:]).pow(2)
    spread = poses.detach().flatten(0, 1).var(0)
    if args.predictive_norm == "each":  # session 47: blew up on numbers that barely vary
        return (error / (spread.sqrt() + 1e-3).pow(2)).mean()
    return error.mean() / spread.mean()  # shrinking the whole pose cannot win


def fit(net, episodes, args, norm):
    opt = optimizer(net)
    rng = np.random.default_rng(args.seed)
    for step in range(args.steps):
        for group in opt.param_groups:
            group["lr"] = wp.learning_rate(step, args.steps, args.max_lr) * group.get("scale", 1)
        picks = [(int(e), *rng.integers(len(episodes[e][0]), size=2))
                 for e in rng.integers(len(episodes), size=BATCH)]
        x = torch.stack([episodes[e][0][t] for e, t, _ in picks])
        sources = torch.stack([episodes[e][0][s] for e, _, s in picks])
        error = net(x, sources) - x
        if args.moved_weight > 0:  # where the two frames differ (the arm, its shadow) counts more
            other = net.last_background.detach() if args.weigh_drawn else sources
            error = error * (1 + args.moved_weight * differs(x, other))
        # the squared error: while the pose says nothing yet, the L1's best guess at each pixel
        # is its median, no arm, and the alpha dies at 0 before the pose can learn (measured)
        squared = args.loss == "l2" and step < args.l1_from * args.steps
        loss = error.pow(2).mean() if squared else error.abs().mean()
        loss = loss + args.alpha_l1 * net.alpha.mean()  # the renderer draws what moves, not all
        predicted = torch.zeros(())
        if args.predictive and step >= args.predictive_from * args.steps:  # once the pose is read
            predicted = predictability(net, episodes, norm, rng, args)
        wp.optimizer_step(net, opt, loss + args.predictive * predicted, step)
        if step % 100 == 0:  # under optimizer_step's loss line
            print(f"  alpha {net.alpha.mean().item():.3f} pose error {predicted.item():.4f}",
                  flush=True)


@torch.no_grad()
def ceiling(net, episodes):
    """Means over val episodes 0..7 (long enough) of window_scores for the frames drawn from
    their own poses over the given frame's background ('given') and their own ('own')."""
    h = wp.recipes.HORIZON
    found = {k: [] for k in ("given", "own", "copy_last")}
    rows = []
    picked = [e for e in range(len(episodes)) if len(episodes[e][0]) > h][:wp.recipes.ROLLOUTS]
    for e in picked:
        frames, seg, _ = episodes[e]
        real = frames[1:h + 1]
        preds = {"given": net(real, frames[:1].expand(h, -1, -1, -1)), "own": net(real, real)}
        preds = {k: wp.goal1.to_uint8(v) for k, v in preds.items()}
        real8, scored = wp.window_scores(frames, seg, preds)
        for name, s in scored.items():
            found[name].append(s)
        if len(rows) < 9:
            rows += [np.concatenate(list(r), 1) for r in (real8, preds["given"], preds["own"])]
    return wp.means(found), rows


@torch.no_grad()
def episode_poses(net, episodes):
    return [torch.cat([net.encoder(f[k:k + 256]) for k in range(0, len(f), 256)])
            for f, _, _ in episodes]


def pick_windows(starts, rng, early=0.0, n=256):
    """n of the windows `starts` ((episode, frame) pairs) at random, the first `early` of them
    from an episode's frame 0 or 1 (its largest actions: the first step underfits, session 48)."""
    picks = [starts[int(k)] for k in rng.integers(len(starts), size=n)]
    if early:
        first = [(e, t) for e, t in starts if t < 2]
        k = int(n * early)
        picks = [first[int(j)] for j in rng.integers(len(first), size=k)] + picks[k:]
    return picks


def fit_dynamics(dyn, poses, episodes, norm, args):
    """Open-loop pose rollouts of --horizon steps from random frames against the encoder's poses
    (squared error, scaled by each pose number's spread, or with --dynamics-scale common by
    their mean spread: keypoints that sit still have almost none, and scaled by their own their
    noise would outweigh the arm's points)."""
    h = args.horizon
    scale = torch.cat(poses).std(0) + 1e-3
    if args.dynamics_scale == "common":
        scale = scale.mean().expand_as(scale)
    starts = [(e, t) for e, p in enumerate(poses) for t in range(len(p) - h)]
    opt = torch.optim.AdamW(dyn.parameters(), args.dynamics_lr, weight_decay=0.01)
    rng = np.random.default_rng(args.seed)
    for step in range(args.dynamics_steps):
        for group in opt.param_groups:
            group["lr"] = wp.learning_rate(step, args.dynamics_steps, args.dynamics_lr)
        picks = pick_windows(starts, rng, args.dynamics_early)
        first = torch.stack([poses[e][t] for e, t in picks])
        target = torch.stack([poses[e][t + 1:t + h + 1] for e, t in picks])
        acts = torch.stack([torch.from_numpy(norm(episodes[e][2][t:t + h])) for e, t in picks])
        loss = ((dyn(first, acts) - target) / scale).pow(2).mean()
        wp.optimizer_step(dyn, opt, loss, step)


def fit_dynamics_pixels(dyn, net, episodes, norm, args):
    """--dynamics-pixels N: then the dynamics fitted through the frozen encoder, background and
    renderer to the real frames (open-loop rollouts of --horizon steps from random frames, the
    autoencoder's final loss): what is scored is the pictures, and a keypoint the pictures do
    not need (on no part of the arm, or jumping between two) costs nothing there."""
    h = args.horizon
    starts = [(e, t) for e, (f, _, _) in enumerate(episodes) for t in range(len(f) - h)]
    opt = torch.optim.AdamW(dyn.parameters(), 3e-4, weight_decay=0.01)
    rng = np.random.default_rng(args.seed + 1)
    net.requires_grad_(False)
    for step in range(args.dynamics_pixels):
        for group in opt.param_groups:
            group["lr"] = wp.learning_rate(step, args.dynamics_pixels, 3e-4)
        picks = [starts[int(k)] for k in rng.integers(len(starts), size=8)]
        first = torch.stack([episodes[e][0][t] for e, t in picks])
        real = torch.cat([episodes[e][0][t + 1:t + h + 1] for e, t in picks])
        acts = torch.stack([torch.from_numpy(norm(episodes[e][2][t:t + h])) for e, t in picks])
        with torch.no_grad():
            pose, background = net.encoder(first), net.background(first)
        background = background.repeat_interleave(h, 0)
        rgb, alpha = net.renderer(dyn(pose, acts).flatten(0, 1))
        error = over(rgb, alpha, background) - real
        error = error * (1 + args.moved_weight * differs(real, background))
        wp.optimizer_step(dyn, opt, error.abs().mean(), step)


def marked(net, frame):
    """`frame` with its keypoints (--renderer keypoint) as red pluses (blue on the border for
    those outside it, --canvas)."""
    if not isinstance(net.encoder, keypoints.KeypointEncoder):
        return frame
    frame, size = frame.clone(), frame.shape[-1]
    for point in net.encoder(frame[None]).view(-1, 2):
        col, row = ((point.clamp(-1, 1) + 1) / 2 * (size - 1)).round().long().tolist()
        colour = torch.tensor([1.0, -1.0, -1.0] if point.abs().max() <= 1 else [-1.0, -1.0, 1.0])
        for r, c in ((row, col), (row - 1, col), (row + 1, col), (row, col - 1), (row, col + 1)):
            if 0 <= r < size and 0 <= c < size:  # a plus, to be seen
                frame[:, r, c] = colour
    return frame


@torch.no_grad()
def write_layers(path, net, episodes, steps=(2, 4, 6, 8)):
    """Per val episode 0-7 a row: the given frame (keypoints marked), its background, and the
    arm drawn from the poses of real frames `steps` (on white)."""
    rows = []
    for frames, _, _ in episodes[:8]:
        tiles = [marked(net, frames[0]), net.background(frames[:1])[0]]
        for t in steps:
            rgb, alpha = net.renderer(net.encoder(frames[min(t, len(frames) - 1)][None]))
            tiles.append(over(rgb, alpha, 1)[0])
        rows.append(np.concatenate([wp.goal1.to_uint8(t[None])[0] for t in tiles], 1))
    wp.write_strip(path, rows)


def arguments():
    ap = wp.arguments(__doc__, steps=2000, unroll=1, channels=32)
    ap.add_argument("--pose-dim", type=int, default=8)
    ap.add_argument("--width", type=int, default=64)
    ap.add_argument("--renderer", choices=("broadcast", "deconv", "keypoint", "sprite"),
                    default="broadcast", help="keypoint: the pose is --pose-dim / 2 keypoints "
                    "drawn as Gaussian blobs through a U-Net (bench/keypoints.py); sprite: "
                    "--parts sprites placed by affine maps of the pose (bench/sprite_renderer.py)")
    ap.add_argument("--parts", type=int, default=4, help="--renderer sprite: the sprites")
    ap.add_argument("--sigma", type=float, default=0.08, help="--renderer keypoint: the blobs' "
                    "width in [-1, 1] units (0.08: 2.5 pixels at 64x64)")
    ap.add_argument("--canvas", type=float, default=1.0, help="--renderer keypoint: keypoints "
                    "may lie in [-C, C] (the frame padded), the renderer also given each "
                    "pixel's offsets from them")
    ap.add_argument("--background", choices=("label", "cross"), default="cross",
                    help="label: each frame's arm erased by its segmentation (a diagnostic); "
                    "cross: erased by a U-Net that sees another frame (no labels)")
    ap.add_argument("--loss", choices=("l1", "l2"), default="l2")
    ap.add_argument("--l1-from", type=float, default=1.0, metavar="F", help="with --loss l2: "
                    "the L1 from that fraction of the steps on (sharper once the pose is read)")
    ap.add_argument("--moved-weight", type=float, default=0.0, metavar="W",
                    help="the pixels where the frame and its background's source differ by "
                    "over 30 levels count 1 + W times (no labels)")
    ap.add_argument("--weigh-drawn", action="store_true", help="with --moved-weight: the "
                    "pixels where the frame differs from the background, not from its source "
                    "frame (what the renderer must draw, not also what the U-Net erased)")
    ap.add_argument("--alpha-l1", type=float, default=0.0, metavar="W",
                    help="W x the renderer's mean alpha in the loss (as the layers' mask L1)")
    ap.add_argument("--dynamics-steps", type=int, default=0, help="then learn the poses' "
                    "motion (PoseDynamics) and score its open-loop rollouts")
    ap.add_argument("--horizon", type=int, default=8, help="the dynamics' training rollouts")
    ap.add_argument("--dynamics-pixels", type=int, default=0, metavar="N",
                    help="then N steps fitting the dynamics to the frames through the frozen "
                    "renderer (8 rollouts a step)")
    ap.add_argument("--dynamics-width", type=int, default=128, metavar="H",
                    help="the correction MLP's width (the C++ demo's: 256; it is underfitted, "
                    "session 49)")
    ap.add_argument("--dynamics-lr", type=float, default=1e-3, metavar="LR",
                    help="the dynamics' peak learning rate (the C++ train.dynamics_lr; 0.006 "
                    "since session 49)")
    ap.add_argument("--save-dynamics", metavar="PT", help="the learned PoseDynamics' state "
                    "(for bench/pose_dynamics_paired.py)")
    ap.add_argument("--dynamics-early", type=float, default=0.0, metavar="F",
                    help="that fraction of the dynamics' windows from an episode's frame 0 or 1")
    ap.add_argument("--dynamics-scale", choices=("each", "common"), default="each",
                    help="the dynamics' errors divided by each pose number's spread or by "
                    "their mean spread (keypoints: all in the same units)")
    ap.add_argument("--per-episode", metavar="PNG", nargs="?", const="",
                    help="the rollouts' arm at step 8 per val episode (layer_predictor's)")
    ap.add_argument("--predictive", type=float, default=0.0, metavar="W",
                    help="W x the error of a pose dynamics learned with the autoencoder, its "
                    "gradient into the encoder too (the pose read to be predictable)")
    ap.add_argument("--predictive-norm", choices=["each", "total"], default="total",
                    help="divide the pose error by each number's spread or by their mean one")
    ap.add_argument("--predictive-from", type=float, default=0.2, metavar="F",
                    help="--predictive from that fraction of the steps on")
    ap.add_argument("--gap", action="store_true", help="per step: the arm drawn from the "
                    "encoder's, the one-step and the open-loop poses, on val and on training "
                    "episodes 0-15 (bench/pose_gap.py)")
    ap.add_argument("--gap-episodes", metavar="DIR", help="with --gap: also over the episodes "
                    "of this shard dataset (say 300 generated with another seed: 16 val episodes "
                    "are too few to separate dynamics that differ by 0.02x; session 49)")
    ap.add_argument("--save")
    ap.add_argument("--load")
    ap.add_argument("--layers", metavar="PNG", help="per val episode 0-7: the given frame, its "
                    "background, and the renderer's arm at steps 2, 4, 6, 8 (on white)")
    return ap.parse_args()


@torch.no_grad()
def score_dynamics(net, train, val, action_dim, norm, args):
    """PoseDynamics learned on the frozen encoder's poses; its rollouts from x_0 scored."""
    with torch.enable_grad():
        dyn = PoseDynamics(args.pose_dim, action_dim, args.dynamics_width)
        fit_dynamics(dyn, episode_poses(net, train), train, norm, args)
        if args.dynamics_pixels:
            fit_dynamics_pixels(dyn, net, train, norm, args)
    if args.save_dynamics:
        torch.save(dyn.state_dict(), args.save_dynamics)

    def imagine(first, acts, _=None):
        return over(*net.renderer(dyn(net.encoder(first), acts)[0]), net.background(first))[None]
    r, rows = wp.score(net, val, norm, imagine)
    print(f"pose dynamics ({args.dynamics_steps} steps, {args.dynamics_pixels} through the "
          f"renderer, horizon {args.horizon}): "
          f"{wp.summary(r)}")
    from pose_dynamics_refit import step8_arm  # it imports this file
    every_first, every_start = step8_arm(imagine, val, norm)
    print(f"  step-8 arm over all {len(val)} val episodes from frame 0: {every_first:.3f}; "
          f"from frames 0, 8, 16, 24: {every_start:.3f}")
    if args.gap:
        sets = [("val", val), ("training episodes 0-15", train[:16])]
        if args.gap_episodes:
            sets.append((args.gap_episodes, wp.recipes.load(args.gap_episodes)))
        for name, episodes in sets:
            print(f"  {name}:")
            pose_gap.print_gap(pose_gap.gap_by_step(net, dyn, episodes, norm, args.horizon))
    if args.strip:
        wp.write_strip(args.strip.replace(".png", "_rollout.png"), rows)
    if args.per_episode is not None:
        lp.per_episode(imagine, val, norm, args.per_episode)


def main():
    args = arguments()
    train, val, actions, norm = wp.setup(args)
    torch.set_flush_denormal(True)
    net = PoseAutoencoder(args.pose_dim, args.channels, args.width, args.renderer,
                          sigma=args.sigma, canvas=args.canvas, parts=args.parts)
    if args.predictive:
        net.predictor = PoseDynamics(args.pose_dim, actions.shape[1], 256)
    if args.background == "label":
        net.labelled = layer_variants.FrameLookup()
        for frames, seg, _ in train + val:
            net.labelled.add(frames, erased(frames, seg))
    start = time.time()
    if args.load:
        net.load_state_dict(torch.load(args.load))
    else:
        fit(net, train, args, norm)
    if args.save:
        torch.save(net.state_dict(), args.save)
    net.eval()
    r, rows = ceiling(net, val)
    if args.layers:
        write_layers(args.layers, net, val)
    print(f"pose autoencoder ({args.renderer}, {args.background} background, pose "
          f"{args.pose_dim}, width {args.width}, "
          f"{args.load or f'{args.steps} steps'}, {time.time() - start:.0f} s)")
    for name in ("given", "own"):
        print(f"  {name} background: {wp.summary(r, name)}")
    if args.strip:
        wp.write_strip(args.strip, rows)
    if args.dynamics_steps:
        score_dynamics(net, train, val, actions.shape[1], norm, args)


if __name__ == "__main__":
    main()
