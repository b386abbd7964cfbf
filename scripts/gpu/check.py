#!/usr/bin/env python3
"""GPU checks beside the C++ runs (docs/gpu.md), with the machine's PyTorch:

numerics  The dynamics model's forward on CUDA fp32 and bf16 against the C++ CPU fp32 outputs:
          dynamics_test_tool writes random weights, inputs and the C++ CPU outputs; the PyTorch
          twin (tests/train/dynamics_twin.py) recomputes them on the GPU. The tokenizer's C++
          encode/decode on CUDA against the C++ CPU on the same checkpoint and frames
          (tokenizer_ref_tool --device).
flops     FLOPs of one meta64 dynamics training step (forward + backward) counted by
          torch.utils.flop_counter on the twin built from a wm-train checkpoint's config, and
          a torch.profiler table of where the twin's bf16 step spends its GPU time.
Writes OUT/check.json and prints a summary."""
import argparse
import json
import os
import subprocess
import sys
import tempfile

import numpy as np
import torch

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "tests", "train"))
import dynamics_twin  # noqa: E402


def dynamics_numerics(bin_dir, tmp):
    path = os.path.join(tmp, "ref.wmt")
    subprocess.run([os.path.join(bin_dir, "dynamics_test_tool"), "reference", "--out", path,
                    "--seed", "3", "--tied"], check=True)
    tensors, meta = dynamics_twin.read_archive(path)
    k = meta["config"]["model"]["num_codes"]
    model = dynamics_twin.load_world_model(tensors, meta["config"]).cuda()
    t = {n[len("input/"):]: torch.from_numpy(v).cuda() for n, v in tensors.items()
         if n.startswith("input/")}
    mask = t["mask"].bool()
    want = tensors["output/logits"]
    out = {}
    for name, dtype in (("cuda_fp32", None), ("cuda_bf16_autocast", torch.bfloat16)):
        with torch.no_grad(), torch.autocast("cuda", dtype=dtype or torch.float32,
                                             enabled=dtype is not None):
            z = model.dynamics_z(t["tokens"], t["actions"])
            logits, _, _ = model.dynamics(t["tokens"].masked_fill(mask, k), t["actions"], z)
        got = logits.float().cpu().numpy()
        out[name] = {"logits_max_abs_diff": float(np.abs(got - want).max()),
                     "logits_scale": float(np.abs(want).max()),
                     "argmax_agreement": float((got.argmax(-1) == want.argmax(-1)).mean())}
    return out


def tokenizer_numerics(bin_dir, checkpoint, size, tmp):
    frames = np.random.default_rng(0).uniform(-1, 1, (8, 3, size, size)).astype(np.float32)
    frames_path = os.path.join(tmp, "frames.f32")
    frames.tofile(frames_path)
    res = {}
    for device in ("cpu", "cuda"):
        d = os.path.join(tmp, "tok-" + device)
        subprocess.run([os.path.join(bin_dir, "tokenizer_ref_tool"), "--checkpoint", checkpoint,
                        "--frames", frames_path, "--out-dir", d, "--device", device], check=True)
        res[device] = {f[:-4]: np.load(os.path.join(d, f)) for f in os.listdir(d)
                       if f.endswith(".npy")}
    out = {}
    for name, a in res["cpu"].items():
        b = res["cuda"][name]
        if name == "codes":
            out["codes_agreement"] = float((a == b).mean())
        else:
            out[name + "_max_abs_diff"] = float(np.abs(a.astype(np.float64) - b).max())
    return out


def dynamics_flops(checkpoint, batch):
    tensors, meta = dynamics_twin.read_archive(checkpoint)
    config = meta["config"]
    m, p = config["model"], config["policy"]
    model = dynamics_twin.WorldModel(config).cuda()
    T, N, k = m["context_frames"], m["grid_h"] * m["grid_w"], m["num_codes"]
    g = torch.Generator(device="cuda").manual_seed(0)
    tokens = torch.randint(k, (batch, T, N), device="cuda", generator=g)
    actions = torch.randn(batch, T, dynamics_twin.action_dim(m), device="cuda", generator=g)
    rewards, terminals = torch.rand(batch, T, device="cuda"), torch.zeros(batch, T, device="cuda")
    mask = torch.rand(batch, T, N, device="cuda", generator=g) < 0.5
    z_noise = torch.rand(batch, p["categories"], p["classes"], device="cuda")
    opt = torch.optim.AdamW(model.parameters(), lr=1e-5)

    def step():
        with torch.autocast("cuda", dtype=torch.bfloat16):
            loss = model.losses(tokens, actions, rewards, terminals, mask, z_noise)["total"]
        loss.backward()
        opt.step()
        opt.zero_grad(set_to_none=True)

    from torch.utils.flop_counter import FlopCounterMode
    counter = FlopCounterMode(display=False)
    with counter:
        step()
    for _ in range(3):
        step()
    torch.cuda.synchronize()
    start, end = torch.cuda.Event(enable_timing=True), torch.cuda.Event(enable_timing=True)
    start.record()
    for _ in range(5):
        step()
    end.record()
    torch.cuda.synchronize()
    twin_s = start.elapsed_time(end) / 5 / 1000
    from torch.profiler import ProfilerActivity, profile
    with profile(activities=[ProfilerActivity.CUDA]) as prof:
        for _ in range(2):
            step()
        torch.cuda.synchronize()
    table = prof.key_averages().table(sort_by="cuda_time_total", row_limit=15)
    flops = counter.get_total_flops()
    return {"flops_per_step": flops, "flops_per_token": flops / (batch * T * N), "batch": batch,
            "tokens_per_step": batch * T * N, "twin_seconds_per_step": twin_s,
            "parameters": sum(x.numel() for x in model.parameters())}, table


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--bin", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--tokenizer", help="a tokenizer run (checkpoint.wmt) for the numerics")
    ap.add_argument("--tokenizer-size", type=int, default=64)
    ap.add_argument("--dynamics", help="a wm-train checkpoint.wmt whose config the FLOPs use")
    # The twin writes attention out: at meta64's batch 64 its [B*T, H, 256, 256] scores and the
    # policy model's activations did not fit in 140 GB (docs/gpu.md). FLOPs scale with the batch,
    # so count at 8 and compare per token.
    ap.add_argument("--batch", type=int, default=8)
    a = ap.parse_args()
    result = {"torch": torch.__version__, "device": torch.cuda.get_device_name(0)}
    with tempfile.TemporaryDirectory() as tmp:
        result["dynamics_numerics"] = dynamics_numerics(a.bin, tmp)
        print(json.dumps(result, indent=1), flush=True)
        if a.tokenizer:
            result["tokenizer_numerics"] = tokenizer_numerics(a.bin, a.tokenizer,
                                                              a.tokenizer_size, tmp)
            print(json.dumps(result["tokenizer_numerics"], indent=1), flush=True)
    if a.dynamics:
        result["dynamics_flops"], table = dynamics_flops(a.dynamics, a.batch)
        print(json.dumps(result["dynamics_flops"], indent=1))
        print(table)
        open(os.path.join(a.out, "twin_profile.txt"), "w").write(table)
    json.dump(result, open(os.path.join(a.out, "check.json"), "w"), indent=1)


if __name__ == "__main__":
    main()
