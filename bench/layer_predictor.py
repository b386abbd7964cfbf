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
      [--mlp-width W]

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
the motion MLP two hidden layers of W units (one run, not yet repeated).
--masks writes, for val episodes 0-2, the given frame, each layer's mask, the fill and the
layers' cut-out. --ceiling (a diagnostic) also scores each rollout with its per-step maps fitted
to the real frames by Adam from the predictor's own (the masks and fill kept): the
representation's error without the motion predictor's.
"""
import os
import time

import cv2
import numpy as np
import torch
from torch.nn import functional as F

import warp_predictor as wp
from dynamics_twin import read_archive
import layer_twin as lt
from layer_twin import LayerNet
from warp_twin import down as wp_down


class VariantLayerNet(LayerNet):
    """Variants measured against the recipe (docs/motion.md): a linear part restricted to a
    similarity (scale and rotation) or a scale (`linear`), and the fill as a correction of the
    given frame (`fill_residual`)."""

    def __init__(self, action_dim, layers, channels, linear="affine", fill_residual=False, **kw):
        super().__init__(action_dim, layers, channels, **kw)
        self.linear, self.fill_residual = linear, fill_residual

    def sprites(self, first):
        masks, fill = super().sprites(first)
        # the fill as a correction of the given frame: at the start the frame is copied
        # whatever the masks, so nothing pushes them to 0 or 1 before the layers move
        return masks, (first + fill if self.fill_residual else fill)

    def step_maps(self, current, first, maps, action):
        inc = super().step_maps(current, first, maps, action)
        if self.linear != "affine":  # [[s, -r], [r, s]]: no shear; "scale": no rotation either
            scale, turn = inc[..., 0], inc[..., 1] * (self.linear == "similarity")
            inc = torch.cat([torch.stack([scale, -turn, turn, scale], -1), inc[..., 4:]], -1)
        return inc


class MarginLayerNet(LayerNet):
    """The layers on a canvas `margin` pixels wider than the frame on every side (`--margin`):
    inside the frame a layer's colours are the given frame's, outside they are drawn by the
    U-Net (a head beside the fill's), so a layer moved inwards brings in what the given frame
    does not show (an arm entering from the edge) instead of its border pixels repeated. The
    U-Net reads the frame zero-padded to the canvas and a channel that says where it is."""

    def __init__(self, action_dim, layers, channels, margin, replicate=False, **kw):
        super().__init__(action_dim, layers, channels, **kw)
        self.margin, self.replicate = margin, replicate
        self.down1 = wp_down(4, channels)
        self.sprite_head = torch.nn.Conv2d(channels + 4, layers + 6, 3, 1, 1)
        torch.nn.init.zeros_(self.sprite_head.weight)
        torch.nn.init.constant_(self.sprite_head.bias, kw.get("mask_bias", 0.0))

    def canvas(self, first):
        """[B, 4, S + 2P, S + 2P]: the frame zero-padded, and 1 where the frame is."""
        inside = torch.ones_like(first[:, :1])
        return F.pad(torch.cat([first, inside], 1), [self.margin] * 4)

    def sprites(self, first):
        """-> masks [B, K, C, C] on the canvas, fill [B, 3, S, S] on the frame; the layers'
        colours [B, 3, C, C] on the canvas are kept for render()."""
        x = self.canvas(first)
        out = self.sprite_head(torch.cat([self.unet(x), x], 1))
        k, p, s = self.layers, self.margin, first.shape[-1]
        inside = x[:, 3:]
        logits = out[:, :k]
        if self.replicate:  # outside: the border's logits and colours plus a learned correction
            border = F.pad(logits[..., p:p + s, p:p + s], [p] * 4, mode="replicate")
            logits = border + logits * (1 - inside)
            colours = F.pad(first, [p] * 4, mode="replicate") + out[:, k + 3:k + 6] * (1 - inside)
        else:
            colours = x[:, :3] * inside + torch.tanh(out[:, k + 3:k + 6]) * (1 - inside)
        if self.training and self.mask_noise > 0:
            logits = logits + self.mask_noise * torch.randn_like(logits)
        self.colours = colours
        return torch.sigmoid(logits), torch.tanh(out[:, k:k + 3, p:p + s, p:p + s])

    def centroids(self, masks):
        return lt.centroids(masks) - self.margin  # frame pixels

    def render(self, first, masks, fill, maps):
        return lt.render(first, masks, fill, maps, first.shape[-1], self.colours, self.margin,
                         "border" if self.replicate else "zeros")


class FollowLayerNet(VariantLayerNet):
    """A layer may follow another's motion this step (`--follow`): the maps applied are
    (I + sum_j g_kj (M_j - I)) M_k, with gates g_kj = sigmoid(.) read by a head beside the
    motion head from the same features (the current frame: is the block in a closed gripper?).
    The gates start near shut (bias `follow_bias`), so the untrained model is the plain one."""

    def __init__(self, action_dim, layers, channels, follow_bias=-4.0, **kw):
        super().__init__(action_dim, layers, channels, **kw)
        self.follow_head = torch.nn.Linear(256, layers * layers)
        torch.nn.init.zeros_(self.follow_head.weight)
        torch.nn.init.constant_(self.follow_head.bias, follow_bias)

    def step_maps(self, current, first, maps, action):
        b, k = current.shape[0], self.layers
        hidden = []
        handle = self.motion_mlp.register_forward_hook(lambda m, i, o: hidden.append(o))
        inc = super().step_maps(current, first, maps, action)
        handle.remove()
        others = 1 - torch.eye(k)
        self.gates = torch.sigmoid(self.follow_head(hidden[0])).view(b, k, k) * others
        return inc

    def combine(self, steps):
        eye = torch.eye(3)
        followed = eye + torch.einsum("bkj,bjrc->bkrc", self.gates, steps - eye)
        return followed @ steps


class KeypointLayerNet(LayerNet):
    """`--keypoints`: the motion MLP also reads where each channel of the motion CNN's 16 x 16
    features peaks, as a spatial soft-argmax (x, y) per channel (the deep spatial autoencoder's
    feature points, Finn et al. 2016): the step's motion in the image depends on where the
    gripper is and how large it looks, which a 4 x 4 map after four halvings blurs."""

    def __init__(self, action_dim, layers, channels, **kw):
        super().__init__(action_dim, layers, channels, **kw)
        cells = 16  # the motion CNN's 4 x 4 map at 64 px, flattened
        self.motion_mlp = torch.nn.Sequential(
            torch.nn.Linear(cells * channels + 2 * channels + layers * lt.AFFINE, 256),
            torch.nn.ReLU())

    def motion_features(self, current, first):
        half = self.motion_cnn[:4](torch.cat([current, first], 1))  # [B, C, 16, 16]
        weights = torch.softmax(half.flatten(2), -1).view_as(half)
        grid = torch.linspace(-1, 1, half.shape[-1])
        points = torch.cat([(weights.sum(2) * grid).sum(-1), (weights.sum(3) * grid).sum(-1)], 1)
        return torch.cat([self.motion_cnn[4:](half).flatten(1), points], 1)


class DepthLayerNet(LayerNet):
    """`--depth`: the motion CNN also reads the given frame's depth image (the dataset's
    steps/observation/depth, as RGB-D robots record it): how far an action moves the arm in the
    image depends on how far the gripper is from the camera, which one 64 px RGB frame leaves
    uncertain. `depths` is the training (or val) episodes' [T, 1, S, S] depths; `windows` says
    which episode and step each batch row starts at."""

    def __init__(self, action_dim, layers, channels, **kw):
        super().__init__(action_dim, layers, channels, **kw)
        self.motion_cnn[0] = torch.nn.Conv2d(7, channels, 4, 2, 1)
        self.depths, self.windows = None, None

    def motion_features(self, current, first):
        depth = torch.stack([self.depths[e][t] for e, t in self.windows])
        return self.motion_cnn(torch.cat([current, first, depth], 1)).flatten(1)


def load_depths(directory):
    """[T, 1, S, S] per episode: steps/observation/depth (mm) as (d - 700) / 250."""
    import wmshard
    ds, out = wmshard.Dataset(directory), []
    for k in range(ds.num_episodes):
        _, _, blobs = ds.episode(k)
        mm = np.stack([cv2.imdecode(np.frombuffer(b, np.uint8), cv2.IMREAD_UNCHANGED)
                       for b in blobs["depth"]]).astype(np.float32)
        out.append(torch.from_numpy((mm - 700) / 250)[:, None])
    return out


class WideMlpLayerNet(LayerNet):
    """`--mlp-width W`: the motion MLP as two hidden layers of W units instead of one of 256, for
    whether the predictor underfits (docs/motion.md, session 27) for want of capacity there."""

    def __init__(self, action_dim, layers, channels, width, **kw):
        super().__init__(action_dim, layers, channels, **kw)
        cells = 16  # the motion CNN's 4 x 4 map at 64 px, flattened
        self.motion_mlp = torch.nn.Sequential(
            torch.nn.Linear(cells * channels + layers * lt.AFFINE, width), torch.nn.ReLU(),
            torch.nn.Linear(width, width), torch.nn.ReLU())
        self.motion_head = torch.nn.Linear(width, layers * lt.AFFINE * (action_dim + 1))
        torch.nn.init.zeros_(self.motion_head.weight)
        torch.nn.init.zeros_(self.motion_head.bias)


TEMPLATE_LR = 10.0


class TemplateLayerNet(LayerNet):
    """`--template T`: behind the given frame's layers, one more layer that is learned once for
    all episodes (its colours and mask on a T x T canvas: the arm as it looks anywhere), placed
    on each given frame by a head that reads the frame, then moved by its own maps like the
    others. It can draw what the given frame does not show: an arm entering from the frame's
    edge, its link beyond the border. Its mask starts near 0, so the untrained model is the
    recipe's."""

    def __init__(self, action_dim, layers, channels, size=96, bias=-4.0, **kw):
        super().__init__(action_dim, layers, channels, **kw)
        self.size, k = size, layers + 1
        self.template = torch.nn.Parameter(torch.cat([torch.zeros(3, size, size),
                                                      torch.full((1, size, size), bias)]))
        cells = 16  # the motion CNN's 4 x 4 map at 64 px, flattened
        self.motion_mlp = torch.nn.Sequential(
            torch.nn.Linear(cells * channels + k * lt.AFFINE, 256), torch.nn.ReLU())
        self.motion_head = torch.nn.Linear(256, k * lt.AFFINE * (action_dim + 1))
        self.place_head = torch.nn.Linear(256, lt.AFFINE)
        for layer in (self.motion_head, self.place_head):
            torch.nn.init.zeros_(layer.weight)
            torch.nn.init.zeros_(layer.bias)

    def param_groups(self):
        """The template's pixels learn `TEMPLATE_LR` times faster: Adam moves a parameter by
        about the learning rate per step, and at the net's 1e-3 a mask logit cannot cross from
        hidden to shown within the run (measured: it stayed below 0.02)."""
        rest = [p for p in self.parameters() if p is not self.template]
        return [{"params": rest}, {"params": [self.template], "lr_scale": TEMPLATE_LR}]

    def placement(self, first):
        """[B, 3, 3] template pixels -> the given frame's pixels: the canvas's centre on the
        frame's, then a map read from the frame (linear part 0.5 tanh, translation 16 px)."""
        b, s, t = first.shape[0], first.shape[-1], self.size
        feats = self.motion_features(first, first)
        state = torch.zeros(b, (self.layers + 1) * lt.AFFINE)
        p = self.place_head(self.motion_mlp(torch.cat([feats, state], 1)))
        lin = torch.eye(2) + 0.5 * torch.tanh(p[:, :4]).view(b, 2, 2)
        centre = torch.full((b, 2), (t - 1) / 2)
        shift = (s - 1) / 2 + 16 * p[:, 4:] - (lin @ centre[..., None])[..., 0]
        top = torch.cat([lin, shift[..., None]], -1)
        return torch.cat([top, torch.tensor([0.0, 0.0, 1.0]).expand(b, 1, 3)], 1)

    def forward(self, first, actions, frames_in=None, fixed=None):
        b, h = actions.shape[:2]
        k = self.layers
        masks, fill = self.sprites(first)
        self.last_masks = masks
        place = self.placement(first)
        middle = torch.full((b, 1, 2), (self.size - 1) / 2)
        centre0 = torch.cat([self.centroids(masks), lt.apply(place[:, None], middle)], 1)
        maps = torch.eye(3).expand(b, k + 1, 3, 3)
        current, out, increments = first, [], []
        for t in range(h):
            inc = (self.step_maps(current.detach(), first, maps, actions[:, t]) if fixed is None
                   else fixed[:, t])
            increments.append(inc)
            maps = lt.increment(inc, lt.apply(maps, centre0)) @ maps
            frame = self.draw(first, masks, fill, maps, place)
            out.append(frame)
            current = frame if frames_in is None else frames_in[:, t]
        self.last_increments = torch.stack(increments, 1)
        return torch.stack(out, 1)

    def draw(self, first, masks, fill, maps, place):
        """The template moved by its map after its placement, over the background, under the
        frame's layers."""
        s, k = first.shape[-1], self.layers
        logit = self.template[3:]
        if self.training and self.mask_noise > 0:
            logit = logit + self.mask_noise * torch.randn_like(logit)
        mask = torch.sigmoid(logit)
        sprite = torch.cat([torch.tanh(self.template[:3]) * mask, mask])
        inv = torch.linalg.inv(maps[:, k] @ place)  # frame pixel -> template pixel
        coords = torch.arange(s, dtype=first.dtype)
        ys, xs = torch.meshgrid(coords, coords, indexing="ij")
        pix = torch.stack([xs, ys, torch.ones_like(xs)], -1).view(1, s * s, 3)
        src = (pix @ inv.transpose(-1, -2))[..., :2].view(-1, s, s, 2) / (self.size - 1) * 2 - 1
        moved = F.grid_sample(sprite.expand(first.shape[0], -1, -1, -1), src, mode="bilinear",
                              padding_mode="zeros", align_corners=True)
        visible = torch.prod(1 - masks, 1, keepdim=True)
        background = visible * first + (1 - visible) * fill
        background = moved[:, :3] + (1 - moved[:, 3:]) * background
        return lt.render(first, masks, fill, maps[:, :k], s, background=background)


