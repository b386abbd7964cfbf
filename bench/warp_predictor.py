#!/usr/bin/python3
"""Issue 20, goal 2: the motion model's recipe on the demo's data, in Python, for experiments
before they reach wm-motion (docs/motion.md; docs/dynamics.md, "Stable tokens, the copy prior,
and arrival"). Trains the PyTorch twin of motion/warp_net.cc (tests/motion/warp_twin.py) on one
CPU thread and scores 8-step open-loop rollouts from frame 0 of val episodes 0..7 as
bench/dynamics_token_recipes.py scores token rollouts: PSNR and SSIM (copy_last's beside them),
PSNR minus the same rollout's with the actions reversed, arm / object MSE over copy_last's (mean
over steps, and at step 8).

  next = (1 - g) * warp(x_t, flow) + g * tanh(rgb),  flow = b + sum_i J_i a_i  (or b only)

  bench/warp_predictor.py --train data/demo/shards/train --val data/demo/shards/val \
      [--steps 600] [--unroll 1] [--channels 48] [--no-jacobian] [--strip OUT.png] \
      [--self-condition P] [--post-refine C] [--edge-loss W] [--flow-l1 W] [--seed S] \
      [--background-memory] [--retrace both|only [--pyramid-loss W]] [--gan W] [--splat] \
      [--max-lr LR] [--flow-target W] [--flow-report] [--photometric W] [--detach-flow] \
      [--gate-bias B] [--peek]

The last options are variants tried against the smear (docs/motion.md, "How the warp kind's
recipe was chosen"); none is in wm-motion: --self-condition P feeds the net, with probability P
per batch, its own (gradient-free) prediction of frame t as the current frame, as an imagined
rollout does;
--post-refine C adds a zero-initialised C-channel conv block that corrects the composited frame
from it and the decoder's features (it sees the warped result, so it could sharpen it);
--edge-loss W adds W times the L1 of the image-gradient difference (Mathieu et al. 2016);
--flow-l1 W adds W times the mean flow length in pixels (most of the scene is static, and on a
plain table the photometric loss leaves the flow of uniform regions free).
--background-memory is a change of model class, not of recipe: the real frame 0 as a third
source the net may copy per pixel (BackgroundMemoryNet). --retrace is WHALE's retracing rollout
for this model: frame 0 warped by a second flow linear in the retrace action (RetraceWarpNet),
beside the warped current frame ("both") or alone ("only"); --pyramid-loss W adds W times the
L1 of that warp at three blur levels, so a large flow gets a gradient on a plain table.
--gan W adds an adversarial loss (a PatchGAN critic of (current, next) pairs, as SAVP's) so the
predictor is pushed away from blurred means towards frames a real step could produce.
--flow-target W adds W times the L1 (px) between the predicted flow and OpenCV's DIS optical
flow measured on the real pair, enlarged 4x (bench/warp_oracle.py: warping by that flow alone
reaches the arm goal; DIS at 64 px does not).
--flow-report prints the flow's error on arm pixels against that DIS flow, with real and with
imagined frames as input.
--photometric W weighs the frames' L1 (0 with --flow-target: pure flow regression); --peek, a
diagnostic, gives the net the real next frame where it reads the previous one, so --flow-report
measures how well this U-Net outputs a flow it can see (its rollout scores mean nothing).
--detach-flow stops the frames' L1 at the flow: with --flow-target the flow learns from DIS's
alone and the photometric loss trains only the gate and the painted colour (and the trunk).
--gate-bias -20 shuts the gate (sigmoid(-20) ~ 2e-9, so it gets no gradient either): nothing
is painted, every frame is a pure warp of the last.
--splat moves the current frame's pixels forward (softmax splatting, SplatWarpNet) instead of
sampling it backward: the flow then belongs to the pixels that move.
"""
import argparse
import os
import sys
import time

import cv2
import numpy as np
import torch
from skimage.metrics import structural_similarity
from torch import nn
from torch.nn import functional as F

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "tests", "motion"))
import dynamics_token_recipes as recipes  # noqa: E402
import tokenizer_goal1 as goal1  # noqa: E402
import warp_twin  # noqa: E402

BATCH, LR, MIN_LR, WARMUP = 16, 1e-3, 1e-4, 50


def learning_rate(step, steps, peak=LR):  # trainkit::LearningRateAt: warmup, cosine to MIN_LR
    if step < WARMUP:
        return peak * (step + 1) / WARMUP
    progress = (step - WARMUP) / max(1, steps - WARMUP)
    return MIN_LR + 0.5 * (peak - MIN_LR) * (1 + np.cos(np.pi * progress))


