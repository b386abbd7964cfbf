#!/usr/bin/python3
"""Issue 20, goal 1: which tiny-tokenizer recipe keeps the arm and the block on plain-look data.
Each variant trains the PyTorch twin (tests/tokenize/vqvae_twin.py) on 1 thread and reports, on
the validation episodes: PSNR (mean over frames of uint8 PSNR, as val.csv), the flicker rate and
token-change rate (docs/tokenizer.md, "Flicker"), and the arm / object MSE of the reconstruction
over steps 1..H against copy_last's (frame 0 repeated), with the scene's segmentation only for
scoring (wm-eval's mse_arm / mse_object: per-frame region MSE on [0, 255], mean over the frames
where the region is present, then over episodes).

  bench/tokenizer_goal1.py --train data/demo/shards/train --val data/demo/shards/val [--only N..]

The table in docs/tokenizer.md, "Issue 20: keeping the arm and the block", is this script's
output. Training is the twin's step (uniform frame sampling), so seconds are per thread of this
machine; the C++ trainer runs at about the same speed (docs/tokenizer.md, benchmark).
"""
import argparse
import math
import multiprocessing
import os
import sys
import time

import cv2
import numpy as np
import torch

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests",
                                "tokenize"))
import vqvae_twin as twin  # noqa: E402

TINY = {"stem_factor": 4, "min_channels": 0, "dead_code_steps": 10}
P4 = {**TINY, "patch_size": 4}
VARIANTS = [  # (label, model overrides, train overrides)
    ("tiny (8x8, 1024 codes)", TINY, {"steps": 1200}),
    ("16x16 tokens, 1024 codes", P4, {"steps": 1200}),
    ("16x16 tokens, 512 codes", {**P4, "num_codes": 512}, {"steps": 1200}),
    ("16x16 tokens, 256 codes", {**P4, "num_codes": 256}, {"steps": 1200}),
    ("16x16, 512 codes, dead_code_steps 200", {**P4, "num_codes": 512, "dead_code_steps": 200},
     {"steps": 1200}),
    ("16x16, 512 codes, detail weight 4",
     {**P4, "num_codes": 512, "detail_weight": 4}, {"steps": 1200}),
    ("8x8, 512 codes, detail weight 4",
     {**TINY, "num_codes": 512, "detail_weight": 4}, {"steps": 1200}),
    ("16x16, 512 codes, 96 channels", {**P4, "num_codes": 512, "encoder_channels": 96,
                                       "decoder_channels": 96}, {"steps": 1200}),
    ("16x16, 512 codes, 2400 steps", {**P4, "num_codes": 512}, {"steps": 2400}),
    ("16x16, 256 codes, detail weight 4",
     {**P4, "num_codes": 256, "detail_weight": 4}, {"steps": 1200}),
    ("16x16, 512 codes, detail weight 4, dead_code_steps 200",
     {**P4, "num_codes": 512, "dead_code_steps": 200, "detail_weight": 4}, {"steps": 1200}),
    ("16x16, 512 codes, detail weight 4, 96 channels",
     {**P4, "num_codes": 512, "encoder_channels": 96, "decoder_channels": 96, "detail_weight": 4},
     {"steps": 1200}),
    ("16x16, 512 codes, detail weight 8",
     {**P4, "num_codes": 512, "detail_weight": 8}, {"steps": 1200}),
    ("16x16, 512 codes, detail weight 4, 2400 steps", {**P4, "num_codes": 512, "detail_weight": 4},
     {"steps": 2400}),
    ("16x16, 512 codes, dead_code_steps 0 (never)", {**P4, "num_codes": 512, "dead_code_steps": 0},
     {"steps": 1200}),
    ("8x8, 256 codes, detail weight 4, 2400 steps", {**TINY, "num_codes": 256, "detail_weight": 4},
     {"steps": 2400}),
    ("16x16, 128 codes, detail weight 4",
     {**P4, "num_codes": 128, "detail_weight": 4}, {"steps": 1200}),
    ("16x16, 512 codes, detail weight 4, dead_code_steps 0",
     {**P4, "num_codes": 512, "dead_code_steps": 0, "detail_weight": 4}, {"steps": 1200}),
    ("16x16, 512 codes, detail weight 4, latent_dim 64",
     {**P4, "num_codes": 512, "latent_dim": 64, "detail_weight": 4}, {"steps": 1200}),
    ("16x16, 512 codes, detail weight 4, 96 channels, latent_dim 64, 2400 steps",
     {**P4, "num_codes": 512, "encoder_channels": 96, "decoder_channels": 96, "latent_dim": 64,
      "detail_weight": 4}, {"steps": 2400}),
]
TRAIN = {"batch_size": 16, "max_lr": 2e-3, "min_lr": 1e-4, "warmup_steps": 20}
HORIZON = 8
ARGS, DATA = None, None  # set by main, read by run in the worker processes


