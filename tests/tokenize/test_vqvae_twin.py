#!/usr/bin/python3
"""The C++ tokenizer against its PyTorch twin (tests/tokenize/vqvae_twin.py).

Small C++ checkpoints are trained here (wm-tokenize train, 20 steps, 1 thread) on a tabletop
set from wm-gen-tabletop + wm-ingest: A with the channel schedule (min_channels 8, 2 stride-2
levels), L2-normalised lookup and the detail-weighted L1
(model.detail_weight), B with Euclidean lookup, constant width, a pixel-unshuffle
stem (factor 2) and 2 levels, C with the anchor decoder (model.anchor_decoder; anchors drawn as
FrameSampler::TrainingAnchors, and the previous frame in the inference checks), D with the
anchor's flow and the change weight (model.anchor_flow, model.change_weight), E with 3 residual
levels (model.levels: codes [n, 3, g, g], each residual codebook re-seeded on its own), F with
the cell-local encoder (model.encoder: cell_local). For each,
the twin loads checkpoint.wmt with its own archive reader and must give, on the set's frames plus
random frames (tokenizer_ref_tool runs the C++ side):
  - identical codes (Tokenizer::Encode), reconstructions and encoder features within 1e-5;
  - the loss terms of one forward pass within 1e-5, and the same parameter gradients;
  - trained in Python from the same seed and config (torch.optim.AdamW, the same frame draws),
    a checkpoint equal to the C++ one bit for bit: weights, AdamW moments, dead-code counters
    and the dead-code RNG state.
Also: val.csv's flicker and token_change_rate equal the twin's count (vqvae_twin.flicker_counts);
`wm-tokenize encode` stores the twin's codes, and refuses a residual tokenizer (token datasets
hold one code per cell) naming it; corrupt or missing checkpoints fail cleanly.
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile

import numpy as np
import torch

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import vqvae_twin as twin  # noqa: E402

SOURCE = twin.SOURCE
BIN = os.environ.get("WM_BIN_DIR", os.path.join(SOURCE, "build/bin"))
TOL = 1e-5
passed, failures = [], []

CONFIGS = {
    "A (cosine, min_channels 8, detail weight)": """
model: {image_size: 32, patch_size: 4, encoder_channels: 32, encoder_layers: 1,
        decoder_channels: 32, decoder_layers: 1, min_channels: 8, latent_dim: 8,
        num_codes: 64, l2_normalize: true, beta: 0.25, dead_code_steps: 5, detail_weight: 3}
train: {batch_size: 8, steps: 20, max_lr: 3.0e-3, min_lr: 3.0e-4, warmup_steps: 3, threads: 1,
        seed: 3, checkpoint_every: 20, log_every: 5}
""",
    "B (euclidean, constant width, pixel-unshuffle stem)": """
model: {image_size: 32, patch_size: 8, stem_factor: 2, encoder_channels: 16, encoder_layers: 2,
        decoder_channels: 24, decoder_layers: 1, min_channels: 0, latent_dim: 6,
        num_codes: 32, l2_normalize: false, beta: 0.5, dead_code_steps: 4}
train: {batch_size: 6, steps: 20, max_lr: 2.0e-3, min_lr: 1.0e-4, warmup_steps: 5, threads: 1,
        seed: 7, checkpoint_every: 20, log_every: 5, weight_decay: 1.0e-3, grad_clip: 0.5}
""",
    "C (anchor decoder, stem 2, min_channels 8)": """
model: {image_size: 32, patch_size: 8, stem_factor: 2, encoder_channels: 16, encoder_layers: 1,
        decoder_channels: 16, decoder_layers: 1, min_channels: 8, latent_dim: 8,
        num_codes: 32, l2_normalize: true, beta: 0.25, dead_code_steps: 5, detail_weight: 2,
        anchor_decoder: true}
train: {batch_size: 8, steps: 20, max_lr: 3.0e-3, min_lr: 3.0e-4, warmup_steps: 3, threads: 1,
        seed: 5, checkpoint_every: 20, log_every: 5, anchor_max_gap: 3, anchor_dropout: 0.7}
""",
    "D (anchor decoder with the anchor's flow and the change weight)": """