def optimizer_step(net, opt, loss, step):
    """Backward, clip the gradient norm to 1 (trainkit's default), step; the loss every 100."""
    opt.zero_grad()
    loss.backward()
    nn.utils.clip_grad_norm_(net.parameters(), 1.0)
    opt.step()
    if step % 100 == 0:
        print(f"step {step} loss {loss.item():.4f}", flush=True)


def unet_features(net, inp, action, extra=0):
    """The twin's U-Net up to its head (warp_twin.WarpNet.forward's first lines): full-resolution
    features of the input frames with the action (and `extra` [B, C]) added at the bottleneck."""
    h1 = net.down1(inp)
    h2 = net.down2(h1)
    bottleneck = net.action_in(action) + extra
    u = net.up3(net.middle(net.down3(h2) + bottleneck[:, :, None, None]))
    return net.up1(torch.cat([net.up2(torch.cat([u, h2], 1)), h1], 1))


def head_outputs(net, out, action, own=0):
    """The twin's head channels in `out` (as warp_twin.WarpNet.forward reads them) -> flow in
    pixels, gate and painted colour; the last `own` channels are a variant's own, left out."""
    b, _, h, w = out.shape
    flow = out[:, warp_twin.FLOW_BIAS:warp_twin.JACOBIAN]
    if net.jacobian:
        jac = out[:, warp_twin.JACOBIAN:out.shape[1] - own].view(b, 2, net.action_dim, h, w)
        flow = flow + (jac * action.view(b, 1, net.action_dim, 1, 1)).sum(2)
    gate = torch.sigmoid(out[:, warp_twin.GATE:warp_twin.GATE + 1] + net.gate_bias)
    rgb = torch.tanh(out[:, warp_twin.RGB:warp_twin.RGB + 3])
    return flow * net.flow_scale, gate, rgb


class PostRefinedNet(warp_twin.WarpNet):
    """The twin plus a zero-initialised conv block that corrects the composited frame, reading it
    and the decoder's full-resolution features."""

    def __init__(self, model, action_dim, channels):
        super().__init__(model, action_dim)
        c = model["channels"]
        self.post = nn.Sequential(nn.Conv2d(c + 3, channels, 3, 1, 1), nn.ReLU(),
                                  nn.Conv2d(channels, 3, 3, 1, 1))
        nn.init.zeros_(self.post[2].weight)
        nn.init.zeros_(self.post[2].bias)

    def forward(self, current, previous, action):
        inp = torch.cat([current, previous], 1)
        u = unet_features(self, inp, action)
        flow, gate, rgb = head_outputs(self, self.head(torch.cat([u, inp], 1)), action)
        composite = (1 - gate) * warp_twin.warp(current, flow) + gate * rgb
        return composite + self.post(torch.cat([composite, u], 1)), flow, gate


class BackgroundMemoryNet(warp_twin.WarpNet):
    """The twin with a third source beside the warped current frame and the painted colour: the
    episode's real first frame, a memory of the static scene. The net also reads it (9 input
    channels) and outputs one more logit, a per-pixel choice of memory over warp:

      next = (1 - g) * ((1 - m) * warp(x_t, flow) + m * x_0) + g * tanh(rgb)

    Static things (table, goal disc, an untouched block) can then be copied from frame 0 at every
    step instead of being resampled from the last prediction, so they neither blur nor drag."""

    def __init__(self, model, action_dim):
        super().__init__(model, action_dim)
        c = model["channels"]
        self.down1 = warp_twin.down(9, c)
        extra = 2 * action_dim if self.jacobian else 0
        self.head = nn.Conv2d(c + 9, warp_twin.JACOBIAN + extra + 1, 3, 1, 1)
        nn.init.zeros_(self.head.weight)
        nn.init.zeros_(self.head.bias)

    def forward(self, current, previous, action, first):
        inp = torch.cat([current, previous, first], 1)
        out = self.head(torch.cat([unet_features(self, inp, action), inp], 1))
        flow, gate, rgb = head_outputs(self, out, action, own=1)
        memory = torch.sigmoid(out[:, -1:])
        kept = (1 - memory) * warp_twin.warp(current, flow) + memory * first
        return (1 - gate) * kept + gate * rgb, flow, gate


