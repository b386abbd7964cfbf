#!/usr/bin/python3
"""Issue 20, goal 2: the layered motion model (wm-motion's model.kind layers; docs/motion.md,
"The layered kind") in Python, for experiments before they reach wm-motion. Trains the PyTorch
twin of motion/layer_net.cc (tests/motion/layer_twin.py) on one CPU thread with the recipe of
configs/motion/tiny.yaml and scores it as bench/warp_predictor.py scores the warp kind (8-step
open-loop rollouts from frame 0 of val episodes 0..7: PSNR, SSIM, PSNR minus the reversed
actions', arm / object MSE over copy_last's).

  bench/layer_predictor.py --train data/demo/shards/train --val data/demo/shards/val \
      [--steps 1500] [--unroll 4] [--layers 3] [--channels 32] [--seed S] [--strip OUT.png] \
      [--mask-noise 2] [--noise-ramp 0.5] [--mask-l1 0.01] [--l1-ramp 0] [--mask-bias 0] \
      [--linear affine|similarity|scale] [--fill-residual] \
      [--motion-prior W [--prior-steps 0.3] [--prior-layers N] [--static-only]] \
      [--follow [--follow-bias -4]] \
      [--moved-weight W] [--start-fraction F [--start-span N]] [--margin P [--margin-replicate]] \
      [--save NET.pt | --load NET.pt | --checkpoint RUN_DIR] [--masks OUT.png] [--ceiling] \
      [--score-from T] [--template T [--template-bias -4]] [--keypoints] [--depth] \
      [--mlp-width W] [--ema D] [--blur-l1 W] [--carry [PNG]] \
      [--block-label [--block-front | --block-order] [--action-input] [--memory N]] \
      [--summed [--hybrid] [--no-step-input]] [--peek] [--carry-choice [--carry-learned]] \
      [--per-episode [PNG]]

--mask-noise SIGMA (Gaussian noise on the mask logits in training, grown from 0 over the first
--noise-ramp of the steps) and --mask-l1 W (W x the layers' mean mask in the loss) are the
recipe's (docs/motion.md says what each does; 0 turns it off). Variants measured and not kept:
--l1-ramp F grows the mask L1 from 0 over the first F of the steps; --linear restricts a step's
linear part to a similarity (no shear) or a scale; --fill-residual makes the fill the given
frame plus a correction. --motion-prior W adds wm-motion's train.motion_prior (the layers'
union pulled towards the pixels that change in the window, fading over --prior-steps);
--prior-layers N pulls only the first N layers' union (the others are left to sort
themselves); --static-only keeps only its term on the pixels that did not move. --follow
(measured, not kept) lets a layer follow another's step, gated by the state: for the block,
carried only once grasped. --moved-weight W (wm-motion's train.moved_weight) weighs the pixels
that change in the window 1 + W in the frame loss. --checkpoint scores a wm-motion run of this
kind through the twin instead of training (its weights and action statistics). Measured in
session 26, not kept: --start-fraction F starts that fraction of the training windows at t < N
(the unroll unless --start-span), where every scored rollout starts; --margin P puts the
layers on a canvas P pixels wider than the frame, whose outside the U-Net draws
(--margin-replicate: starting from the border repeated, the recipe). --score-from T scores the
rollouts from frame T of each val episode long enough.
Measured in session 27, not kept: --template T adds, behind the frame's layers, a layer learned
once for all episodes on a T x T canvas and placed on each given frame by a head (what enters
the frame could come from it); --keypoints lets the motion MLP read its features' soft-argmax
points; --depth lets the motion CNN read the given frame's depth image; --mlp-width W makes
the motion MLP two hidden layers of W units (repeated in session 28: not kept either).
Session 28: --ema D evaluates an exponential moving average of the weights (not kept);
--block-label [--block-front | --block-order] [--action-input] [--memory N] adds session 23's
upper bound, a layer whose mask is the block's true segmentation, with --follow's gates, behind
(in front of; either, chosen per step) the others, its motion MLP reading the action too (a
GRU state of N units carried across the steps); --blur-l1 W adds the L1 of the frames blurred
at radii 2, 4 and 8; --carry [PNG] also scores the 8-step windows where the block starts to
move. Session 29: --summed reads each layer's map at once from the given frame and the actions
summed so far (--hybrid: and the imagined frame; --no-step-input: without the step's index);
--peek, a diagnostic, shows the motion CNN the real frame each step leads to; --carry-choice
lets a learned layer carry the labelled block from a step on, the carry chosen (winner takes
all) instead of blended (--carry-learned: the carried layer's mask learned, not the label);
--per-episode [PNG] prints the arm at step 8 per val episode and over the episodes whose given
frame shows the arm and the others (PNG: the others' rows). None is kept. The variants' nets
are in bench/layer_variants.py.
--masks writes, for val episodes 0-2, the given frame, each layer's mask, the fill and the
layers' cut-out. --ceiling (a diagnostic) also scores each rollout with its per-step maps fitted
to the real frames by Adam from the predictor's own (the masks and fill kept): the
representation's error without the motion predictor's.
"""
import time