model: {image_size: 32, patch_size: 8, stem_factor: 4, encoder_channels: 16, encoder_layers: 1,
        decoder_channels: 16, decoder_layers: 1, min_channels: 0, latent_dim: 8,
        num_codes: 32, l2_normalize: true, beta: 0.25, dead_code_steps: 5, detail_weight: 2,
        anchor_decoder: true, anchor_flow: true, change_weight: 4}
train: {batch_size: 8, steps: 20, max_lr: 3.0e-3, min_lr: 3.0e-4, warmup_steps: 3, threads: 1,
        seed: 6, checkpoint_every: 20, log_every: 5, anchor_max_gap: 3, anchor_dropout: 0.4}
""",
    "E (3 residual levels, cosine first level, pixel-unshuffle stem)": """
model: {image_size: 32, patch_size: 8, stem_factor: 2, encoder_channels: 16, encoder_layers: 1,
        decoder_channels: 16, decoder_layers: 1, min_channels: 0, latent_dim: 8,
        num_codes: 16, l2_normalize: true, beta: 0.25, dead_code_steps: 3, levels: 3}
train: {batch_size: 8, steps: 20, max_lr: 3.0e-3, min_lr: 3.0e-4, warmup_steps: 3, threads: 1,
        seed: 8, checkpoint_every: 20, log_every: 5}
""",
    "F (cell-local encoder, anchor decoder)": """
model: {image_size: 32, patch_size: 8, stem_factor: 2, encoder: cell_local, encoder_channels: 16,
        decoder_channels: 16, decoder_layers: 1, latent_dim: 8, num_codes: 16,
        l2_normalize: true, beta: 0.25, dead_code_steps: 3, detail_weight: 2,
        anchor_decoder: true}
train: {batch_size: 8, steps: 20, max_lr: 3.0e-3, min_lr: 3.0e-4, warmup_steps: 3, threads: 1,
        seed: 9, checkpoint_every: 20, log_every: 5, anchor_max_gap: 3, anchor_dropout: 0.5}