class RetraceWarpNet(BackgroundMemoryNet):
    """WHALE's retracing rollout (whale-x.txt Sec. 3.4) for a pixel model: beside the step's
    action a_t the net gets the retrace action r_t = retrace(a_0..a_t) (eq. 6: end-effector
    deltas summed, the last gripper command), which leads from the real frame 0 straight to
    frame t+1, and a second flow linear in it that samples frame 0:

      source0 = warp(x_0, b0 + sum_i J0_i r_t,i)          (one resampling of a real frame)
      next = (1 - g) * ((1 - m) * warp(x_t, flow) + m * source0) + g * tanh(rgb)   ("both")
      next = (1 - g) * source0 + g * tanh(rgb)                                     ("only")

    The imagined x_t still tells the net where things are now (so J0 can be read off the arm's
    current pixels); the pixels themselves come from the sharp real frame, so the arm need not
    be resampled once per step. "only" is the pure fast track: every frame one warp of x_0."""

    def __init__(self, model, action_dim, mode):
        super().__init__(model, action_dim)
        c, self.mode = model["channels"], mode
        self.retrace_in = nn.Linear(action_dim, c)
        self.extra0 = 2 + 2 * action_dim  # b0 and J0 after BackgroundMemoryNet's outputs
        self.head = nn.Conv2d(c + 9, self.head.out_channels + self.extra0, 3, 1, 1)
        nn.init.zeros_(self.head.weight)
        nn.init.zeros_(self.head.bias)

    def forward(self, current, previous, action, first, retrace):
        inp = torch.cat([current, previous, first], 1)
        out = self.head(torch.cat([unet_features(self, inp, action, self.retrace_in(retrace)),
                                   inp], 1))
        b, _, h, w = out.shape
        out, out0 = out[:, :-self.extra0], out[:, -self.extra0:]
        flow, gate, rgb = head_outputs(self, out, action, own=1)
        jac0 = out0[:, 2:].view(b, 2, self.action_dim, h, w)
        flow0 = out0[:, :2] + (jac0 * retrace.view(b, 1, self.action_dim, 1, 1)).sum(2)
        self.flow0 = flow0 * self.flow_scale  # for the pyramid loss
        source0 = warp_twin.warp(first, self.flow0)
        if self.mode == "only":
            kept = source0
        else:
            memory = torch.sigmoid(out[:, -1:])
            kept = (1 - memory) * warp_twin.warp(current, flow) + memory * source0
        return (1 - gate) * kept + gate * rgb, flow, gate


def forward_splat(image, flow, importance):
    """Softmax splatting (Niklaus and Liu 2020): each source pixel p of `image` [B, C, S, S] is
    moved to p + flow(p) and spread bilinearly over the 4 nearest target pixels, weighted by
    exp(importance(p)) so that where several land on one pixel the more important one wins
    (the arm over the table it passes). Returns the splatted image and its coverage [B, 1, S, S]
    (the bilinear weights landing on each target, at most 1: 0 where nothing arrived)."""
    b, c, h, w = image.shape
    xs = torch.arange(w, dtype=image.dtype).view(1, 1, w) + flow[:, 0]
    ys = torch.arange(h, dtype=image.dtype).view(1, h, 1) + flow[:, 1]
    x0, y0 = xs.floor(), ys.floor()
    fx, fy = xs - x0, ys - y0
    weight = torch.exp(importance.clamp(-10, 10)).view(b, 1, -1)
    num = image.new_zeros(b, c, h * w)
    den = image.new_zeros(b, 1, h * w)
    cover = image.new_zeros(b, 1, h * w)
    for dx, dy, bilinear in ((0, 0, (1 - fx) * (1 - fy)), (1, 0, fx * (1 - fy)),
                             (0, 1, (1 - fx) * fy), (1, 1, fx * fy)):
        tx, ty = x0 + dx, y0 + dy
        inside = ((tx >= 0) & (tx < w) & (ty >= 0) & (ty < h)).to(image.dtype)
        index = (ty.clamp(0, h - 1) * w + tx.clamp(0, w - 1)).long().view(b, 1, -1)
        share = (bilinear * inside).view(b, 1, -1)
        num.scatter_add_(2, index.expand(b, c, -1), image.view(b, c, -1) * share * weight)
        den.scatter_add_(2, index, share * weight)
        cover.scatter_add_(2, index, share)
    splat = num / den.clamp(min=1e-6)
    return splat.view(b, c, h, w), cover.clamp(max=1).view(b, 1, h, w)


