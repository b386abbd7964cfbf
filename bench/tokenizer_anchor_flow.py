#!/usr/bin/python3
"""Issue 20, goal 1: an anchor the decoder may move, and a weight on what changed since it.

The anchored tokenizer (docs/tokenizer.md, "Anchor decoder") gets what did not move from its
anchor; what its tokens must draw is what changed: the arm, and a block the gripper carried
somewhere new. Two label-free changes to the `tiny` recipe, trained with its PyTorch twin
(tests/tokenize/vqvae_twin.py; bench/tokenizer_anchor.py's sampling and schedule, 1 thread):

  change_weight a (`model.change_weight`, tokenize/vqvae.h ChangedPixels): the L1 weighted per
      pixel by detail(frame) + a * [a channel moved by over 30 levels since a real anchor],
      normalised by its mean (a = 0: the shipped loss);
  flow (`model.anchor_flow`, MoveByFlow): the anchor first moved by a 2-channel flow in pixels
      read off the merged features (zero-initialised: it starts as the anchor decoder without
      it), upsampled to the frame, applied by bilinear resampling; then the correction is added.

Each run is scored as wm-eval scores a rollout from frame 0 (steps 1..8 decoded from their own
tokens with the real frame 0 as anchor; region MSE against copy_last's, the segmentation only to
score), per validation episode, so two variants of one weights seed are compared paired
(bootstrap over episodes). --checkpoints scores finished C++ runs (wm-tokenize train) the same
way, loaded into the twin.

  bench/tokenizer_anchor_flow.py --train TRAIN --val VAL --variants base flow_change4 \
      --seeds 1 2 [--steps 2400] [--jobs 2] [--out rows.npz]
  bench/tokenizer_anchor_flow.py --val VAL --checkpoints RUN_BASE RUN_OTHER... [--strip PNG]
"""
import argparse
import itertools
import math
import multiprocessing
import os
import sys
import time

import cv2
import numpy as np
import torch

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import tokenizer_anchor as anchor_bench  # noqa: E402
import tokenizer_goal1 as goal1  # noqa: E402
from tokenizer_goal1 import twin  # noqa: E402

TINY = anchor_bench.P8  # 8x8 tokens, 1024 codes, detail weight 4, anchor decoder
DROPOUT = 0.5
DATA = None  # (train episodes, val episodes), set before the workers fork
VARIANTS = {  # name: model overrides on `tiny`'s
    "base": {}, "change4": {"change_weight": 4.0}, "change8": {"change_weight": 8.0},
    "flow": {"anchor_flow": True}, "flow_change4": {"anchor_flow": True, "change_weight": 4.0}}


@torch.no_grad()
def scored_frames(model, frames):
    """An episode's codes, and its steps 1..8 as uint8 levels: (codes, real, reconstructed from
    their own tokens with the real frame 0 as anchor, copy_last). Every frame is encoded with
    frame 0 as anchor, which only an encoder that reads the anchor uses."""
    codes = twin.encode(model, frames, frames[:1].expand(len(frames), -1, -1, -1))
    steps = codes[1:anchor_bench.HORIZON + 1]
    recon = twin.decode(model, steps, frames[:1].expand(len(steps), -1, -1, -1))
    real = goal1.to_uint8(frames[1:len(steps) + 1])
    return codes, real, goal1.to_uint8(recon), np.repeat(goal1.to_uint8(frames[:1]), len(real), 0)


@torch.no_grad()
def per_episode(model, episodes):
    """Per validation episode: region MSE of the anchored reconstruction and of copy_last over
    steps 1..8 (NaN where the region is absent), PSNR over those steps, and the fraction of
    cells whose code changes from frame to frame (a collapsed tokenizer's is near 0)."""
    rows = []
    for frames, seg in episodes:
        codes, real, rec, copy = scored_frames(model, frames)
        s = seg[1:len(real) + 1]
        row = [float(np.mean([goal1.frame_psnr(x, y) for x, y in zip(real, rec)])),
               float((codes[1:] != codes[:-1]).float().mean())]
        for label in (1, 2):
            for pred in (rec, copy):
                values = goal1.region_mse(real, pred, s, label)
                row.append(np.nanmean(values) if not all(map(math.isnan, values)) else math.nan)
        rows.append(row)
    return np.array(rows)  # [episodes, 6]: psnr, change rate, arm, arm copy, block, block copy


def run(job):
    variant, seed, steps = job
    torch.set_num_threads(1)
    start = time.time()
    model, _ = anchor_bench.train({**TINY, **VARIANTS[variant]}, steps, DROPOUT, DATA[0], seed)
    return job, time.time() - start, per_episode(model, DATA[1])


def ratio(rows, col):
    ok = ~np.isnan(rows[:, col])
    return rows[ok, col].mean() / rows[ok, col + 1].mean()


def paired_interval(a, b, col, resamples=2000, seed=0):
    """Difference of the ratios (b - a) with a 95% bootstrap interval over episodes."""
    ok = ~(np.isnan(a[:, col]) | np.isnan(b[:, col]))
    a, b = a[ok], b[ok]
    rng = np.random.default_rng(seed)
    diffs = []
    for _ in range(resamples):
        k = rng.integers(0, len(a), len(a))
        diffs.append(ratio(b[k], col) - ratio(a[k], col))
    return ratio(b, col) - ratio(a, col), np.percentile(diffs, 2.5), np.percentile(diffs, 97.5)