import numpy as np
import torch

import warp_predictor as wp
import layer_twin as lt
import layer_variants
from motion_run import load_run


def fit(net, episodes, norm, steps, args):
    groups = net.param_groups() if hasattr(net, "param_groups") else net.parameters()
    opt = torch.optim.AdamW(groups, wp.LR, betas=(0.9, 0.9), weight_decay=0.01)
    rng = np.random.default_rng(args.seed)
    average = WeightAverage(net, args.ema) if args.ema > 0 else None
    for step in range(steps):
        for group in opt.param_groups:
            group["lr"] = wp.learning_rate(step, steps, args.max_lr) * group.get("lr_scale", 1)
        net.mask_noise = args.mask_noise * min(1.0, step / max(1, args.noise_ramp * steps))
        clips, actions, _, _, _, _ = wp.batch(episodes, norm, rng, args.unroll,
                                                     args.start_fraction, args.start_span)
        if hasattr(net, "targets"):  # --carry-choice: the real frames pick the winning carry
            net.targets = clips[:, 3:]
        pred = net(clips[:, 2], actions[:, 1:])
        loss = frame_loss(pred, clips, args.moved_weight)
        if getattr(net, "aux_loss", None) is not None:
            loss = loss + net.aux_loss
        if args.blur_l1 > 0:  # a block moved farther than its size still gets a gradient
            loss = loss + args.blur_l1 * blurred_l1(pred, clips[:, 3:])
        if args.mask_l1 > 0:  # what need not move stays in the background, copied exactly
            weight = args.mask_l1 * min(1.0, step / max(1, args.l1_ramp * steps))
            loss = loss + weight * net.last_masks.mean(dim=(0, 2, 3)).sum()
        if args.motion_prior > 0 and step < args.prior_steps * steps:
            weight = args.motion_prior * (1 - step / (args.prior_steps * steps))
            pulled = net.last_masks[:, :args.prior_layers or None]
            loss = loss + weight * motion_prior_loss(pulled, clips, args.static_only)
        wp.optimizer_step(net, opt, loss, step)
        if average is not None:
            average.update(net)
    if average is not None:
        average.copy_to(net)
    if hasattr(net, "carries"):
        print(f"  training windows won by a carry: {net.carries} of {net.windows}")


class WeightAverage:
    """`--ema D`: an exponential moving average of the weights (decay D per step), which the
    net takes at the end: the last iterate of a small-batch run moves with its last batches,
    and the twin's runs differ by more across weights seeds than most variants do."""

    def __init__(self, net, decay):
        self.decay = decay
        self.shadow = {k: v.detach().clone() for k, v in net.state_dict().items()}

    @torch.no_grad()
    def update(self, net):
        for k, v in net.state_dict().items():
            self.shadow[k].mul_(self.decay).add_(v, alpha=1 - self.decay)

    def copy_to(self, net):
        net.load_state_dict(self.shadow)


def frame_loss(pred, clips, moved_weight=0.0):
    """The L1 between the imagined and the real frames of the window; with `moved_weight` W
    the pixels that change within the window (moved_pixels) weigh 1 + W: the arm and the block
    are a few percent of the frame, and the metrics that matter are on them."""
    error = (pred - clips[:, 3:]).abs()
    if moved_weight <= 0:
        return error.mean()
    weight = 1 + moved_weight * moved_pixels(clips)[:, None, None]
    return (error * weight).mean() / weight.mean()


def blurred_l1(pred, real, radii=(2, 4, 8)):
    """The mean over radii of the L1 between the frames box-blurred (warp_predictor.box_blur):
    where a small object is drawn a few of its sizes from where it is, the plain L1 has no
    gradient towards the right place; blurred, the two overlap."""
    a, b = pred.flatten(0, 1), real.flatten(0, 1)
    return sum((wp.box_blur(a, r) - wp.box_blur(b, r)).abs().mean() for r in radii) / len(radii)