class SplatWarpNet(warp_twin.WarpNet):
    """The twin with a forward warp instead of a backward one: the flow is defined on the
    current frame's pixels (where each one goes), so the arm's flow is the arm's own motion and
    its discontinuity sits on the arm's visible edge, not on the edge of where the arm will be,
    which a backward flow must guess (and smooths over, dragging the disc and block along). One
    more head channel is the splatting importance; holes (what the arm uncovers) take the
    painted colour:

      next = (1 - g) * (cover * splat(x_t, flow, z) + (1 - cover) * tanh(rgb)) + g * tanh(rgb)

    At zero init every pixel lands on itself with cover 1: the twin's copy-last start."""

    def __init__(self, model, action_dim):
        super().__init__(model, action_dim)
        c = model["channels"]
        self.head = nn.Conv2d(c + 6, self.head.out_channels + 1, 3, 1, 1)
        nn.init.zeros_(self.head.weight)
        nn.init.zeros_(self.head.bias)

    def forward(self, current, previous, action):
        inp = torch.cat([current, previous], 1)
        out = self.head(torch.cat([unet_features(self, inp, action), inp], 1))
        flow, gate, rgb = head_outputs(self, out, action, own=1)
        splat, cover = forward_splat(current, flow, out[:, -1:])
        return (1 - gate) * (cover * splat + (1 - cover) * rgb) + gate * rgb, flow, gate


def retrace_actions(raw, norm):
    """[T, D] raw actions -> [T, D] retrace actions r_t = retrace(a_0..a_t), scaled like the
    actions: summed deltas divided by the actions' std (no mean: a sum of n means is not a
    mean), the last (gripper) dimension normalised as the step's own action is."""
    normed = norm(raw)
    scale = norm(np.ones_like(raw[:1])) - norm(np.zeros_like(raw[:1]))  # 1 / std per dim
    out = np.cumsum(raw, 0) * scale
    out[:, -1] = normed[:, -1]
    return out.astype(np.float32)


def predict_next(net, current, previous, action, first, retrace=None):
    """One predicted frame; `first` (the real frame 0) reaches only a BackgroundMemoryNet, the
    retrace action only a RetraceWarpNet."""
    if isinstance(net, RetraceWarpNet):
        return net(current, previous, action, first, retrace)
    if isinstance(net, BackgroundMemoryNet):
        return net(current, previous, action, first)
    return net(current, previous, action)


@torch.no_grad()
def imagine(net, first, actions, retraces=None):
    """warp_twin.imagine through predict_next(): open-loop frames after `first`."""
    current = previous = first
    frames = []
    for h in range(actions.shape[1]):
        r = None if retraces is None else retraces[:, h]
        nxt = predict_next(net, current, previous, actions[:, h], first, r)[0].clamp(-1, 1)
        frames.append(nxt)
        previous, current = current, nxt
    return torch.stack(frames, 1)


def batch(episodes, norm, rng, unroll, start_fraction=0.0, start_span=0):
    """[B, unroll + 3, 3, S, S] windows (frames t-2, t-1, t, t+1..t+unroll, indices clamped at
    0), the normalised actions a_{t-1}..a_{t+unroll-1} (a_0 again at t = 0), whether t > 0,
    the episodes' frames 0 [B, 3, S, S], the retrace actions r_{t-1}..r_{t+unroll-1} and the
    windows' (episode, t). Episodes of at most `unroll` frames hold no window and are skipped,
    as wm-motion's WindowSampler skips them (the same draws when none is that short)."""
    clips, actions, later, firsts, retraces, where = [], [], [], [], [], []
    long_enough = [e for e, (frames, _, _) in enumerate(episodes) if len(frames) > unroll]
    for _ in range(BATCH):
        e = long_enough[int(rng.integers(len(long_enough)))]
        frames, _, acts = episodes[e]
        t = int(rng.integers(len(frames) - unroll))
        if start_fraction > 0 and rng.random() < start_fraction:  # an episode's first frames
            t = int(rng.integers(min(start_span or unroll, len(frames) - unroll)))
        where.append((e, t))
        clips.append(frames[[max(t - 2, 0), max(t - 1, 0)] + list(range(t, t + unroll + 1))])
        steps = [max(t - 1, 0)] + list(range(t, t + unroll))
        actions.append(norm(acts[steps]))
        retraces.append(retrace_actions(acts[:t + unroll], norm)[steps])
        later.append(t > 0)
        firsts.append(frames[0])
    return (torch.stack(clips), torch.tensor(np.stack(actions)), torch.tensor(later),
            torch.stack(firsts), torch.tensor(np.stack(retraces)), where)