""",
}


def check(ok, what):
    print(("ok    " if ok else "FAIL  ") + what)
    (passed if ok else failures).append(what)


def run(args, **kw):
    return subprocess.run([str(a) for a in args], check=True, capture_output=True, text=True, **kw)


def make_dataset(tmp):
    raw, shards = os.path.join(tmp, "raw"), os.path.join(tmp, "shards")
    run([os.path.join(BIN, "wm-gen-tabletop"), "--out", raw, "--train-episodes", 2,
         "--val-episodes", 1, "--size", 64, "--max-steps", 8, "--seed", 0])
    run([os.path.join(BIN, "wm-ingest"), "--format", "rlds", "--input",
         os.path.join(raw, "wm_tabletop/1.0.0"), "--split", "train", "--output", shards,
         "--configs", os.path.join(SOURCE, "configs"), "--log-level", "warn"])
    return shards


def max_diff(a, b):
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    return float(np.abs(a - b).max()) if a.shape == b.shape else float("inf")


def compare_inference(label, model, frames, ref_dir, cpp):
    x = torch.from_numpy(frames)
    codes = twin.encode(model, x).numpy()
    cpp_codes = np.load(os.path.join(ref_dir, "codes.npy"))
    check(cpp_codes.shape == codes.shape and (cpp_codes == codes).all(),
          f"{label}: codes {list(codes.shape)} identical ({len(np.unique(codes))} distinct)")
    anchors = twin.previous_frames(x) if model.anchored else None
    err = max_diff(np.load(os.path.join(ref_dir, "reconstruction.npy")),
                   twin.reconstruct(model, x, anchors).numpy())
    check(err <= TOL, f"{label}: reconstruction max |diff| {err:.1e}"
          f"{' (anchors: the previous frames)' if model.anchored else ''}")
    feats = twin.encoder_features(model, x)
    check([list(f.shape) for f in feats] == cpp["features"],
          f"{label}: encoder feature shapes {[list(f.shape)[1:] for f in feats]}")
    errs = [max_diff(np.load(os.path.join(ref_dir, f"features_{k}.npy")), f.numpy())
            for k, f in enumerate(feats)]
    check(max(errs) <= TOL, f"{label}: encoder features max |diff| {max(errs):.1e}")


def compare_losses(label, model, frames, cpp, grads_path):
    model.train()
    x = torch.from_numpy(frames)
    out = model(x, twin.previous_frames(x) if model.anchored else None)
    out["loss"].backward()
    ours = {"loss": out["loss"].item(), "recon_l1": out["recon_l1"].item(),
            "codebook_loss": out["quant"]["codebook_loss"].item(),
            "commitment": out["quant"]["commitment"].item()}
    err = max(abs(ours[k] - cpp["losses"][k]) for k in ours)
    check(err <= TOL, f"{label}: loss terms max |diff| {err:.1e} "
          f"({', '.join(f'{k} {v:.5f}' for k, v in ours.items())})")
    check(abs(out["quant"]["perplexity"] - cpp["losses"]["perplexity"]) <= 1e-9 and
          out["quant"]["usage"] == cpp["losses"]["usage"], f"{label}: perplexity and usage equal")
    grads, _ = twin.read_archive(grads_path)
    names = [n for n, _ in model.named_parameters()]
    ok = sorted(grads) == sorted("grad/" + n for n in names)
    worst = max(max_diff(grads["grad/" + n], p.grad.numpy()) /
                max(1e-12, float(p.grad.abs().max())) for n, p in model.named_parameters())
    check(ok and worst <= 1e-4, f"{label}: gradients of all {len(names)} parameters, max relative "
          f"|diff| {worst:.1e} (straight-through and stop-gradients agree)")


def compare_flicker(label, model, run_dir, sampler, stored):
    """val.csv's flicker and token_change_rate (C++, --val-data = the training set) against the
    twin's codes counted by vqvae_twin.flicker_counts over the same episodes."""
    patch = stored["model"]["patch_size"]
    total = np.zeros(3, np.int64)
    for k in range(len(sampler.steps[0])):
        frames = sampler.frames(0, k)
        codes = twin.encode(model, torch.from_numpy(frames)).numpy()
        levels = ((frames + 1) * 127.5).round().clip(0, 255).transpose(0, 2, 3, 1)
        total += twin.flicker_counts(codes, levels, patch)
    with open(os.path.join(run_dir, "val.csv")) as f:
        last = f.read().split()[-1].split(",")
    ours = (total[0] / max(1, total[1]), total[1] / total[2])
    err = max(abs(float(last[4]) - ours[0]), abs(float(last[5]) - ours[1]))
    # C's 20-step anchored tokenizer keeps one code per episode cell (the anchor carries the
    # frames), so only A and B exercise the count; for C, 0 / 0 must still agree.
    exercised = total[1] > 0 or model.anchored
    check(err <= 1e-5 and exercised, f"{label}: val.csv flicker {last[4]} / change rate "
          f"{last[5]} = the twin's count {ours[0]:.6f} / {ours[1]:.6f} "
          f"({total[0]} of {total[1]} changes static)")