def paired_line(a, b):
    """b - a over the episodes: PSNR, and the arm's and block's ratios to copy_last's, each with
    its 95% bootstrap interval."""
    psnr = b[:, 0] - a[:, 0]
    draws = np.random.default_rng(0).integers(0, len(psnr), (2000, len(psnr)))
    plo, phi = np.percentile(psnr[draws].mean(1), [2.5, 97.5])
    arm, lo, hi = paired_interval(a, b, 2)
    block, blo, bhi = paired_interval(a, b, 4)
    return (f"PSNR {psnr.mean():+.2f} [{plo:+.2f}, {phi:+.2f}], arm {arm:+.3f} [{lo:+.3f}, "
            f"{hi:+.3f}], block {block:+.3f} [{blo:+.3f}, {bhi:+.3f}]")


def score_checkpoints(runs, val, strip=None):
    """The C++ runs, loaded into the twin (the same numbers as C++: tests/tokenize), paired;
    with `strip`, their picture (draw_strip)."""
    models = [twin.load_checkpoint(run)[0].eval() for run in runs]
    rows = [per_episode(model, val) for model in models]
    for run, r in zip(runs, rows):
        print(f"{run}: PSNR (steps 1-8) {r[:, 0].mean():.2f}, code changes {r[:, 1].mean():.3f}, "
              f"arm / copy_last {ratio(r, 2):.3f}, block / copy_last {ratio(r, 4):.3f}")
    for run, r in zip(runs[1:], rows[1:]):
        print(f"paired, {run} - {runs[0]}: {paired_line(rows[0], r)}")
    if strip:
        draw_strip(strip, models, runs, val, rows[0])


def draw_strip(path, models, labels, val, rows):
    """For the 2 episodes where copying's block error is largest (per_episode `rows`): real
    frames, each model's reconstructions, copy_last; one PNG."""
    order = np.argsort(-np.nan_to_num(rows[:, 5]))[:2]
    panels = []
    for e in order:
        for k, model in enumerate(models):
            _, real, rec, copy = scored_frames(model, val[e][0])
            panels += [real] if k == 0 else []
            panels.append(rec)
        panels.append(copy)
    write_strip(path, panels)
    print(f"wrote {path} (episodes {order[0]} and {order[1]}; rows: real, "
          f"{', '.join(labels)}, copy_last)")


def run_variants(run, args):
    """run((variant, seed, steps)) -> (job, seconds, rows, ...) for every variant x seed of
    `args`, args.jobs at a time: {(variant, seed): (seconds, rows, ...)}."""
    jobs = list(itertools.product(args.variants, args.seeds, [args.steps]))
    with multiprocessing.get_context("fork").Pool(args.jobs) as pool:
        return {job[:2]: tuple(rest) for job, *rest in pool.imap(run, jobs)}


def report_pairs(results, args):
    """Each variant against the first at the same seed (paired_line), and args.out's .npz."""
    base = args.variants[0]
    for variant, seed in itertools.product(args.variants[1:], args.seeds):
        a, b = results[(base, seed)][1], results[(variant, seed)][1]
        print(f"paired, {variant} - {base}, seed {seed}: {paired_line(a, b)}")
    if args.out:
        np.savez(args.out, **{f"{v}_s{s}": rest[1] for (v, s), rest in results.items()})


def write_strip(path, rows):
    """Rows of frames ([n, S, S, 3] RGB levels) one above the other, frames side by side: a PNG."""
    cv2.imwrite(path, np.concatenate([np.concatenate(list(r.clip(0, 255)), 1) for r in rows],
                                     0).astype(np.uint8)[..., ::-1])


def add_run_arguments(ap, variants, default_variants, default_seeds):
    """The options every twin-training bench of this family takes (run_variants, report_pairs)."""
    ap.add_argument("--train")
    ap.add_argument("--val", required=True)
    ap.add_argument("--variants", nargs="+", default=default_variants, choices=variants)
    ap.add_argument("--seeds", type=int, nargs="+", default=default_seeds)
    ap.add_argument("--steps", type=int, default=2400)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", help=".npz of every run's per-episode rows")


def main():
    global DATA
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    add_run_arguments(ap, VARIANTS, ["base", "change4"], [0, 1])
    ap.add_argument("--checkpoints", nargs="+", metavar="RUN_DIR",
                    help="score these wm-tokenize runs instead of training (the first is the base)")
    ap.add_argument("--strip", metavar="PNG", help="with --checkpoints: their picture")
    args = ap.parse_args()
    if args.checkpoints:
        return score_checkpoints(args.checkpoints, goal1.load(args.val, True), args.strip)
    if not args.train:
        ap.error("--train is needed to train variants (or score runs with --checkpoints)")
    DATA = (goal1.load(args.train, False), goal1.load(args.val, True))
    results = run_variants(run, args)
    print("| variant | weights seed | seconds | PSNR (steps 1-8) | code changes | "
          "arm / copy_last | block / copy_last |")
    print("|---|---|---|---|---|---|---|")
    for (variant, seed), (sec, rows) in sorted(results.items()):
        print(f"| {variant} | {seed} | {sec:.0f} | {rows[:, 0].mean():.2f} | "
              f"{rows[:, 1].mean():.3f} | {ratio(rows, 2):.3f} | {ratio(rows, 4):.3f} |")
    report_pairs(results, args)


if __name__ == "__main__":
    main()