def backward_flow(target, source, upscale):
    """[2, S, S] flow (px) on `target`'s pixels to where they are in `source` (uint8 levels,
    HWC), by OpenCV's DIS optical flow on the frames enlarged `upscale` times (at 64 px it
    misses the arm's motion: bench/warp_oracle.py)."""
    def gray(x):
        g = cv2.cvtColor(x.astype(np.uint8), cv2.COLOR_RGB2GRAY)
        return cv2.resize(g, None, fx=upscale, fy=upscale, interpolation=cv2.INTER_CUBIC)
    dis = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)
    flow = dis.calc(gray(target), gray(source), None)
    flow = cv2.resize(flow, target.shape[1::-1], interpolation=cv2.INTER_AREA) / upscale
    return torch.from_numpy(flow.transpose(2, 0, 1).copy())


def step_flows(frames, upscale=4):
    """[T - 1, 2, S, S]: the backward flow of each step t -> t+1 of `frames` ([T, 3, S, S] in
    [-1, 1]) on frame t+1."""
    real = goal1.to_uint8(frames)
    return torch.stack([backward_flow(real[t + 1], real[t], upscale)
                        for t in range(len(real) - 1)])


def edge_l1(a, b):
    """L1 between the horizontal and vertical differences of a and b."""
    def dx(z):
        return z[..., :, 1:] - z[..., :, :-1]

    def dy(z):
        return z[..., 1:, :] - z[..., :-1, :]
    return (dx(a) - dx(b)).abs().mean() + (dy(a) - dy(b)).abs().mean()


def box_blur(z, radius):
    """Two box filters of width 2 radius + 1 (about a Gaussian of sigma 0.8 radius), edges
    repeated."""
    for _ in range(2):
        z = F.avg_pool2d(F.pad(z, [radius] * 4, mode="replicate"), 2 * radius + 1, stride=1)
    return z


def pyramid_loss(net, first, target):
    """L1 of frame 0 warped by the retrace flow against the target, both blurred at radii
    2, 4, 8: a warp's gradient is the source's spatial gradient where the flow points, zero on
    a plain table, so a large flow starting from 0 gets no signal at full resolution; blurred
    copies spread the arm's edges far enough to pull the flow from afar (coarse-to-fine)."""
    loss = 0
    for radius in (2, 4, 8):
        warped = warp_twin.warp(box_blur(first, radius), net.flow0)
        loss = loss + (warped - box_blur(target, radius)).abs().mean() / 3
    return loss


class Critic(nn.Module):
    """A PatchGAN critic of (current, next) frame pairs, as SAVP's (Lee et al. 2018, stochastic
    adversarial video prediction, on robot pushing): [B, 1, S/8, S/8] hinge logits, spectral
    norm for stability. Under L1 alone the predictor paints the mean of what it is unsure of (the
    blur); the critic penalises frames that no real step would produce."""

    def __init__(self, channels=32):
        super().__init__()
        sn, c = nn.utils.spectral_norm, channels
        self.net = nn.Sequential(
            sn(nn.Conv2d(6, c, 4, 2, 1)), nn.LeakyReLU(0.2), sn(nn.Conv2d(c, 2 * c, 4, 2, 1)),
            nn.LeakyReLU(0.2), sn(nn.Conv2d(2 * c, 4 * c, 4, 2, 1)), nn.LeakyReLU(0.2),
            sn(nn.Conv2d(4 * c, 1, 3, 1, 1)))

    def forward(self, current, nxt):
        return self.net(torch.cat([current, nxt], 1))


def critic_step(critic, opt, pairs):
    """One hinge-loss step of the critic on (current, real next, imagined next) triples."""
    opt.zero_grad()
    loss = 0
    for current, real, fake in pairs:
        loss = loss + (F.relu(1 - critic(current, real)).mean() +
                       F.relu(1 + critic(current, fake)).mean()) / len(pairs)
    loss.backward()
    opt.step()