def fit(net, episodes, norm, steps, args):
    groups = net.param_groups() if hasattr(net, "param_groups") else net.parameters()
    opt = torch.optim.AdamW(groups, wp.LR, betas=(0.9, 0.9), weight_decay=0.01)
    rng = np.random.default_rng(args.seed)
    for step in range(steps):
        for group in opt.param_groups:
            group["lr"] = wp.learning_rate(step, steps, args.max_lr) * group.get("lr_scale", 1)
        net.mask_noise = args.mask_noise * min(1.0, step / max(1, args.noise_ramp * steps))
        clips, actions, _, _, _, where = wp.batch(episodes, norm, rng, args.unroll,
                                                     args.start_fraction, args.start_span)
        net.windows = where  # --depth reads the window's given frame's depth
        pred = net(clips[:, 2], actions[:, 1:])
        loss = frame_loss(pred, clips, args.moved_weight)
        if args.mask_l1 > 0:  # what need not move stays in the background, copied exactly
            weight = args.mask_l1 * min(1.0, step / max(1, args.l1_ramp * steps))
            loss = loss + weight * net.last_masks.mean(dim=(0, 2, 3)).sum()
        if args.motion_prior > 0 and step < args.prior_steps * steps:
            weight = args.motion_prior * (1 - step / (args.prior_steps * steps))
            pulled = net.last_masks[:, :args.prior_layers or None]
            loss = loss + weight * motion_prior_loss(pulled, clips, args.static_only)
        wp.optimizer_step(net, opt, loss, step)