def load_all(train_dir, val_dir, cache):
    """(training frames [N, 3, S, S], [(val frames [T, 3, S, S], segmentation [T, S, S])]),
    read from the shard datasets or from `cache` (.npz, written on the first use)."""
    if cache and os.path.exists(cache):
        z = np.load(cache)
        bounds = np.cumsum(z["val_lengths"])[:-1]
        return torch.from_numpy(from_levels(z["train"])), [
            (torch.from_numpy(from_levels(f)), s) for f, s in zip(np.split(z["val"], bounds),
                                                                  np.split(z["seg"], bounds))]
    train_frames = torch.cat([f for f, _ in load(train_dir, False)])
    val = load(val_dir, True)
    if cache:
        np.savez_compressed(cache, train=to_levels(train_frames),
                 val=np.concatenate([to_levels(f) for f, _ in val]),
                 seg=np.concatenate([s for _, s in val]), val_lengths=[len(f) for f, _ in val])
    return train_frames, val


def to_levels(frames):  # decode_frame's [-1, 1] floats -> the uint8 levels they came from
    return ((frames.numpy() + 1) * np.float32(127.5)).round().astype(np.uint8)


def from_levels(levels):  # as decode_frame: uint8 -> float32 / 127.5 - 1, bit for bit
    return levels.astype(np.float32) / np.float32(127.5) - np.float32(1)


def load(directory, with_seg):
    sys.path.insert(0, os.path.join(twin.SOURCE, "scripts"))
    import wmshard
    ds, episodes = wmshard.Dataset(directory), []
    for k in range(ds.num_episodes):
        blobs = ds.episode(k)[2]
        frames = np.stack([twin.decode_frame(b, 64) for b in blobs["image"]])
        seg = None
        if with_seg:
            seg = np.stack([cv2.imdecode(np.frombuffer(b, np.uint8), cv2.IMREAD_UNCHANGED)
                            for b in blobs["segmentation"]])
        episodes.append((torch.from_numpy(frames), seg))
    return episodes


def train(model_over, train_over, frames, seed=0):
    t = {**TRAIN, **train_over}
    config = {**twin.MODEL_DEFAULTS, **model_over}
    torch.manual_seed(seed)
    model = twin.VqVae(config)
    opt = torch.optim.AdamW(model.parameters(), lr=t["max_lr"], betas=(0.9, 0.9),
                            weight_decay=1e-4)
    draws, codes_rng = np.random.default_rng(seed), twin.Mt19937_64(seed)
    for step in range(t["steps"]):
        for g in opt.param_groups:
            g["lr"] = twin.learning_rate_at(t, step)
        x = frames[draws.integers(0, len(frames), t["batch_size"])]
        if step == 0:
            with torch.no_grad():
                model.quantizer.seed_from_latents(model.encoder(x), codes_rng)
        out = model(x)  # the twin's loss, model.detail_weight included
        q = out["quant"]
        opt.zero_grad()
        out["loss"].backward()
        torch.nn.utils.clip_grad_norm_(model.parameters(), 1.0)
        opt.step()
        model.quantizer.update_usage_and_reseed(q, config["dead_code_steps"], codes_rng)
    return model, config


