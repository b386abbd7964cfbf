#!/usr/bin/python3
"""Issue 20, goal 1: can the anchor's flow be taught to move the arm, not just nudge it?

In `tiny` (model.anchor_flow, docs/tokenizer.md "An anchor that moves") the learned flow stays
under a pixel: its largest displacement over a rollout's frames is 0.9 px, while the arm moves
5-30 px in 8 steps. So the anchor's arm is never moved to where the arm went; the codes redraw
it, blurred. Two label-free teachers, each an extra loss on the same flow, trained with the
PyTorch twin (tests/tokenize/vqvae_twin.py) exactly as bench/tokenizer_anchor_flow.py trains
`tiny` (its `flow_change4` variant, the shipped recipe) and scored the same way, paired:

  blur W     W x L1 between the anchor moved by the flow and the frame, both blurred (two passes
             of a k x k box, k = 5, 9 and 17, averaged): resampling a blurred image has a
             gradient that reaches across ten pixels, where the sharp frame's reaches one;
  dis W      W x L1 (pixels) between the flow (upsampled to the frame) and OpenCV's DIS optical
             flow from the frame to its anchor (preset medium, grey levels): a dense target;
  deep       the flow read by four dilated convolutions instead of one (deep_flow_head), with no
             teacher or with dis 0.02: a probe on the demo tokenizer's frozen features regressed
             DIS's flow no better than zero with one convolution, and part of the way with these.

Both only where the anchor is real (not blank). The largest flow (max over pixels of |flow|,
mean over the first 60 scored episodes' frames) is printed beside the scores.

  bench/tokenizer_flow_teachers.py --train TRAIN --val VAL --variants base blur1 dis0.02 \
      --seeds 1 2 [--steps 2400] [--jobs 2]

--show RUN_DIR scores a finished C++ run instead (loaded into the twin): where its block error
is (the fifth of episodes where copying's is largest against the rest; frames grouped by
copying's block error), its largest flow, and
--strip PNG: for the 2 episodes where copying's block error is largest, steps 1-8 as rows of
real frames, reconstructions (own tokens, real frame 0 as anchor), copy_last, and 3x the
reconstruction's absolute error.

  bench/tokenizer_flow_teachers.py --val VAL --show RUN_DIR [--strip PNG]

--probe RUN_DIR fits flow heads alone to DIS's flow on the run's frozen merged features (pairs
from --train, scored on --val): whether the shipped head could read a far flow at all.

  bench/tokenizer_flow_teachers.py --probe RUN_DIR --train HELDOUT --val VAL
"""
import argparse
import math
import os
import sys
import time

import cv2
import numpy as np
import torch
import torch.nn.functional as F

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import tokenizer_anchor as anchor_bench  # noqa: E402
import tokenizer_anchor_flow as flow_bench  # noqa: E402
import tokenizer_goal1 as goal1  # noqa: E402
from tokenizer_goal1 import twin  # noqa: E402

RECIPE = {**flow_bench.TINY, **flow_bench.VARIANTS["flow_change4"]}  # the shipped `tiny`
VARIANTS = {"base": ("none", 0.0), "blur1": ("blur", 1.0), "dis0.02": ("dis", 0.02),
            "dis0.1": ("dis", 0.1), "deep": ("none", 0.0), "deep_dis0.02": ("dis", 0.02),
            "deep_dis0.1": ("dis", 0.1)}
BOXES = (5, 9, 17)
DATA = None  # (train episodes, val episodes), set before the workers fork


def blur(x, k):
    for _ in range(2):  # two box passes: a tent, smoother than one box
        x = F.avg_pool2d(x, k, stride=1, padding=k // 2, count_include_pad=False)
    return x


def dis_flow(images, anchors):
    """[B, 2, S, S] (x, y in pixels): where each pixel of `images` is in `anchors` (DIS)."""
    dis = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)

    def grey(x):
        levels = goal1.to_uint8(x.detach()).astype(np.uint8)
        return [cv2.cvtColor(np.ascontiguousarray(f), cv2.COLOR_RGB2GRAY) for f in levels]
    flows = [dis.calc(a, b, None) for a, b in zip(grey(images), grey(anchors))]
    return torch.from_numpy(np.stack(flows)).permute(0, 3, 1, 2).float()


def deep_flow_head(channels):
    """Four 3x3 convolutions, dilated 1, 2, 4, 1 (a 15 x 15 cell field, 60 pixels, against the
    single convolution's 3 x 3), the last zero-initialised so the flow starts at 0."""
    last = torch.nn.Conv2d(channels, 2, 3, padding=1)
    with torch.no_grad():
        last.weight.zero_()
        last.bias.zero_()
    layers = []
    for dilation in (1, 2, 4):
        layers += [torch.nn.Conv2d(channels, channels, 3, padding=dilation, dilation=dilation),
                   torch.nn.ReLU()]
    return torch.nn.Sequential(*layers, last)