def fit(net, episodes, norm, steps, args):
    flows = [step_flows(f) for f, _, _ in episodes] if args.flow_target > 0 else None
    opt = torch.optim.AdamW(net.parameters(), LR, betas=(0.9, 0.9), weight_decay=0.01)
    critic = Critic() if args.gan > 0 else None
    critic_opt = (torch.optim.Adam(critic.parameters(), 2e-4, betas=(0.5, 0.999))
                  if critic is not None else None)
    rng = np.random.default_rng(args.seed)
    unroll = args.unroll
    for step in range(steps):
        for group in opt.param_groups:
            group["lr"] = learning_rate(step, steps, args.max_lr)
        clips, actions, later, first, retraces, where = batch(episodes, norm, rng, unroll)
        previous, current, loss, pairs = clips[:, 1], clips[:, 2], 0, []
        if args.self_condition > 0 and rng.random() < args.self_condition:
            with torch.no_grad():  # frame t as imagined from t-1 (kept real where t = 0)
                imagined = predict_next(net, clips[:, 1], clips[:, 0], actions[:, 0], first,
                                        retraces[:, 0])[0]
            imagined = imagined.clamp(-1, 1)
            current = torch.where(later.view(-1, 1, 1, 1), imagined, current)
        for u in range(unroll):
            if args.peek:  # the answer in place of the previous frame (a diagnostic)
                previous = clips[:, u + 3]
            predicted, flow, gate = predict_next(net, current, previous, actions[:, u + 1],
                                                 first, retraces[:, u + 1])
            if args.detach_flow:  # same frame, no photometric gradient into the flow
                predicted = predicted - (1 - gate) * (warp_twin.warp(current, flow) -
                                                      warp_twin.warp(current, flow.detach()))
            loss = loss + args.photometric * (predicted - clips[:, u + 3]).abs().mean() / unroll
            if args.flow_l1 > 0:
                loss = loss + args.flow_l1 * flow.norm(dim=1).mean() / unroll
            if args.flow_target > 0:  # the measured flow of step t+u -> t+u+1
                target = torch.stack([flows[e][t + u] for e, t in where])
                loss = loss + args.flow_target * (flow - target).abs().mean() / unroll
            if critic is not None:
                loss = loss - args.gan * critic(current.detach(), predicted).mean() / unroll
                pairs.append((current.detach(), clips[:, u + 3], predicted.detach()))
            if args.pyramid_loss > 0:
                loss = loss + args.pyramid_loss * pyramid_loss(net, first, clips[:, u + 3]) / unroll
            if args.edge_loss > 0:
                loss = loss + args.edge_loss * edge_l1(predicted, clips[:, u + 3]) / unroll
            previous, current = current, predicted
        opt.zero_grad()
        loss.backward()
        nn.utils.clip_grad_norm_(net.parameters(), 1.0)
        opt.step()
        if critic is not None:
            critic_step(critic, critic_opt, pairs)


@torch.no_grad()
def flow_report(net, episodes, norm, peek=False):
    """Mean end-point error (px) of the net's flow against DIS's (4x) of the real step, on the
    next frame's arm pixels, over val episodes 0..ROLLOUTS-1 and steps 0..HORIZON-1: with the
    real frames as input (teacher-forced) and along the open-loop rollout (imagined input);
    and the measured flow's mean length there. `peek`: the net was trained with the real next
    frame as its previous frame (--peek), so it gets it here too, teacher-forced only."""
    H, err, length = recipes.HORIZON, {"teacher_forced": [], "imagined": []}, []

    def end_point_error(out, target, arm):
        return float((out[1][0] - target).norm(dim=0)[arm].mean())
    for frames, seg, acts in episodes[:recipes.ROLLOUTS]:
        targets = step_flows(frames[:H + 1])
        a = torch.tensor(norm(acts[:H]))
        imagined = [frames[0:1], frames[0:1]]  # previous, current
        for t, target in enumerate(targets):
            arm = torch.from_numpy(seg[t + 1] == 1)
            if not arm.any():
                continue
            length.append(float(target.norm(dim=0)[arm].mean()))
            given = frames[t + 1] if peek else frames[max(t - 1, 0)]
            real_in = predict_next(net, frames[t][None], given[None], a[t:t + 1], frames[0:1])
            err["teacher_forced"].append(end_point_error(real_in, target, arm))
            if peek:
                continue
            own_in = predict_next(net, imagined[1], imagined[0], a[t:t + 1], frames[0:1])
            err["imagined"].append(end_point_error(own_in, target, arm))
            imagined = [imagined[1], own_in[0].clamp(-1, 1)]
    return ", ".join(f"{n} {np.mean(v):.2f} px" for n, v in err.items() if v) + \
        f" (measured flow {np.mean(length):.2f} px)"