def to_uint8(x):  # [n, 3, S, S] in [-1, 1] -> [n, S, S, 3] float of uint8 levels
    return ((x.numpy() + 1) * 127.5).round().clip(0, 255).transpose(0, 2, 3, 1)


def frame_psnr(a, b):
    """PSNR of two frames on [0, 255] (uint8 levels as floats); finite (168 dB) for equal ones."""
    return 10 * math.log10(255.0 ** 2 / max(1e-10, float(np.mean((a - b) ** 2))))


def region_mse(real, pred, seg, label):
    """Per-frame MSE over the pixels of `label` (mean over channels); NaN where absent."""
    out = []
    for r, p, s in zip(real, pred, seg):
        m = s == label
        out.append(float(((r - p) ** 2)[m].mean()) if m.any() else math.nan)
    return out


def evaluate(model, config, episodes):
    psnrs, flick, changes, cells = [], 0, 0, 0
    arm, obj, arm_copy, obj_copy = [], [], [], []
    with torch.no_grad():
        for frames, seg in episodes:
            q = model.quantizer(model.encoder(frames))
            recon = model.decoder(q["z_q"]).clamp(-1, 1)
            a, b = to_uint8(frames), to_uint8(recon)
            psnrs += [frame_psnr(x, y) for x, y in zip(a, b)]
            f, c, n = twin.flicker_counts(q["indices"].numpy(), a, config["patch_size"])
            flick, changes, cells = flick + f, changes + c, cells + n
            real, rec = a[1:HORIZON + 1], b[1:HORIZON + 1]
            copy = np.repeat(a[:1], len(real), 0)
            s = seg[1:HORIZON + 1]
            arm.append(np.nanmean(region_mse(real, rec, s, 1)))
            arm_copy.append(np.nanmean(region_mse(real, copy, s, 1)))
            obj.append(np.nanmean(region_mse(real, rec, s, 2)))
            obj_copy.append(np.nanmean(region_mse(real, copy, s, 2)))
    return {"psnr": float(np.mean(psnrs)), "flicker": flick / max(1, changes),
            "change_rate": changes / cells, "arm": np.nanmean(arm) / np.nanmean(arm_copy),
            "object": np.nanmean(obj) / np.nanmean(obj_copy)}


def run(i):
    label, model_over, train_over = VARIANTS[i]
    torch.set_num_threads(ARGS.threads)
    start = time.time()
    model, config = train(model_over, train_over, DATA[0])
    seconds = time.time() - start
    r = evaluate(model.eval(), config, DATA[1])
    return (f"| {i} | {label} | {train_over['steps']} | {seconds:.0f} | {r['psnr']:.1f} | "
            f"{r['flicker']:.3f} | {r['change_rate']:.3f} | {r['arm']:.2f} | {r['object']:.2f} |")


def main():
    global ARGS, DATA
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--train", required=True)
    ap.add_argument("--val", required=True)
    ap.add_argument("--cache", help=".npz of the decoded frames (written when missing)")
    ap.add_argument("--only", type=int, nargs="*", help="row numbers to run (default all)")
    ap.add_argument("--threads", type=int, default=1, help="torch threads per variant")
    ap.add_argument("--jobs", type=int, default=1, help="variants trained at once (processes)")
    ARGS = ap.parse_args()
    DATA = load_all(ARGS.train, ARGS.val, ARGS.cache)
    print(f"{len(DATA[0])} training frames, {len(DATA[1])} validation episodes")
    print("| # | variant | steps | seconds | PSNR dB | flicker | token changes | arm / copy_last "
          "| object / copy_last |")
    print("|---|---|---|---|---|---|---|---|---|")
    rows = [i for i in range(len(VARIANTS)) if not ARGS.only or i in ARGS.only]
    if ARGS.jobs > 1:
        with multiprocessing.get_context("fork").Pool(ARGS.jobs) as pool:
            for line in pool.imap(run, rows):
                print(line, flush=True)
    else:
        for i in rows:
            print(run(i), flush=True)


if __name__ == "__main__":
    main()