class TaughtFlow(twin.VqVae):
    """The twin's anchored tokenizer with one of the teachers' terms added to its loss; variants
    named deep* read the flow with deep_flow_head instead of one convolution."""

    def __init__(self, config, teacher, weight, deep=False):
        super().__init__(config)
        self.teacher, self.weight, self.flow = teacher, weight, None
        if deep:
            self.anchor_flow = deep_flow_head(self.anchor_flow.in_channels)
        # The twin's decode, unchanged, leaves its last flow here for the loss and largest_flow.
        self.anchor_flow.register_forward_hook(lambda _, __, flow: setattr(self, "flow", flow))

    def forward(self, images, anchors=None):
        out = super().forward(images, anchors)
        if self.teacher == "none":
            return out
        real = (anchors.abs().amax((1, 2, 3), keepdim=True) > 0).float()
        if self.teacher == "blur":
            term = sum(((twin.move_by_flow(blur(anchors, k), self.flow) - blur(images, k)).abs()
                        * real).mean() for k in BOXES) / len(BOXES)
        else:
            flow = F.interpolate(self.flow, size=images.shape[-2:], mode="bilinear",
                                 align_corners=False)
            term = ((flow - dis_flow(images, anchors)).abs() * real).mean()
        out["loss"] = out["loss"] + self.weight * term
        return out


@torch.no_grad()
def largest_flow(model, episodes):
    tops = []
    for frames, _ in episodes[:60]:
        codes = twin.encode(model, frames)[1:anchor_bench.HORIZON + 1]
        model.decode(model.quantizer.lookup(codes), frames[:1].expand(len(codes), -1, -1, -1))
        tops.append(model.flow.norm(dim=1).amax().item())
    return float(np.mean(tops))


def run(job):
    variant, seed, steps = job
    torch.set_num_threads(1)
    start = time.time()
    model, _ = anchor_bench.train(RECIPE, steps, flow_bench.DROPOUT, DATA[0], seed,
                                  build=lambda c: TaughtFlow(c, *VARIANTS[variant],
                                                             variant.startswith("deep")))
    return job, time.time() - start, flow_bench.per_episode(model, DATA[1]), \
        largest_flow(model, DATA[1])


def frame_block_errors(model, episodes):
    """Block-region MSE of every scored frame (steps 1..8 where the block shows): (recon, copy)."""
    recon_errors, copy_errors = [], []
    for frames, seg in episodes:
        _, real, recon, copy = flow_bench.scored_frames(model, frames)
        recon_errors += goal1.region_mse(real, recon, seg[1:len(real) + 1], 2)
        copy_errors += goal1.region_mse(real, copy, seg[1:len(real) + 1], 2)
    recon_errors, copy_errors = np.array(recon_errors), np.array(copy_errors)
    shown = ~np.isnan(copy_errors)
    return recon_errors[shown], copy_errors[shown]


def print_block_buckets(recon, copy):
    """Frames grouped by copy_last's block error: each group's share of copying's total block
    error, and the reconstructions' error there as a share of the same total."""
    print("| copy_last's block MSE | frames | copy_last's share | reconstructions' share |")
    print("|---|---|---|---|")
    for lo, hi in ((0, 100), (100, 1000), (1000, 5000), (5000, math.inf)):
        k = (copy >= lo) & (copy < hi)
        print(f"| [{lo}, {hi}) | {k.sum()} | {copy[k].sum() / copy.sum():.3f} | "
              f"{recon[k].sum() / copy.sum():.3f} |")