def train_twin(label, run_dir, shards):
    """The twin trained in Python reproduces the C++ checkpoint bit for bit."""
    tensors, header = twin.read_archive(os.path.join(run_dir, "checkpoint.wmt"))
    meta = header["meta"]
    config, t = meta["config"], meta["config"]["train"]
    trainer = twin.Trainer(config)
    sampler = twin.FrameSampler([shards], config["data"]["image_key"],
                                config["model"]["image_size"], t["seed"])
    reseeded = []
    blanks = []
    for step in range(meta["step"]):
        refs = sampler.batch_refs(step, t["batch_size"])
        anchors = None
        if config["model"].get("anchor_decoder"):
            drawn = sampler.training_anchors(refs, step, t["anchor_max_gap"], t["anchor_dropout"])
            blanks += [blank for _, blank in drawn]
            anchors = sampler.load_anchors(drawn)
        out = trainer.train_step(sampler.load(refs), anchors)
        reseeded.append(out["reseeded"])
    if blanks:
        check(0 < sum(blanks) < len(blanks), f"{label}: {sum(blanks)} of {len(blanks)} training "
              "anchors blank (both paths exercised)")
    ours = {**{"model/" + k: v.numpy() for k, v in trainer.model.state_dict().items()},
            **{k: v.numpy() for k, v in trainer.moments().items()}}
    same_names = sorted(ours) == sorted(tensors)
    unequal = [k for k in tensors if k in ours and not np.array_equal(tensors[k], ours[k])]
    worst = max([max_diff(tensors[k], ours[k]) for k in unequal], default=0.0)
    check(same_names and not unequal,
          f"{label}: twin trained {meta['step']} steps == C++ checkpoint, all {len(tensors)} "
          f"tensors bit for bit (unequal: {unequal[:3]}{'...' if len(unequal) > 3 else ''}, "
          f"max |diff| {worst:.1e}; codes re-seeded {sum(reseeded)})")
    state = trainer.reseed_rng
    text = " ".join(str(x) for x in state.mt) + f" {state.i}"
    check(text == meta["rng"]["reseed_mt19937_64"], f"{label}: dead-code RNG state equal")
    check(trainer.optimizer.state[next(trainer.model.parameters())]["step"].item() ==
          meta["adamw_step"], f"{label}: AdamW step count {meta['adamw_step']}")
    check(sum(reseeded) > 0, f"{label}: dead codes were re-seeded (the path is exercised)")
    if trainer.model.anchor_flow is not None:  # it started at zero: training must move it
        moved = float(trainer.model.anchor_flow.weight.abs().max())
        check(moved > 0, f"{label}: the anchor's flow learned (max |weight| {moved:.1e})")


def encode_with_cli(run_dir, shards, out, model, margin):
    """Runs wm-tokenize encode (--hysteresis margin) into `out`; returns the dataset as
    wmshard.py reads it and, per episode, (stored codes, the twin's codes of its frames)."""
    sys.path.insert(0, os.path.join(SOURCE, "scripts"))
    import wmshard
    run([os.path.join(BIN, "wm-tokenize"), "encode", "--checkpoint", run_dir, "--data", shards,
         "--out", out, "--hysteresis", margin])
    tokens, sampler = wmshard.TokenDataset(out), twin.FrameSampler([shards], "image", 32, 0)
    return tokens, [(np.array(tokens.episode(k)["tokens"]),
                     twin.encode_episode(model, torch.from_numpy(sampler.frames(0, k)), margin))
                    for k in range(tokens.num_episodes)]


def check_encode_cli(label, run_dir, shards, tmp, model):
    """wm-tokenize encode (C++ JPEG decode + Tokenizer) stores the twin's codes, without and with
    code hysteresis (--hysteresis: fewer code changes, the twin's sticky codes)."""
    changes = {}
    for margin in (0.0, 0.002):
        out = os.path.join(tmp, f"tokens{margin}")
        shutil.rmtree(out, ignore_errors=True)
        tokens, episodes = encode_with_cli(run_dir, shards, out, model, margin)
        changes[margin] = sum(int((ours[1:] != ours[:-1]).sum()) for _, ours in episodes)
        check(all(np.array_equal(stored, ours.numpy().reshape(stored.shape))
                  for stored, ours in episodes),
              f"{label}: wm-tokenize encode --hysteresis {margin} stores the twin's codes "
              f"({tokens.num_episodes} episodes, {changes[margin]} code changes)")
    check(0 < changes[0.002] < changes[0.0], f"{label}: hysteresis lowers the code changes, "
          "and some remain")


def check_encode_levels(label, run_dir, shards, tmp, model):
    """A residual tokenizer's token dataset (format_version 3) holds every level's codes, [F,
    levels, g, g], the twin's; code hysteresis (one code per cell) is refused, naming the
    checkpoint and its levels."""
    out = os.path.join(tmp, "tokens_levels")
    tokens, episodes = encode_with_cli(run_dir, shards, out, model, 0.0)
    levels = len(model.quantizer.levels)
    ok = tokens.index["format_version"] == 3 and tokens.index["tokenizer"]["levels"] == levels
    for stored, ours in episodes:
        ok &= stored.shape[1] == levels and np.array_equal(stored, ours.numpy())
    check(ok, f"{label}: wm-tokenize encode stores the twin's {levels} levels a cell "
          f"(format_version 3, {tokens.num_episodes} episodes)")
    bad = subprocess.run([os.path.join(BIN, "wm-tokenize"), "encode", "--checkpoint", run_dir,
                          "--data", shards, "--out", out + "_sticky", "--hysteresis", "0.002"],
                         capture_output=True, text=True)
    check(bad.returncode == 1 and "checkpoint.wmt" in bad.stderr and
          f"model.levels = {levels}" in bad.stderr and
          not os.path.exists(os.path.join(out + "_sticky", "index.json")),
          f"{label}: --hysteresis is refused, exit 1: {bad.stderr.strip()[-120:]}")