def psnr(a, b):
    return 10 * np.log10(255.0 ** 2 / max(1e-10, float(np.mean((a - b) ** 2))))


def scores(real, pred, seg):
    arm = goal1.region_mse(real, pred, seg, 1)
    return {"psnr": np.mean([psnr(a, b) for a, b in zip(real, pred)]),
            "ssim": np.mean([structural_similarity(a, b, channel_axis=2, data_range=255)
                             for a, b in zip(real, pred)]),
            "arm": np.nanmean(arm), "arm8": arm[-1],
            "obj": np.nanmean(goal1.region_mse(real, pred, seg, 2))}


def window_scores(frames, seg, preds):
    """scores() of each of `preds` ({name: uint8 [H, S, S, 3] imagined from frames[0]}) and of
    copy_last against the real frames 1..H -> (those real frames, {name: scores})."""
    h = len(next(iter(preds.values())))
    real = goal1.to_uint8(frames[1:h + 1])
    preds = dict(preds, copy_last=np.repeat(goal1.to_uint8(frames[:1]), h, 0))
    return real, {name: scores(real, p, seg[1:h + 1]) for name, p in preds.items()}


def score(net, episodes, norm, imagine_fn=None, start=0):
    """Means over val episodes 0..ROLLOUTS-1 of scores() for the net's rollout from frame
    `start` under the logged and the reversed actions and for copy_last, and strip rows of
    episodes 0-2. `imagine_fn(first, actions, retraces)`, when given, replaces
    imagine(net, ...). Episodes too short for the horizon from `start` are left out."""
    H = recipes.HORIZON
    imagine_fn = imagine_fn or (lambda first, a, r: imagine(net, first, a, r))
    found = {k: [] for k in ("model", "reversed", "copy_last")}
    rows = []
    long_enough = [e for e in episodes if len(e[0]) > start + H]
    for k in range(min(recipes.ROLLOUTS, len(long_enough))):
        frames, seg, acts = (x[start:] for x in long_enough[k])
        runs = {}
        for name, raw in (("model", acts[:H]), ("reversed", acts[:H][::-1].copy())):
            runs[name] = (torch.tensor(norm(raw))[None],
                          torch.tensor(retrace_actions(raw, norm))[None])
        preds = {name: goal1.to_uint8(imagine_fn(frames[:1], a, r)[0])
                 for name, (a, r) in runs.items()}
        real, scored = window_scores(frames, seg, preds)
        for name, s in scored.items():
            found[name].append(s)
        if k < 3:
            rows += [np.concatenate(list(r), 1) for r in (real, preds["model"], preds["reversed"])]
    return means(found), rows


def means(found):
    """{rollout: [scores() per episode]} -> {rollout: {metric: mean over episodes}}."""
    return {n: {m: float(np.nanmean([s[m] for s in v])) for m in v[0]} for n, v in found.items()}