def show(run_dir, val, strip):
    loaded, config, _ = twin.load_checkpoint(run_dir)
    model = TaughtFlow(twin.model_config(config), "none", 0.0)  # keeps its flow to measure
    model.load_state_dict(loaded.state_dict())
    rows = flow_bench.per_episode(model, val)
    copy_block, block = np.nan_to_num(rows[:, 5]), np.nan_to_num(rows[:, 4])
    order = np.argsort(-copy_block)
    top, rest = order[:len(order) // 5], order[len(order) // 5:]
    print(f"{run_dir}: block / copy_last {flow_bench.ratio(rows, 4):.3f}, arm / copy_last "
          f"{flow_bench.ratio(rows, 2):.3f}, largest flow {largest_flow(model, val):.2f} px")
    print(f"the fifth of episodes where copying's block error is largest: "
          f"{copy_block[top].sum() / copy_block.sum():.0%} of copying's block error, "
          f"{block[top].sum() / block.sum():.0%} of the reconstructions'; block / copy_last "
          f"{block[top].sum() / copy_block[top].sum():.2f} there, "
          f"{block[rest].sum() / copy_block[rest].sum():.2f} in the rest")
    print_block_buckets(*frame_block_errors(model, val))
    if not strip:
        return
    panels = []
    for e in order[:2]:
        _, real, rec, copy = flow_bench.scored_frames(model, val[e][0])
        error = np.repeat(np.abs(real - rec).mean(-1, keepdims=True), 3, -1) * 3
        panels += [real, rec, copy, error]
    flow_bench.write_strip(strip, panels)
    print(f"wrote {strip} (episodes {order[0]} and {order[1]})")


def probe(run_dir, train, val, steps=800):
    """Can the flow be read off a finished run's frozen merged features? Heads (one 3x3
    convolution as shipped; deep_flow_head) trained alone to regress DIS's flow (L1, Adam 2e-3,
    batches of 16 (frame t in 1..8, its frame 0) from `train`), scored on 128 pairs of `val`."""
    model, _, _ = twin.load_checkpoint(run_dir)
    model.requires_grad_(False)

    def pairs(episodes, n, rng):
        chosen = [episodes[rng.integers(len(episodes))][0] for _ in range(n)]
        steps_ = [int(rng.integers(1, min(anchor_bench.HORIZON + 1, len(f)))) for f in chosen]
        return (torch.stack([f[t] for f, t in zip(chosen, steps_)]),
                torch.stack([f[0] for f in chosen]))

    @torch.no_grad()
    def merged(x, a):
        z_q = model.quantizer(model.encoder(x))["z_q"]
        return model.merge(torch.cat([model.decoder(z_q), model.anchor_stem(a)], 1))

    def full(flow):
        return F.interpolate(flow, size=(64, 64), mode="bilinear", align_corners=False)
    torch.manual_seed(0)
    vx, va = pairs(val, 128, np.random.default_rng(1))
    target, features = dis_flow(vx, va), merged(vx, va)
    print(f"mean |DIS flow| {target.abs().mean():.2f} px; L1 to the frame: copy_last "
          f"{(va - vx).abs().mean():.3f}, the anchor moved by DIS's flow "
          f"{(twin.move_by_flow(va, target) - vx).abs().mean():.3f}")
    channels = model.anchor_flow.in_channels
    for name, head in (("one 3x3 convolution", torch.nn.Conv2d(channels, 2, 3, padding=1)),
                       ("deep_flow_head", deep_flow_head(channels))):
        opt, rng = torch.optim.Adam(head.parameters(), 2e-3), np.random.default_rng(0)
        for _ in range(steps):
            x, a = pairs(train, 16, rng)
            loss = (full(head(merged(x, a))) - dis_flow(x, a)).abs().mean()
            opt.zero_grad()
            loss.backward()
            opt.step()
        with torch.no_grad():
            flow = full(head(features))
            print(f"{name}: flow L1 to DIS {(flow - target).abs().mean():.2f} px, largest "
                  f"{flow.norm(dim=1).amax():.1f} px, the anchor moved by it: L1 to the frame "
                  f"{(twin.move_by_flow(va, flow) - vx).abs().mean():.3f}")


def main():
    global DATA
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    flow_bench.add_run_arguments(ap, VARIANTS, ["base", "blur1", "dis0.02"], [1, 2])
    ap.add_argument("--show", metavar="RUN_DIR", help="score this wm-tokenize run instead")
    ap.add_argument("--strip", metavar="PNG", help="with --show: the two worst episodes' strip")
    ap.add_argument("--probe", metavar="RUN_DIR",
                    help="fit flow heads to DIS's flow on this run's frozen features (--train "
                         "gives the pairs, --val scores them)")
    args = ap.parse_args()
    if args.show:
        return show(args.show, goal1.load(args.val, True), args.strip)
    if args.probe and args.train:
        return probe(args.probe, goal1.load(args.train, False), goal1.load(args.val, False))
    if not args.train:
        ap.error("--train is needed to train variants (or score a run with --show)")
    DATA = (goal1.load(args.train, False), goal1.load(args.val, True))
    results = flow_bench.run_variants(run, args)
    print("| variant | weights seed | seconds | PSNR (steps 1-8) | arm / copy_last | "
          "block / copy_last | largest flow (px) |")
    print("|---|---|---|---|---|---|---|")
    for (variant, seed), (sec, rows, top) in sorted(results.items()):
        print(f"| {variant} | {seed} | {sec:.0f} | {rows[:, 0].mean():.2f} | "
              f"{flow_bench.ratio(rows, 2):.3f} | {flow_bench.ratio(rows, 4):.3f} | {top:.2f} |")
    flow_bench.report_pairs(results, args)


if __name__ == "__main__":
    main()