def carry_windows(episodes, horizon=8, lead=2, pixels=1.5, label=2):
    """[(episode, start)]: `horizon` steps from `lead` steps before the block's centroid first
    moves by more than `pixels` (docs/motion.md, session 23's carry windows)."""
    out = []
    for e, (frames, seg, _) in enumerate(episodes):
        ys, xs = np.nonzero(seg[0] == label)
        if len(xs) == 0:
            continue
        c0 = np.array([xs.mean(), ys.mean()])
        for t in range(1, len(frames)):
            ys, xs = np.nonzero(seg[t] == label)
            if len(xs) and np.linalg.norm(np.array([xs.mean(), ys.mean()]) - c0) > pixels:
                start = max(0, t - lead)
                if start + horizon < len(frames):
                    out.append((e, start))
                break
    return out


@torch.no_grad()
def carry_score(net, episodes, norm, horizon=8, strip=None):
    """Block MSE over copy_last's (ratio of the means) and arm MSE ratio on carry_windows;
    `strip`: a PNG of each window's real and imagined rows."""
    found, rows = {"model": [], "copy_last": []}, []
    net.gate_history, net.order_history = [], []
    for e, start in carry_windows(episodes, horizon):
        frames, seg, acts = (x[start:] for x in episodes[e])
        pred = wp.goal1.to_uint8(net(frames[:1], torch.tensor(norm(acts[:horizon]))[None])[0])
        real, scored = wp.window_scores(frames, seg, {"model": pred})
        for name, s in scored.items():
            found[name].append(s)
        rows += [np.concatenate(list(x), 1) for x in (real, pred)]
    if strip:
        wp.write_strip(strip, rows)
    r = wp.means(found)
    if net.gate_history:  # how far the block's layer follows each other, per window step
        row = 0 if getattr(net, "front", False) else -1
        gates = torch.stack(net.gate_history)[:, 0, row].view(-1, horizon, net.layers)
        print("  the block layer's follow gates on the carry windows (per step, max over layers):",
              " ".join(f"{g:.3f}" for g in gates.amax(-1).mean(0).tolist()))
    if net.order_history:  # --block-order: how far the block's layer is drawn in front
        print("  the block layer in front on the carry windows (per step):", " ".join(
            f"{g:.2f}" for g in np.reshape(net.order_history, (-1, horizon)).mean(0)))
    net.gate_history = net.order_history = None
    return len(found["model"]), r["model"]["obj"] / r["copy_last"]["obj"], \
        r["model"]["arm"] / r["copy_last"]["arm"]


@torch.no_grad()
def per_episode(net, episodes, norm, strip=None, hidden=50, horizon=8):
    """Per scored val episode: the arm's MSE at the last step, the model's and copy_last's,
    and how many robot pixels the given frame shows; then both sums over the episodes whose
    given frame shows at least `hidden` robot pixels and over the others. `strip`: a PNG of
    the others' real rows (from the given frame) over their imagined ones."""
    sums, rows = {True: np.zeros(2), False: np.zeros(2)}, []
    for k, (frames, seg, acts) in enumerate(episodes[:wp.recipes.ROLLOUTS]):
        pred = wp.goal1.to_uint8(net(frames[:1], torch.tensor(norm(acts[:horizon]))[None])[0])
        _, s = wp.window_scores(frames, seg, {"model": pred})
        robot = int((seg[0] == 1).sum())
        arm = np.array([s["model"]["arm8"], s["copy_last"]["arm8"]])
        sums[robot >= hidden] += arm
        print(f"  val episode {k}: arm at step {horizon} {arm[0]:.0f} (copy_last {arm[1]:.0f}, "
              f"ratio {arm[0] / arm[1]:.2f}); robot pixels in the given frame: {robot}")
        if robot < hidden:
            given = wp.goal1.to_uint8(frames[:1])
            rows += [np.concatenate(list(wp.goal1.to_uint8(frames[:horizon + 1])), 1),
                     np.concatenate(list(given) + list(pred), 1)]
    for shown, (model, copy) in sums.items():
        print(f"  episodes whose given frame shows {'at least' if shown else 'under'} {hidden} "
              f"robot pixels: arm at step {horizon} / copy_last "
              f"{model / max(copy, 1e-9):.2f} (ratio of sums)")
    if strip and rows:
        wp.write_strip(strip, rows)


