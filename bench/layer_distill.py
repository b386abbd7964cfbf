#!/usr/bin/python3
"""Issue 20, goal 2: does the layers' ceiling teach the motion predictor? (docs/motion.md,
"Fitted maps as targets; a layer learned for all episodes; more episodes (session 27)").

Session 24 found that a trained layered model's own masks and fill, moved by maps fitted to the
real frames (bench/layer_predictor.py --ceiling), draw the arm at 0.42x copy_last's error at
step 8, where its predictor draws it at 0.58x; a pull towards maps refined by 5 Adam steps per
window changed nothing. This script asks the stronger form of that question, offline:

1. fit the maps of every training window (`--horizon` steps from every `--stride`-th frame of
   every training episode) to its real frames, as --ceiling does (Adam on the L1, from the
   predictor's own increments, `--iterations`), batched; cached in `--targets`;
2. fine-tune the checkpoint's motion predictor (the sprite U-Net, so the masks and fill the
   targets were fitted with, frozen) for `--steps` on the same windows: the frame L1 of its own
   rollout plus `--weight` x the L1 between its increments, read at the fitted rollout's states
   (the frame the fitted maps draw and the fitted maps so far), and the fitted increments;
   `--weight 0` is the control (the same fine-tuning without the targets);
3. score it as every table in docs/motion.md (val episodes 0..7, 8 steps from frame 0).

  bench/layer_distill.py --checkpoint data/demo/run/motion --train data/demo/shards/train \
      --val data/demo/shards/val --targets /tmp/fits.pt [--weight 1] [--steps 600] [--strip S]
"""
import argparse
import os
import time

import numpy as np
import torch

import warp_predictor as wp
import layer_predictor as lp
from motion_run import load_run

SCALE = lp.INCREMENT_SCALE


def windows(episodes, horizon, stride):
    """[(episode, t)] for every stride-th start with `horizon` frames after it."""
    return [(e, t) for e, (frames, _, _) in enumerate(episodes)
            for t in range(0, len(frames) - horizon, stride)]


def gather(episodes, norm, where, horizon):
    """First frames [B, 3, S, S], normalised actions [B, H, D], real frames [B, H, 3, S, S]."""
    first = torch.stack([episodes[e][0][t] for e, t in where])
    acts = torch.tensor(np.stack([norm(episodes[e][2][t:t + horizon]) for e, t in where]))
    real = torch.stack([episodes[e][0][t + 1:t + horizon + 1] for e, t in where])
    return first, acts, real


def fit_targets(net, episodes, norm, where, horizon, iterations, batch):
    """[N, H, K, 6] increments fitted to each window's real frames (the --ceiling fit)."""
    out = []
    for i in range(0, len(where), batch):
        first, a, real = gather(episodes, norm, where[i:i + batch], horizon)
        out.append(lp.fit_increments(net, first, a, real, iterations))
        print(f"fitted {min(i + batch, len(where))} / {len(where)} windows", flush=True)
    return torch.cat(out)


def predicted_along(net, first, a, fitted):
    """[B, H, K, 6] the predictor's increments at the fitted rollout's states: the frame the
    fitted maps draw so far and those maps, as the predictor would see them had it been right."""
    with torch.no_grad():
        masks, fill = net.sprites(first)
        frames, maps = lp.drawn(net, first, masks, fill, fitted, with_maps=True)
    # the states before each step: the given frame and identity maps, then the fitted ones
    currents = torch.cat([first[:, None], frames[:, :-1]], 1)
    identity = torch.eye(3).expand(first.shape[0], 1, net.layers, 3, 3)
    befores = torch.cat([identity, maps[:, :-1]], 1)
    return torch.stack([net.step_maps(currents[:, t], first, befores[:, t], a[:, t])
                        for t in range(a.shape[1])], 1)


def finetune(net, episodes, norm, where, fitted, args):
    sprite = [p for n, p in net.named_parameters() if not n.startswith("motion_")]
    for p in sprite:  # the targets were fitted with these masks and this fill
        p.requires_grad_(False)
    motion = [p for p in net.parameters() if p.requires_grad]
    opt = torch.optim.AdamW(motion, args.max_lr, betas=(0.9, 0.9), weight_decay=0.01)
    rng = np.random.default_rng(args.seed)
    net.eval()  # no mask noise: the sprites are fixed
    for step in range(args.steps):
        for group in opt.param_groups:
            group["lr"] = wp.learning_rate(step, args.steps, args.max_lr)
        pick = rng.integers(len(where), size=wp.BATCH)
        first, a, real = gather(episodes, norm, [where[i] for i in pick], args.horizon)
        loss = (net(first, a) - real).abs().mean()
        if args.weight > 0:
            target = fitted[torch.from_numpy(pick)]
            pred = predicted_along(net, first, a, target)
            loss = loss + args.weight * ((pred - target) / SCALE).abs().mean()
        wp.optimizer_step(net, opt, loss, step)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--checkpoint", required=True, metavar="RUN_DIR")
    ap.add_argument("--train", required=True)
    ap.add_argument("--val", required=True)
    ap.add_argument("--targets", required=True, help="cache of the fitted increments (.pt)")
    ap.add_argument("--horizon", type=int, default=8)
    ap.add_argument("--stride", type=int, default=4)
    ap.add_argument("--iterations", type=int, default=300)
    ap.add_argument("--fit-batch", type=int, default=64)
    ap.add_argument("--steps", type=int, default=600)
    ap.add_argument("--weight", type=float, default=1.0)
    ap.add_argument("--max-lr", type=float, default=3e-4)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--strip")
    ap.add_argument("--save")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    torch.manual_seed(args.seed)
    torch.set_flush_denormal(True)
    net, norm = load_run(args.checkpoint, "layers")
    net.eval()
    train, val = wp.recipes.load(args.train), wp.recipes.load(args.val)
    where = windows(train, args.horizon, args.stride)
    start = time.time()
    if os.path.exists(args.targets):
        fitted = torch.load(args.targets)
        assert len(fitted) == len(where), f"{args.targets} holds other windows"
    elif args.weight > 0:
        fitted = fit_targets(net, train, norm, where, args.horizon, args.iterations,
                             args.fit_batch)
        torch.save(fitted, args.targets)
    else:
        fitted = None
    print(f"{len(where)} windows, targets in {time.time() - start:.0f} s", flush=True)
    start = time.time()
    finetune(net, train, norm, where, fitted, args)
    net.eval()
    with torch.no_grad():
        r, rows = wp.score(net, val, norm, lambda first, a, _: net(first, a))
    print(f"distilled (weight {args.weight}, {args.steps} steps, {time.time() - start:.0f} s): "
          f"{wp.summary(r)}")
    if args.strip:
        wp.write_strip(args.strip, rows)
    if args.save:
        torch.save(net.state_dict(), args.save)


if __name__ == "__main__":
    main()
