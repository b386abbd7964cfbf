#!/usr/bin/python3
"""Issue 20, goal 2 (docs/dynamics.md, "Stable tokens, copy prior, arrival"): which token recipe
lets the tiny dynamics model predict change at all. Each row trains, on 1 thread:

  1. the anchored tiny tokenizer twin (bench/tokenizer_anchor.py, 1200 steps, dropout 0.5) with
     its conv encoder, or a *cell-local* encoder (pixel unshuffle by the patch, then 1x1 convs:
     a token sees only its own 8x8 cell, so a cell whose pixels stay keeps its code; the twin's
     `model.encoder: cell_local`, wm-tokenize's: until session 61 this bench built its own copy,
     which drew the conv encoder's initial weights first, so older tables differ in the last
     digits), with K codes;
  2. the dynamics twin's body (bench/dynamics_objective.py: tiny preset, next-frame CE, policy
     conditioning off) for 300 steps (--dynamics-steps) on those tokens, with or without the
     copy prior;

and reports the tokenizer (PSNR over rollout steps 1..8, flicker, token change rate), the
dynamics on val windows (argmax right where the code changes / stays, p(copy) where it changes,
one-step decoded MSE on the pixels that moved vs decoding the previous frame's tokens), and
8-step open-loop rollouts from frame 0 of val episodes 0..7 (argmax, anchor = frame 0): PSNR,
arm / object MSE vs copy_last, PSNR with the actions reversed. `--strips DIR` writes per row
real / predicted / reversed-actions / tokenizer rows for val episodes 0 and 1.

  bench/dynamics_token_recipes.py --train data/demo/shards/train --val data/demo/shards/val \
      [--only N..] [--strips DIR] [--dynamics-steps N] [--seed S]
"""
import argparse
import os
import sys
import time

import cv2
import numpy as np
import torch

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import dynamics_objective as dob  # noqa: E402
import tokenizer_anchor as anchor_bench  # noqa: E402
from tokenizer_goal1 import frame_psnr  # noqa: E402
import tokenizer_goal1 as goal1  # noqa: E402
from tokenizer_goal1 import twin  # noqa: E402

VARIANTS = [  # (label, cell-local encoder, codes, copy prior)
    ("conv encoder, 1024 codes, copy prior (the demo's recipe)", False, 1024, True),
    ("conv encoder, 1024 codes, no copy prior", False, 1024, False),
    ("cell-local encoder, 1024 codes, copy prior", True, 1024, True),
    ("cell-local encoder, 1024 codes, no copy prior", True, 1024, False),
    ("cell-local encoder, 256 codes, copy prior", True, 256, True),
    ("cell-local encoder, 64 codes, copy prior", True, 64, True),
    ("cell-local encoder, 64 codes, no copy prior", True, 64, False),
]
TOKENIZER_STEPS, HORIZON, ROLLOUTS = 1200, goal1.HORIZON, 8


def load(directory):
    """[(frames [T, 3, 64, 64] in [-1, 1], segmentation [T, 64, 64], raw actions [T, 7])]."""
    import wmshard
    ds, out = wmshard.Dataset(directory), []
    for k in range(ds.num_episodes):
        meta, _, blobs = ds.episode(k)
        frames = np.stack([twin.decode_frame(b, 64) for b in blobs["image"]])
        seg = np.stack([cv2.imdecode(np.frombuffer(b, np.uint8), cv2.IMREAD_UNCHANGED)
                        for b in blobs["segmentation"]])
        out.append((torch.from_numpy(frames), seg, np.array(meta["actions"], np.float32)))
    return out


def next_logits(dyn, x, a):
    """[N, K] logits of the frame after the window's last one."""
    return dyn.net(x, a, None)[0][0, x.shape[1] - 1]


def decode(tokenizer, codes, anchor):
    g = int(round(codes.shape[-1] ** 0.5))
    return goal1.to_uint8(twin.decode(tokenizer, codes.view(-1, g, g),
                                      anchor.expand(len(codes), -1, -1, -1)))


@torch.no_grad()
def one_step(dyn, tokenizer, val_eps):
    """p(copy) where the code changes; moved-pixel MSE of the argmax frame vs the copied one."""
    p_copy, mse = [], {"model": [], "copy": []}
    for k, (codes, _) in enumerate(dyn.val):
        frames = val_eps[k][0]
        for s in range(0, len(codes) - dyn.context + 1, 2):
            x, a = dyn.windows(dyn.val, k, s)
            x, a = x[:, :-1], a[:, :-1]
            t = s + dyn.context - 1  # the predicted frame
            logits = next_logits(dyn, x, a)
            prev, true = x[0, -1], torch.tensor(codes[t])
            changed = true != prev
            if changed.any():
                p_copy.append(logits.softmax(-1).gather(-1, prev[:, None])[:, 0][changed].mean())
            real, before = goal1.to_uint8(frames[t:t + 1]), goal1.to_uint8(frames[t - 1:t])
            moved = (np.abs(real - before).max(-1) > 30)[0]
            if moved.any():
                for name, c in (("model", logits.argmax(-1)), ("copy", prev)):
                    img = decode(tokenizer, c[None], frames[s:s + 1])
                    mse[name].append(((img - real) ** 2).mean(-1)[0][moved].mean())
    return float(np.mean(p_copy)), float(np.mean(mse["model"]) / np.mean(mse["copy"]))