def moved_pixels(clips, levels=30):
    """[B, S, S] 1 where some later frame of the window differs from the given one (clips[:, 2])
    by more than `levels` in some channel, grown by a pixel: where something moves, from the
    frames alone (no labels)."""
    change = (clips[:, 3:] - clips[:, 2:3]).abs().amax(dim=(1, 2)) > levels / 127.5
    return torch.nn.functional.max_pool2d(change.float()[:, None], 3, 1, 1)[:, 0]


def motion_prior_loss(masks, clips, static_only=False):
    """Cross-entropy of the layers' union against moved_pixels: the layers start on what moves
    instead of growing over the whole (textured) table before any motion is learned.
    `static_only`: only the term that keeps the layers off the pixels that did not move."""
    covered = (1 - torch.prod(1 - masks, 1)).clamp(1e-4, 1 - 1e-4)
    moved = moved_pixels(clips)
    if static_only:
        return -((1 - moved) * torch.log(1 - covered)).mean()
    return torch.nn.functional.binary_cross_entropy(covered, moved)


# Adam's steps of similar size for the linear part and the translation (pixels)
INCREMENT_SCALE = torch.tensor([0.1] * 4 + [4.0] * 2)


def drawn(net, first, masks, fill, increments, with_maps=False):
    """[B, H, 3, S, S] the frames the layers (`masks`, `fill` of `first`) draw when moved by
    `increments` [B, H, K, 6]; `with_maps`: also the maps [B, H, K, 3, 3] after each step."""
    centre0 = net.centroids(masks)
    maps = torch.eye(3).expand(first.shape[0], net.layers, 3, 3)
    out, steps = [], []
    for t in range(increments.shape[1]):
        maps = lt.increment(increments[:, t], lt.apply(maps, centre0)) @ maps
        out.append(net.render(first, masks, fill, maps))
        steps.append(maps)
    frames = torch.stack(out, 1)
    return (frames, torch.stack(steps, 1)) if with_maps else frames


def fit_increments(net, first, actions, real, iterations=300):
    """[B, H, K, 6] each rollout's increments fitted to its real frames [B, H, 3, S, S] by Adam
    on the L1, started from the predictor's own increments (the masks and fill kept, computed
    once). Started from identity maps instead, the fit fell into local minima (the gripper
    vanished). The loss is a sum of per-rollout means, so each rollout is fitted alone."""
    with torch.no_grad():
        net(first, actions)
        masks, fill = net.sprites(first)
    inc = (net.last_increments / INCREMENT_SCALE).requires_grad_()
    opt = torch.optim.Adam([inc], 0.02)
    for _ in range(iterations):
        frames = drawn(net, first, masks, fill, inc * INCREMENT_SCALE)
        loss = (frames - real).abs().mean((1, 2, 3, 4)).sum()
        opt.zero_grad()
        loss.backward()
        opt.step()
    return (inc * INCREMENT_SCALE).detach()