def main():
    ap = arguments(__doc__, steps=600, unroll=1, channels=48)
    ap.add_argument("--no-jacobian", action="store_true",
                    help="action added at the bottleneck only")
    ap.add_argument("--self-condition", type=float, default=0, metavar="P")
    ap.add_argument("--post-refine", type=int, default=0, metavar="C")
    ap.add_argument("--edge-loss", type=float, default=0, metavar="W")
    ap.add_argument("--flow-l1", type=float, default=0, metavar="W")
    ap.add_argument("--flow-report", action="store_true",
                    help="the flow's error on arm pixels against DIS's, real and imagined input")
    ap.add_argument("--flow-target", type=float, default=0, metavar="W",
                    help="W times the L1 (px) between the flow and DIS's on 4x enlarged frames")
    ap.add_argument("--photometric", type=float, default=1, metavar="W",
                    help="weight of the L1 between imagined and real frames (0: flow target only)")
    ap.add_argument("--detach-flow", action="store_true",
                    help="the flow learns from --flow-target only; the frames' L1 trains the "
                    "gate and painted colour (twin's WarpNet only)")
    ap.add_argument("--gate-bias", type=float, default=-3.0, metavar="B",
                    help="the gate's logit offset (-20: nothing painted, a pure warp)")
    ap.add_argument("--peek", action="store_true",
                    help="diagnostic: the real next frame replaces the previous one as input, so "
                    "--flow-report measures how well the net can output a flow it is shown")
    ap.add_argument("--background-memory", action="store_true",
                    help="a third source: the real frame 0, chosen per pixel (BackgroundMemoryNet)")
    ap.add_argument("--retrace", choices=("both", "only"),
                    help="frame 0 warped by a flow linear in the retrace action (RetraceWarpNet)")
    ap.add_argument("--pyramid-loss", type=float, default=0, metavar="W",
                    help="with --retrace: W times the blurred-pyramid L1 of frame 0's warp")
    ap.add_argument("--splat", action="store_true",
                    help="a forward warp (softmax splatting) instead of the backward one")
    ap.add_argument("--gan", type=float, default=0, metavar="W",
                    help="W times a PatchGAN critic's hinge loss on the imagined frames (Critic)")
    args = ap.parse_args()
    if args.detach_flow and (args.retrace or args.background_memory or args.splat or
                             args.post_refine):
        ap.error("--detach-flow rewrites the twin's composite: the plain WarpNet only")
    train, val, actions, norm = setup(args)
    model = {"channels": args.channels, "flow_scale": 4.0, "gate_bias": args.gate_bias,
             "action_jacobian": not args.no_jacobian}
    if args.retrace:
        net = RetraceWarpNet(model, actions.shape[1], args.retrace)
    elif args.background_memory:
        net = BackgroundMemoryNet(model, actions.shape[1])
    elif args.splat:
        net = SplatWarpNet(model, actions.shape[1])
    elif args.post_refine:
        net = PostRefinedNet(model, actions.shape[1], args.post_refine)
    else:
        net = warp_twin.WarpNet(model, actions.shape[1])
    start = time.time()
    fit(net, train, norm, args.steps, args)
    seconds = time.time() - start
    r, rows = score(net.eval(), val, norm)
    print(f"warp predictor ({'additive action' if args.no_jacobian else 'action Jacobian'}, "
          f"{args.channels} ch), {args.steps} steps, unroll {args.unroll}, {seconds:.0f} s: "
          f"{summary(r)}")
    if args.strip:
        write_strip(args.strip, rows)
    if args.flow_report:
        print("flow error on arm pixels against DIS (4x):",
              flow_report(net, val, norm, args.peek))


def arguments(doc, steps, unroll, channels):
    """The options every predictor script here takes, with its own defaults."""
    ap = argparse.ArgumentParser(description=doc.split("\n")[0])
    ap.add_argument("--train", required=True)
    ap.add_argument("--val", required=True)
    ap.add_argument("--steps", type=int, default=steps)
    ap.add_argument("--unroll", type=int, default=unroll)
    ap.add_argument("--channels", type=int, default=channels)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--max-lr", type=float, default=LR, help="peak learning rate")
    ap.add_argument("--strip", help="PNG: real, predicted, reversed-actions rows, val episodes 0-2")
    return ap


def setup(args):
    """One thread, args.seed; -> (train, val episodes as recipes.load gives them, the training
    actions [n, D], the action normaliser fitted on them)."""
    torch.set_num_threads(1)
    torch.manual_seed(args.seed)
    train, val = recipes.load(args.train), recipes.load(args.val)
    actions = np.concatenate([a for _, _, a in train])
    mean, std = actions.mean(0), actions.std(0)
    std[std < 1e-6] = 1

    def norm(a):
        return ((a - mean) / std).astype(np.float32)
    return train, val, actions, norm


def summary(r, name="model"):
    """score()'s means as the docs' columns for rollout `name`: PSNR and SSIM beside
    copy_last's, controllability (when r has the "reversed" rollout), arm and object MSE over
    copy_last's."""
    m, c = r[name], r["copy_last"]
    control = (f"PSNR - reversed actions' {m['psnr'] - r['reversed']['psnr']:+.2f}, "
               if "reversed" in r else "")
    return (f"PSNR {m['psnr']:.2f} (copy_last {c['psnr']:.2f}), SSIM {m['ssim']:.3f} "
            f"({c['ssim']:.3f}),\n  {control}"
            f"arm / copy_last {m['arm'] / c['arm']:.2f} (step 8: {m['arm8'] / c['arm8']:.2f}), "
            f"object / copy_last {m['obj'] / c['obj']:.2f}")


def write_strip(path, rows):
    """Strip rows ([S, n*S, 3] uint8 levels, RGB) stacked, doubled in size, as a PNG."""
    img = np.concatenate(rows, 0).clip(0, 255).astype(np.uint8)[..., ::-1]
    cv2.imwrite(path, cv2.resize(img, None, fx=2, fy=2, interpolation=cv2.INTER_NEAREST))


if __name__ == "__main__":
    main()
