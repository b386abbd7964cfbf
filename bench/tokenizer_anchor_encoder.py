#!/usr/bin/python3
"""Issue 20, goal 1: what do `tiny`'s codes lose? Variants of what a cell's code is.

In `tiny` (docs/tokenizer.md, "Anchor decoder") each 8x8 cell is one of 1024 codes, chosen by an
encoder that does not see the anchor the decoder reads. Where the arm moved 10-20 pixels the
codes redraw it blurred over the block (docs/tokenizer.md, "Teaching the flow to move far").
Is that the codes' fault, or the network's that draws them? Variants (docs/tokenizer.md, "What
the codes lose"):

  seen        the encoder reads the frame and its anchor side by side (6 channels; its first
              convolution's anchor half starts at zero, so at step 0 it is `tiny`'s encoder),
              as Delta-IRIS's encoder reads the previous frame;
  rvq2, rvq4  residual VQ of 2 or 4 levels of 1024 codes (model.levels, as the C++ tokenizer):
              a cell is 2 or 4 codes (in session 52 a prototype of it, docs/tokenizer.md);
  continuous  no quantiser: the decoder reads the encoder's unit-length latents (the network's
              ceiling at these steps).

Trained with the PyTorch twin as bench/tokenizer_anchor_flow.py trains the shipped `tiny`
(its `flow_change4` variant: 8x8 tokens, 1024 codes, the anchor's flow, change weight 4, 2400
steps of 16) and scored the same way, paired: steps 1..8 encoded and decoded with the real frame
0 as anchor, region MSE against copy_last's. Also printed: flicker over steps 1..8 (token
changes where no pixel changed by over 30 levels, over all token changes; an encoder that reads
the anchor can keep a still cell's code).

  bench/tokenizer_anchor_encoder.py --train TRAIN --val VAL --variants base seen \
      --seeds 1 2 [--steps 2400] [--jobs 2] [--save DIR] [--out rows.npz]
  bench/tokenizer_anchor_encoder.py --val VAL --strip PNG --load DIR --seed 1

--strip: for the 2 episodes where copying's block error is largest, rows of real frames, each
saved variant's reconstructions (own tokens, real frame 0 as anchor), and copy_last.
"""
import argparse
import os
import sys
import time

import torch

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import tokenizer_anchor as anchor_bench  # noqa: E402
import tokenizer_anchor_flow as flow_bench  # noqa: E402
import tokenizer_goal1 as goal1  # noqa: E402
from tokenizer_goal1 import twin  # noqa: E402

RECIPE = {**flow_bench.TINY, **flow_bench.VARIANTS["flow_change4"]}  # the shipped `tiny`
VARIANTS = {"base": ("vq", 0.5), "seen": ("seen", 0.5),
            "continuous": ("continuous", 0.5), "rvq2": ("rvq2", 0.5), "rvq4": ("rvq4", 0.5)}
DATA = None  # (train episodes, val episodes), set before the workers fork
SAVE = None  # where run() keeps each run's weights (--save), or None


class AnchorSeeingVqVae(twin.VqVae):
    """The twin's anchored tokenizer whose encoder reads [frame, anchor] (blank: zeros)."""

    def __init__(self, config):
        super().__init__(config)
        first = self.encoder[1]  # after the pixel unshuffle: channel c * f^2 + offset
        seeing = torch.nn.Conv2d(2 * first.in_channels, first.out_channels, 3, padding=1)
        with torch.no_grad():  # the frame's half as `tiny`'s, the anchor's half silent
            seeing.weight.copy_(torch.cat([first.weight, torch.zeros_like(first.weight)], 1))
            seeing.bias.copy_(first.bias)
        self.encoder[1] = seeing

    def latents(self, images, anchors=None):
        anchors = torch.zeros_like(images) if anchors is None else anchors
        return self.encoder(torch.cat([images, anchors], 1))


