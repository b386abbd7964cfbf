#!/usr/bin/python3
"""Issue 20, goal 1 with the anchor decoder (docs/tokenizer.md, "Anchor decoder"): each variant
trains the PyTorch twin (tests/tokenize/vqvae_twin.py, model.anchor_decoder) on 1 thread, with
anchors drawn like FrameSampler::TrainingAnchors (gap uniform in [1, min(t, max_gap)], blank with
probability `dropout`), and scores the validation episodes as wm-eval scores a rollout from
frame 0: steps 1..8 decoded from their own tokens with the real frame 0 as anchor. Columns as
bench/tokenizer_goal1.py, except PSNR, which here is over steps 1..8 (the frames a rollout
decodes; frame 0 is given).

  bench/tokenizer_anchor.py --train data/demo/shards/train --val data/demo/shards/val [--only N..]
"""
import argparse
import os
import sys
import time

import numpy as np
import torch

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import tokenizer_goal1 as goal1  # noqa: E402
from tokenizer_goal1 import twin  # noqa: E402

P8 = {"stem_factor": 4, "min_channels": 0, "dead_code_steps": 10, "detail_weight": 4,
      "num_codes": 1024, "anchor_decoder": True}
P4 = {**P8, "patch_size": 4, "num_codes": 512}
VARIANTS = [  # (label, model overrides, steps, anchor dropout); max gap 8 throughout
    ("8x8, 1024 codes, no anchor decoder", {**P8, "anchor_decoder": False}, 1200, 0.0),
    ("8x8, 1024 codes, anchor dropout 0", P8, 1200, 0.0),
    ("8x8, 1024 codes, anchor dropout 0.5", P8, 1200, 0.5),
    ("8x8, 1024 codes, anchor dropout 0.5, 2400 steps (tiny)", P8, 2400, 0.5),
    ("16x16, 512 codes, no anchor decoder", {**P4, "anchor_decoder": False}, 1200, 0.0),
    ("16x16, 512 codes, anchor dropout 0", P4, 1200, 0.0),
    ("16x16, 512 codes, anchor dropout 0.3", P4, 1200, 0.3),
    ("16x16, 512 codes, anchor dropout 0.5", P4, 1200, 0.5),
    ("16x16, 512 codes, anchor dropout 0.5, 2400 steps", P4, 2400, 0.5),
]
MAX_GAP, HORIZON = 8, goal1.HORIZON


def train(model_over, steps, dropout, episodes, seed=0, build=twin.VqVae):
    """The twin trained as the C++ trainer trains an anchored tokenizer; `build(config)` makes
    the model (bench/tokenizer_anchor_encoder.py and tokenizer_flow_teachers.py swap in their
    own)."""
    config = {**twin.MODEL_DEFAULTS, **model_over}
    t = {**goal1.TRAIN, "steps": steps}
    torch.manual_seed(seed)
    model = build(config)
    opt = torch.optim.AdamW(model.parameters(), lr=t["max_lr"], betas=(0.9, 0.9),
                            weight_decay=1e-4)
    draws, codes_rng = np.random.default_rng(seed), twin.Mt19937_64(seed)
    for step in range(steps):
        for g in opt.param_groups:
            g["lr"] = twin.learning_rate_at(t, step)
        frames, anchors = [], []
        for _ in range(t["batch_size"]):
            clip = episodes[draws.integers(len(episodes))][0]
            i = int(draws.integers(len(clip)))
            span = min(i, MAX_GAP)
            blank = span == 0 or draws.random() < dropout
            frames.append(clip[i])
            anchors.append(torch.zeros_like(clip[i]) if blank else
                           clip[i - 1 - int(draws.integers(span))])
        x, a = torch.stack(frames), torch.stack(anchors)
        if step == 0:
            with torch.no_grad():
                model.quantizer.seed_from_latents(model.latents(x, a), codes_rng)
        out = model(x, a if config["anchor_decoder"] else None)
        opt.zero_grad()
        out["loss"].backward()
        torch.nn.utils.clip_grad_norm_(model.parameters(), 1.0)
        opt.step()
        model.quantizer.update_usage_and_reseed(out["quant"], config["dead_code_steps"],
                                                codes_rng)
    return model.eval(), config


@torch.no_grad()
def evaluate(model, config, episodes):
    psnrs, counts, ratios = [], np.zeros(3, np.int64), {"arm": [], "obj": [], "arm_copy": [],
                                                       "obj_copy": []}
    for frames, seg in episodes:
        codes = twin.encode(model, frames)
        total = twin.flicker_counts(codes.numpy(), goal1.to_uint8(frames), 64 // codes.shape[1])
        counts += np.array(total)
        steps = codes[1:HORIZON + 1]
        anchors = frames[:1].expand(len(steps), -1, -1, -1)
        recon = twin.decode(model, steps, anchors if config["anchor_decoder"] else None)
        real, rec = goal1.to_uint8(frames[1:HORIZON + 1]), goal1.to_uint8(recon)
        copy = np.repeat(goal1.to_uint8(frames[:1]), len(real), 0)
        psnrs += [goal1.frame_psnr(x, y) for x, y in zip(real, rec)]
        s = seg[1:HORIZON + 1]
        for key, label in (("arm", 1), ("obj", 2)):
            ratios[key].append(np.nanmean(goal1.region_mse(real, rec, s, label)))
            ratios[key + "_copy"].append(np.nanmean(goal1.region_mse(real, copy, s, label)))
    return {"psnr": float(np.mean(psnrs)), "flicker": counts[0] / max(1, counts[1]),
            "change_rate": counts[1] / counts[2],
            "arm": np.nanmean(ratios["arm"]) / np.nanmean(ratios["arm_copy"]),
            "object": np.nanmean(ratios["obj"]) / np.nanmean(ratios["obj_copy"])}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--train", required=True)
    ap.add_argument("--val", required=True)
    ap.add_argument("--only", type=int, nargs="*", help="row numbers to run (default all)")
    ap.add_argument("--steps", type=int, help="override every row's steps (a smoke run)")
    args = ap.parse_args()
    torch.set_num_threads(1)
    train_eps, val_eps = goal1.load(args.train, False), goal1.load(args.val, True)
    print("| # | variant | steps | seconds | PSNR dB (steps 1-8) | flicker | token changes | "
          "arm / copy_last | object / copy_last |")
    print("|---|---|---|---|---|---|---|---|---|")
    for i, (label, over, steps, dropout) in enumerate(VARIANTS):
        if args.only and i not in args.only:
            continue
        steps = args.steps or steps
        start = time.time()
        model, config = train(over, steps, dropout, train_eps)
        seconds = time.time() - start
        r = evaluate(model, config, val_eps)
        print(f"| {i} | {label} | {steps} | {seconds:.0f} | {r['psnr']:.1f} | "
              f"{r['flicker']:.3f} | {r['change_rate']:.3f} | {r['arm']:.2f} | "
              f"{r['object']:.2f} |", flush=True)


if __name__ == "__main__":
    main()