def ceiling(net, episodes, norm, iterations=300):
    """score() of the layers' best case near the predictor's: each val rollout's increments
    fitted to its real frames (fit_increments), so what is left is the representation's error,
    not the motion predictor's. The reversed rollouts are the predictor's, so that column says
    nothing here."""
    fitted = {}
    for k, (frames, _, acts) in enumerate(episodes[:wp.recipes.ROLLOUTS]):
        first, real = frames[:1], frames[1:wp.recipes.HORIZON + 1][None]
        a = torch.tensor(norm(acts[:wp.recipes.HORIZON]))[None]
        fitted[k] = fit_increments(net, first, a, real, iterations)
    calls = iter(range(2 * wp.recipes.ROLLOUTS))

    def imagine(first, a, _):  # score() asks for each episode's logged, then reversed actions
        call = next(calls)
        return net(first, a) if call % 2 else net(first, a, fixed=fitted[call // 2])
    with torch.no_grad():
        return wp.score(net, episodes, norm, imagine)


@torch.no_grad()
def write_masks(path, net, episodes):
    """Per val episode 0-2 a row: the given frame, each layer's mask (white = in the layer), the
    fill, and the given frame where some layer covers it."""
    rows = []
    for frames, _, _ in episodes[:3]:
        first = frames[:1]
        masks, fill = net.eval().sprites(first)
        p, s = getattr(net, "margin", 0), first.shape[-1]
        masks = masks[..., p:p + s, p:p + s]  # --margin: the canvas cropped to the frame
        covered = 1 - torch.prod(1 - masks, 1, keepdim=True)
        tiles = [first[0]] + [m.expand(3, -1, -1) * 2 - 1 for m in masks[0]]
        tiles += [fill[0], (first * covered + (1 - covered))[0]]
        rows.append(np.concatenate([wp.goal1.to_uint8(t[None])[0] for t in tiles], 1))
    wp.write_strip(path, rows)


def add_prior_arguments(ap, pulled):
    """--motion-prior, --prior-steps (motion_prior_loss on `pulled`) and --moved-weight
    (frame_loss), as this script and bench/pose_arm.py take them."""
    ap.add_argument("--motion-prior", type=float, default=0.0, metavar="W",
                    help=f"W x the cross-entropy of {pulled} against the pixels that change in "
                    "the window, fading to 0 over --prior-steps")
    ap.add_argument("--prior-steps", type=float, default=0.3, metavar="FRACTION")
    ap.add_argument("--moved-weight", type=float, default=0.0, metavar="W",
                    help="the frame loss weighs the pixels that change in the window 1 + W")


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
    ap.add_argument("--l1-ramp", type=float, default=0.0, metavar="FRACTION",
                    help="the mask L1 grows linearly from 0 over this fraction of the steps")
    add_prior_arguments(ap, "the layers' union")
    ap.add_argument("--prior-layers", type=int, default=0, metavar="N",
                    help="the prior pulls only the union of the first N layers (0: all)")
    ap.add_argument("--static-only", action="store_true",
                    help="the motion prior only keeps the layers off what did not move")
    ap.add_argument("--start-fraction", type=float, default=0.0, metavar="F",
                    help="this fraction of the windows starts in an episode's first frames")
    ap.add_argument("--start-span", type=int, default=0, metavar="N",
                    help="those windows start at t < N (0: the unroll)")
    ap.add_argument("--score-from", type=int, default=0, metavar="T",
                    help="score rollouts from frame T of each val episode (not the first)")
    ap.add_argument("--blur-l1", type=float, default=0.0, metavar="W",
                    help="plus W times the L1 of the frames blurred at radii 2, 4, 8")
    ap.add_argument("--carry", metavar="PNG", nargs="?", const="",
                    help="also score the carry windows (block and arm over copy_last's); "
                    "PNG: their real and imagined rows")
    ap.add_argument("--per-episode", metavar="PNG", nargs="?", const="",
                    help="also the arm at step 8 per val episode, and over the episodes whose "
                    "given frame shows the arm and the others; PNG: the others' rows")
    ap.add_argument("--ema", type=float, default=0.0, metavar="D",
                    help="evaluate an exponential moving average of the weights (decay D)")
    ap.add_argument("--save", help="the trained net's state_dict (torch.save)")
    ap.add_argument("--load", help="a --save'd net: no training")
    ap.add_argument("--checkpoint", metavar="RUN_DIR",
                    help="a wm-motion run of kind layers: its weights and action statistics")
    ap.add_argument("--masks", metavar="PNG", help="the layers of val episodes 0-2")
    ap.add_argument("--ceiling", action="store_true",
                    help="also score each val rollout with its maps fitted to the real frames")
    layer_variants.add_arguments(ap)
    args = ap.parse_args()
    train, val, actions, norm = wp.setup(args)
    torch.set_flush_denormal(True)  # as wm-motion: saturated masks underflow
    net = layer_variants.build(args, actions.shape[1], train, val)
    start = time.time()
    if args.checkpoint:
        net, norm = load_run(args.checkpoint, "layers")
    elif args.load:
        net.load_state_dict(torch.load(args.load))
    else:
        fit(net, train, norm, args.steps, args)
    seconds = time.time() - start
    net.eval()
    with torch.no_grad():
        r, rows = wp.score(net, val, norm, lambda first, a, _: net(first, a), args.score_from)
    trained = (args.checkpoint or args.load or
               f"{args.layers} layers, {args.channels} ch, {args.steps} steps, "
               f"unroll {args.unroll}, {seconds:.0f} s")
    print(f"layer predictor ({trained}): {wp.summary(r)}")
    if args.carry is not None:
        n, block, arm = carry_score(net, val, norm, strip=args.carry)
        print(f"  carry windows ({n}): object / copy_last {block:.2f}, arm / copy_last {arm:.2f}")
    if args.per_episode is not None:
        per_episode(net, val, norm, args.per_episode)
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