class Unquantised(torch.nn.Module):
    """Stands in for the quantiser: the decoder reads the encoder's (unit-length) latents
    themselves, so what the 8x8 grid could keep with no codebook at all is measured. Its
    "indices" are those latents and its lookup returns them, so the twin's encode / decode
    score it unchanged; no codebook terms, nothing to revive."""

    def forward(self, z_e):
        z = torch.nn.functional.normalize(z_e, dim=1)
        zero = z_e.new_zeros(())
        return {"z_q": z, "indices": z, "codebook_loss": zero, "commitment": zero}

    def lookup(self, latents):
        return latents

    def seed_from_latents(self, *_):
        pass

    def update_usage_and_reseed(self, *_):
        pass


def residual(levels):
    """tiny with model.levels = `levels`: the twin's (and the C++) residual quantiser."""
    return lambda config: twin.VqVae({**config, "levels": levels})


def continuous(config):
    model = twin.VqVae(config)
    model.quantizer = Unquantised()
    return model


def build(variant):
    return {"vq": twin.VqVae, "seen": AnchorSeeingVqVae, "continuous": continuous,
            "rvq2": residual(2), "rvq4": residual(4)}[VARIANTS[variant][0]]


def flicker(model, episodes):
    """Over steps 1..8 of every episode, encoded as scored_frames encodes them (frame 0 as
    anchor): token changes in still cells over all token changes."""
    if isinstance(model.quantizer, Unquantised):
        return float("nan")
    still, changes = 0, 0
    for frames, _ in episodes:
        codes, *_ = flow_bench.scored_frames(model, frames)
        n = min(len(frames), anchor_bench.HORIZON + 1)
        s, c, _ = twin.flicker_counts(codes[1:n].numpy(), goal1.to_uint8(frames[1:n]), 8)
        still, changes = still + s, changes + c
    return still / max(1, changes)


def run(job):
    variant, seed, steps = job
    torch.set_num_threads(1)
    start = time.time()
    model, _ = anchor_bench.train(RECIPE, steps, VARIANTS[variant][1], DATA[0], seed,
                                  build=build(variant))
    if SAVE:
        torch.save(model.state_dict(), os.path.join(SAVE, f"{variant}_s{seed}.pt"))
    return job, time.time() - start, flow_bench.per_episode(model, DATA[1]), \
        flicker(model, DATA[1])


def strip(path, load_dir, seed, variants, val):
    """Real frames, each variant's reconstructions and copy_last for the 2 episodes where
    copying's block error is largest."""
    models = []
    for variant in variants:
        model = build(variant)({**twin.MODEL_DEFAULTS, **RECIPE})
        model.load_state_dict(torch.load(os.path.join(load_dir, f"{variant}_s{seed}.pt")))
        models.append(model.eval())
    flow_bench.draw_strip(path, models, variants, val, flow_bench.per_episode(models[0], val))


def main():
    global DATA, SAVE
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    flow_bench.add_run_arguments(ap, VARIANTS, ["base", "seen"], [1, 2])
    ap.add_argument("--save", metavar="DIR", help="keep each run's weights (VARIANT_sSEED.pt)")
    ap.add_argument("--strip", metavar="PNG", help="picture of --load's runs of --variants")
    ap.add_argument("--load", metavar="DIR")
    ap.add_argument("--seed", type=int, default=1, help="with --strip: which weights seed")
    args = ap.parse_args()
    if args.strip:
        return strip(args.strip, args.load, args.seed, args.variants, goal1.load(args.val, True))
    if not args.train:
        ap.error("--train is needed to train variants (or draw saved runs with --strip)")
    SAVE = args.save
    if SAVE:
        os.makedirs(SAVE, exist_ok=True)
    DATA = (goal1.load(args.train, False), goal1.load(args.val, True))
    results = flow_bench.run_variants(run, args)
    print("| variant | weights seed | seconds | PSNR (steps 1-8) | code changes | flicker | "
          "arm / copy_last | block / copy_last |")
    print("|---|---|---|---|---|---|---|---|")
    for (variant, seed), (sec, rows, still) in sorted(results.items()):
        print(f"| {variant} | {seed} | {sec:.0f} | {rows[:, 0].mean():.2f} | "
              f"{rows[:, 1].mean():.3f} | {still:.3f} | {flow_bench.ratio(rows, 2):.3f} | "
              f"{flow_bench.ratio(rows, 4):.3f} |")
    flow_bench.report_pairs(results, args)


if __name__ == "__main__":
    main()
