#!/usr/bin/python3
"""Tokenizer architecture variants on the demo data: the table in docs/tokenizer.md, "Choosing
the tiny preset". Each row trains the PyTorch twin (tests/tokenize/vqvae_twin.py) of a config
for a number of steps on 1 thread and prints validation PSNR/SSIM on uint8 frames.

  bench/tokenizer_variants.py --train data/demo/shards/train --val data/demo/shards/val

Not the C++ trainer (no checkpoints, plain uniform frame sampling), so the table can be rerun in
a few minutes and extended with variants the C++ does not have, such as no quantiser.
"""
import argparse
import math
import os
import sys
import time

import numpy as np
import torch
from skimage.metrics import structural_similarity

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests",
                                "tokenize"))
import vqvae_twin as twin  # noqa: E402

OLD_TINY = {"stem_factor": 1, "min_channels": 16}
NEW_TINY = {"stem_factor": 4, "min_channels": 0}
VARIANTS = [  # (label, model overrides, steps, quantise)
    ("old tiny: full-resolution stem, min_channels 16", OLD_TINY, 400, True),
    ("same, no quantiser (plain autoencoder)", OLD_TINY, 400, False),
    ("same, no quantiser", OLD_TINY, 2000, False),
    ("4x pixel-unshuffle stem, 64 channels, 1 block (new tiny)", NEW_TINY, 400, True),
    ("new tiny", NEW_TINY, 800, True),
    ("new tiny", NEW_TINY, 1200, True),
    ("new tiny", NEW_TINY, 2400, True),
    ("8x stem (pure pixel unshuffle), 128 channels, 2 blocks",
     {"stem_factor": 8, "encoder_channels": 128, "decoder_channels": 128, "encoder_layers": 2,
      "decoder_layers": 2, "min_channels": 0}, 800, True),
    ("new tiny, 2048 codes", {**NEW_TINY, "num_codes": 2048}, 400, True),
    ("new tiny, Euclidean lookup", {**NEW_TINY, "l2_normalize": False}, 400, True),
    ("new tiny, dead_code_steps 100", {**NEW_TINY, "dead_code_steps": 100}, 400, True),
    ("16x16 tokens (patch_size 4), 4x stem", {**NEW_TINY, "patch_size": 4}, 800, True),
]
TRAIN = {"batch_size": 16, "max_lr": 2e-3, "min_lr": 1e-4, "warmup_steps": 20, "dead": 10}


def load_frames(directory):
    sys.path.insert(0, os.path.join(twin.SOURCE, "scripts"))
    import wmshard
    ds, frames = wmshard.Dataset(directory), []
    for k in range(ds.num_episodes):
        frames += [twin.decode_frame(b, 64) for b in ds.episode(k)[2]["image"]]
    return torch.from_numpy(np.stack(frames))


def train(overrides, steps, quantise, train_frames, seed=0):
    config = {**twin.MODEL_DEFAULTS, "dead_code_steps": TRAIN["dead"], **overrides}
    torch.manual_seed(seed)
    model = twin.VqVae(config)
    opt = torch.optim.AdamW(model.parameters(), lr=TRAIN["max_lr"], betas=(0.9, 0.9),
                            weight_decay=1e-4)
    draws, codes_rng = np.random.default_rng(seed), twin.Mt19937_64(seed)
    for step in range(steps):
        for g in opt.param_groups:
            g["lr"] = twin.learning_rate_at({**TRAIN, "steps": steps}, step)
        x = train_frames[draws.integers(0, len(train_frames), TRAIN["batch_size"])]
        z = model.encoder(x)
        loss = 0.0
        if quantise:
            if step == 0:
                with torch.no_grad():
                    model.quantizer.seed_from_latents(z, codes_rng)
            q = model.quantizer(z)
            z, loss = q["z_q"], q["codebook_loss"] + model.beta * q["commitment"]
        loss = loss + (model.decoder(z) - x).abs().mean()
        opt.zero_grad()
        loss.backward()
        torch.nn.utils.clip_grad_norm_(model.parameters(), 1.0)
        opt.step()
        if quantise:
            model.quantizer.update_usage_and_reseed(q, config["dead_code_steps"], codes_rng)
    return model


def evaluate(model, quantise, frames):
    with torch.no_grad():
        z = [model.encoder(frames[i:i + 64]) for i in range(0, len(frames), 64)]
        if quantise:
            z = [model.quantizer(zi)["z_q"] for zi in z]
        recon = torch.cat([model.decoder(zi).clamp(-1, 1) for zi in z])
    a = ((frames.numpy() + 1) * 127.5).round().transpose(0, 2, 3, 1)
    b = ((recon.numpy() + 1) * 127.5).round().transpose(0, 2, 3, 1)
    psnr = 10 * math.log10(255.0 ** 2 / float(np.mean((a - b) ** 2)))
    ssim = np.mean([structural_similarity(a[i], b[i], channel_axis=2, data_range=255)
                    for i in range(len(a))])
    return psnr, float(ssim)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--train", required=True)
    ap.add_argument("--val", required=True)
    ap.add_argument("--only", type=int, nargs="*", help="row numbers to run (default all)")
    args = ap.parse_args()
    torch.set_num_threads(1)
    train_frames, val_frames = load_frames(args.train), load_frames(args.val)
    print(f"{len(train_frames)} training / {len(val_frames)} validation frames")
    print("| variant (8x8 tokens unless noted) | steps | seconds | PSNR dB | SSIM |")
    print("|---|---|---|---|---|")
    for i, (label, overrides, steps, quantise) in enumerate(VARIANTS):
        if args.only and i not in args.only:
            continue
        start = time.time()
        model = train(overrides, steps, quantise, train_frames)
        seconds = time.time() - start
        psnr, ssim = evaluate(model.eval(), quantise, val_frames)
        print(f"| {label} | {steps} | {seconds:.0f} | {psnr:.1f} | {ssim:.2f} |", flush=True)


if __name__ == "__main__":
    main()