@torch.no_grad()
def rollouts(dyn, tokenizer, val_eps):
    """Open-loop argmax rollouts of HORIZON steps; metrics and strip rows."""
    found = {k: {"psnr": [], "arm": [], "obj": []} for k in ("model", "reversed", "copy_last")}
    rows = []
    for k in range(ROLLOUTS):
        codes, actions = dyn.val[k]
        frames, seg, _ = val_eps[k]
        normed = torch.tensor((actions[:HORIZON] - dyn.mean) / dyn.std).float()
        preds = {}
        for name, acts in (("model", normed), ("reversed", torch.flip(normed, [0]))):
            context = [torch.tensor(codes[0])]
            for h in range(HORIZON):
                x = torch.stack(context[-(dyn.context - 1):])[None]
                step_actions = acts[h + 1 - x.shape[1]:h + 1][None]
                context.append(next_logits(dyn, x, step_actions).argmax(-1))
            preds[name] = decode(tokenizer, torch.stack(context[1:]), frames[:1])
        real = goal1.to_uint8(frames[1:HORIZON + 1])
        preds["copy_last"] = np.repeat(goal1.to_uint8(frames[:1]), HORIZON, 0)
        for name, p in preds.items():
            found[name]["psnr"].append(np.mean([frame_psnr(a, b) for a, b in zip(real, p)]))
            for key, label in (("arm", 1), ("obj", 2)):
                found[name][key].append(np.nanmean(goal1.region_mse(real, p, seg[1:HORIZON + 1],
                                                                   label)))
        if k < 2:
            recon = decode(tokenizer, torch.tensor(codes[1:HORIZON + 1]), frames[:1])
            rows += [np.concatenate(list(r), 1) for r in (real, preds["model"],
                                                          preds["reversed"], recon)]
    mean = {n: {k: float(np.nanmean(v)) for k, v in d.items()} for n, d in found.items()}
    return mean, np.concatenate(rows, 0)


def run(label, cell_local, num_codes, copy_prior, train_eps, val_eps, dynamics_steps, seed):
    over = {**anchor_bench.P8, "num_codes": num_codes,
            "encoder": "cell_local" if cell_local else "conv"}  # the twin's, as wm-tokenize's
    start = time.time()
    tokenizer, config = anchor_bench.train(over, TOKENIZER_STEPS, 0.5,
                                           [(f, s) for f, s, _ in train_eps], seed=seed)
    tok = anchor_bench.evaluate(tokenizer, config, [(f, s) for f, s, _ in val_eps])
    codes = {split: [twin.encode(tokenizer, f).reshape(len(f), -1).numpy() for f, _, _ in eps]
             for split, eps in (("train", train_eps), ("val", val_eps))}
    dyn = dob.Experiment.on_episodes(
        "ce", tokenizer.quantizer.codes().detach(),
        [(c, a) for c, (_, _, a) in zip(codes["train"], train_eps)],
        [(c, a) for c, (_, _, a) in zip(codes["val"], val_eps)], copy_prior, seed)
    dyn.fit(dynamics_steps, seed)
    changed_acc, static_acc, _, _, _ = dyn.score()
    p_copy, moved_ratio = one_step(dyn, tokenizer, val_eps)
    r, strip = rollouts(dyn, tokenizer, val_eps)
    cl = r["copy_last"]
    print(f"| {label} | {tok['psnr']:.1f} | {tok['flicker']:.3f} | {tok['change_rate']:.3f} | "
          f"{changed_acc:.4f} | {static_acc:.3f} | {p_copy:.2f} | {moved_ratio:.2f} | "
          f"{r['model']['psnr']:.2f} ({cl['psnr']:.2f}) | "
          f"{r['model']['psnr'] - r['reversed']['psnr']:+.2f} | "
          f"{r['model']['arm'] / cl['arm']:.2f} | {r['model']['obj'] / cl['obj']:.2f} | "
          f"{time.time() - start:.0f} |", flush=True)
    return strip


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--train", required=True)
    ap.add_argument("--val", required=True)
    ap.add_argument("--only", type=int, nargs="*", help="row numbers to run (default all)")
    ap.add_argument("--strips", help="directory for one strip PNG per row")
    ap.add_argument("--dynamics-steps", type=int, default=300,
                    help="the dynamics model's steps (a cosine schedule to the last)")
    ap.add_argument("--seed", type=int, default=0,
                    help="weights and batch draws of both the tokenizer and the dynamics model")
    args = ap.parse_args()
    torch.set_num_threads(1)
    sys.path.insert(0, os.path.join(dob.SRC, "scripts"))
    train_eps, val_eps = load(args.train), load(args.val)
    print("| variant | tokenizer PSNR (steps 1-8) | flicker | token changes | argmax right, "
          "changed | argmax right, unchanged | p(copy), changed | one-step moved-pixel MSE / "
          "copied tokens' | rollout PSNR (copy_last) | PSNR - reversed actions' | arm / copy_last"
          " | object / copy_last | seconds |")
    print("|" + "---|" * 13)
    for i, (label, cell_local, num_codes, copy_prior) in enumerate(VARIANTS):
        if args.only and i not in args.only:
            continue
        strip = run(label, cell_local, num_codes, copy_prior, train_eps, val_eps,
                    args.dynamics_steps, args.seed)
        if args.strips:
            os.makedirs(args.strips, exist_ok=True)
            cv2.imwrite(os.path.join(args.strips, f"row{i}.png"),
                        cv2.resize(strip.clip(0, 255).astype(np.uint8)[..., ::-1], None, fx=2,
                                   fy=2, interpolation=cv2.INTER_NEAREST))


if __name__ == "__main__":
    main()