def frame_loss(pred, clips, moved_weight=0.0):
    """The L1 between the imagined and the real frames of the window; with `moved_weight` W
    the pixels that change within the window (moved_pixels) weigh 1 + W: the arm and the block
    are a few percent of the frame, and the metrics that matter are on them."""
    error = (pred - clips[:, 3:]).abs()
    if moved_weight <= 0:
        return error.mean()
    weight = 1 + moved_weight * moved_pixels(clips)[:, None, None]
    return (error * weight).mean() / weight.mean()


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
        p, s = getattr(net, "margin", 0), first.shape[-1]
        masks = masks[..., p:p + s, p:p + s]  # --margin: the canvas cropped to the frame
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
    ap.add_argument("--l1-ramp", type=float, default=0.0, metavar="FRACTION",
                    help="the mask L1 grows linearly from 0 over this fraction of the steps")
    ap.add_argument("--motion-prior", type=float, default=0.0, metavar="W",
                    help="W x the cross-entropy of the layers' union against the pixels that "
                         "change in the window, fading to 0 over --prior-steps")
    ap.add_argument("--prior-steps", type=float, default=0.3, metavar="FRACTION")
    ap.add_argument("--prior-layers", type=int, default=0, metavar="N",
                    help="the prior pulls only the union of the first N layers (0: all)")
    ap.add_argument("--static-only", action="store_true",
                    help="the motion prior only keeps the layers off what did not move")
    ap.add_argument("--moved-weight", type=float, default=0.0, metavar="W",
                    help="the frame loss weighs the pixels that change in the window 1 + W")
    ap.add_argument("--start-fraction", type=float, default=0.0, metavar="F",
                    help="this fraction of the windows starts in an episode's first frames")
    ap.add_argument("--start-span", type=int, default=0, metavar="N",
                    help="those windows start at t < N (0: the unroll)")
    ap.add_argument("--score-from", type=int, default=0, metavar="T",
                    help="score rollouts from frame T of each val episode (not the first)")
    ap.add_argument("--margin", type=int, default=0, metavar="P",
                    help="the layers on a canvas P pixels wider on each side, drawn outside")
    ap.add_argument("--margin-replicate", action="store_true",
                    help="--margin's canvas starts as the frame's border repeated (the recipe)")
    ap.add_argument("--mlp-width", type=int, default=0, metavar="W",
                    help="the motion MLP as two hidden layers of W units")
    ap.add_argument("--depth", action="store_true",
                    help="the motion CNN also reads the given frame's depth image")
    ap.add_argument("--keypoints", action="store_true",
                    help="the motion MLP also reads the motion CNN's features' soft-argmax points")
    ap.add_argument("--template", type=int, default=0, metavar="T",
                    help="behind the frame's layers a layer learned for all episodes on a T x T "
                         "canvas, placed on each given frame by a head")
    ap.add_argument("--template-bias", type=float, default=-4.0,
                    help="the template's initial mask logit")
    ap.add_argument("--save", help="the trained net's state_dict (torch.save)")
    ap.add_argument("--load", help="a --save'd net: no training")
    ap.add_argument("--checkpoint", metavar="RUN_DIR",
                    help="a wm-motion run of kind layers: its weights and action statistics")
    ap.add_argument("--masks", metavar="PNG", help="the layers of val episodes 0-2")
    ap.add_argument("--linear", choices=("affine", "similarity", "scale"), default="affine",
                    help="what a step may do to a layer besides moving it")
    ap.add_argument("--fill-residual", action="store_true",
                    help="the fill is the given frame plus a learned correction")
    ap.add_argument("--follow", action="store_true",
                    help="a layer may follow another's motion, gated per step by the state")
    ap.add_argument("--follow-bias", type=float, default=-4.0, help="the gates' initial logit")
    ap.add_argument("--ceiling", action="store_true",
                    help="also score each val rollout with its maps fitted to the real frames")
    args = ap.parse_args()
    train, val, actions, norm = wp.setup(args)
    torch.set_flush_denormal(True)  # as wm-motion: saturated masks underflow
    if args.follow:
        net = FollowLayerNet(actions.shape[1], args.layers, args.channels, args.follow_bias,
                             linear=args.linear, fill_residual=args.fill_residual,
                             mask_bias=args.mask_bias, mask_noise=args.mask_noise)
    elif args.mlp_width:
        net = WideMlpLayerNet(actions.shape[1], args.layers, args.channels, args.mlp_width,
                              mask_bias=args.mask_bias, mask_noise=args.mask_noise)
    elif args.depth:
        net = DepthLayerNet(actions.shape[1], args.layers, args.channels,
                            mask_bias=args.mask_bias, mask_noise=args.mask_noise)
        net.depths = load_depths(args.train)
    elif args.keypoints:
        net = KeypointLayerNet(actions.shape[1], args.layers, args.channels,
                               mask_bias=args.mask_bias, mask_noise=args.mask_noise)
    elif args.template:
        net = TemplateLayerNet(actions.shape[1], args.layers, args.channels, args.template,
                               args.template_bias, mask_bias=args.mask_bias,
                               mask_noise=args.mask_noise)
    elif args.margin:
        net = MarginLayerNet(actions.shape[1], args.layers, args.channels, args.margin,
                             args.margin_replicate,
                             mask_bias=args.mask_bias, mask_noise=args.mask_noise)
    elif args.linear != "affine" or args.fill_residual:
        net = VariantLayerNet(actions.shape[1], args.layers, args.channels, args.linear,
                              args.fill_residual, mask_bias=args.mask_bias,
                              mask_noise=args.mask_noise)
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
    if args.depth:  # score() imagines each long enough val episode's logged, then reversed
        net.depths = load_depths(args.val)
        scored = [e for e, (f, _, _) in enumerate(val) if len(f) > args.score_from + 8]
        calls = iter(range(2 * len(scored)))

        def imagine(first, a, _):
            net.windows = [(scored[next(calls) // 2], args.score_from)]
            return net(first, a)
    else:
        def imagine(first, a, _):
            return net(first, a)
    with torch.no_grad():
        r, rows = wp.score(net, val, norm, imagine, args.score_from)
    trained = (args.checkpoint or args.load or
               f"{args.layers} layers, {args.channels} ch, {args.steps} steps, "
               f"unroll {args.unroll}, {seconds:.0f} s")
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