def check_errors(run_dir, frames_path, tmp):
    tool = os.path.join(BIN, "tokenizer_ref_tool")
    bad = subprocess.run([tool, "--checkpoint", os.path.join(tmp, "absent.wmt"), "--frames",
                          frames_path], capture_output=True, text=True)
    check(bad.returncode == 1 and "absent.wmt" in bad.stderr, "missing checkpoint: exit 1, named")
    short = os.path.join(tmp, "short.f32")
    with open(short, "wb") as f:
        f.write(b"\0" * 100)
    bad = subprocess.run([tool, "--checkpoint", run_dir, "--frames", short],
                         capture_output=True, text=True)
    check(bad.returncode == 1 and "short.f32" in bad.stderr, "partial frame file: exit 1, named")
    corrupt = os.path.join(tmp, "corrupt.wmt")
    blob = bytearray(open(os.path.join(run_dir, "checkpoint.wmt"), "rb").read())
    blob[-3] ^= 0x40  # inside the last tensor
    open(corrupt, "wb").write(bytes(blob))
    try:
        twin.read_archive(corrupt)
        check(False, "twin reader rejects a flipped bit")
    except AssertionError as e:
        check("CRC32C" in str(e), f"twin reader rejects a flipped bit ({e})")
    bad = subprocess.run([tool, "--checkpoint", corrupt, "--frames", frames_path],
                         capture_output=True, text=True)
    check(bad.returncode == 1 and "corrupt.wmt" in bad.stderr, "C++ rejects it too: exit 1")


def main():
    torch.set_num_threads(1)
    with tempfile.TemporaryDirectory() as tmp:
        shards = make_dataset(tmp)
        sampler = twin.FrameSampler([shards], "image", 32, 0)
        data = np.concatenate([sampler.frames(0, k) for k in range(len(sampler.steps[0]))])
        noise = np.random.default_rng(0).uniform(-1, 1, (5, 3, 32, 32)).astype(np.float32)
        frames = np.ascontiguousarray(np.concatenate([data, noise]))  # [n, 3, 32, 32]
        frames_path = os.path.join(tmp, "frames.f32")
        frames.tofile(frames_path)
        for i, (label, yaml) in enumerate(CONFIGS.items()):
            config, run_dir, ref = (os.path.join(tmp, f"{name}{i}") for name in
                                    ("config.yaml", "run", "ref"))
            with open(config, "w") as f:
                f.write(yaml)
            run([os.path.join(BIN, "wm-tokenize"), "train", "--config", config, "--data", shards,
                 "--val-data", shards, "--out", run_dir])
            grads = os.path.join(ref, "grads.wmt")
            os.makedirs(ref)
            cpp = json.loads(run([os.path.join(BIN, "tokenizer_ref_tool"), "--checkpoint",
                                  run_dir, "--frames", frames_path, "--out-dir", ref, "--losses",
                                  "--grads", grads]).stdout)
            model, stored, _ = twin.load_checkpoint(run_dir)
            check(True, f"{label}: checkpoint loads into the twin, all names and shapes equal")
            compare_inference(label, model, frames, ref, cpp)
            compare_losses(label, model, frames, cpp, grads)
            compare_flicker(label, model, run_dir, sampler, stored)
            train_twin(label, run_dir, shards)
            torch.set_num_threads(1)
            if i == 0:
                check_encode_cli(label, run_dir, shards, tmp, model.eval())
                check_errors(run_dir, frames_path, tmp)
            if stored["model"].get("levels", 1) > 1:
                check_encode_levels(label, run_dir, shards, tmp, model.eval())
    print(f"{len(passed)} passed, {len(failures)} failed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
