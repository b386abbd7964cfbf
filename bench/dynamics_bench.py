#!/usr/bin/python3
"""Dynamics-model training throughput: wm-train (C++/LibTorch) vs its PyTorch twin
(tests/train/dynamics_twin.py) on the same config, same batch shape and thread count.
C++ is timed end to end per step (sampling from a token dataset, masks, forward, backward,
all-reduce no-op, clipping, AdamW); the twin is timed on ready-made random batches (a bound that
favours it). Prints training tokens/s (B x T x grid tokens per step) and the ratio
C++ / PyTorch (goal >= 1.0x)."""
import argparse
import os
import subprocess
import sys
import tempfile
import time

import torch
import yaml

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tests", "train"))
import dynamics_twin  # noqa: E402


def load_config(path):
    """The YAML preset; the twin needs every key, which the presets spell out."""
    return yaml.safe_load(open(path))


def twin_tokens_per_s(cfg, steps, threads):
    torch.set_num_threads(threads)
    torch.manual_seed(0)
    m, t, p = cfg["model"], cfg["train"], cfg["policy"]
    model = dynamics_twin.WorldModel(cfg)
    dyn = [q for n, q in model.named_parameters() if not n.startswith("policy.")]
    pol = [q for n, q in model.named_parameters() if n.startswith("policy.")]
    opt = torch.optim.AdamW(model.parameters(), lr=t["max_lr"], betas=(t["beta1"], t["beta2"]),
                            weight_decay=t["weight_decay"])
    b, tt, n = t["batch_size"], m["context_frames"], m["grid_h"] * m["grid_w"]

    def batch():
        mask = torch.rand(b, tt, n) < 0.5
        mask[:, 0] = False
        return (torch.randint(m["num_codes"], (b, tt, n)),
                torch.randn(b, tt, dynamics_twin.action_dim(m)), torch.rand(b, tt),
                (torch.rand(b, tt) > 0.9).float(), mask,
                torch.rand(b, p["categories"], p["classes"]))

    def step(x):
        opt.zero_grad()
        model.losses(*x)["total"].backward()
        torch.nn.utils.clip_grad_norm_(dyn, t["grad_clip"])
        torch.nn.utils.clip_grad_norm_(pol, t["grad_clip"])
        opt.step()

    batches = [batch() for _ in range(4)]
    for i in range(3):  # warm-up
        step(batches[i % 4])
    start = time.perf_counter()
    for i in range(steps):
        step(batches[i % 4])
    return steps * b * tt * n / (time.perf_counter() - start)


def cpp_tokens_per_s(bin_dir, config, steps, threads, tmp):
    tokens = os.path.join(tmp, "tokens")
    cfg = load_config(config)
    m = cfg["model"]
    subprocess.run([os.path.join(bin_dir, "dynamics_test_tool"), "make-tokens", "--out", tokens,
                    "--episodes", "32", "--steps", "24", "--grid", str(m["grid_h"]),
                    "--codes", str(m["num_codes"])], check=True)
    out = os.path.join(tmp, "run")
    subprocess.run([os.path.join(bin_dir, "wm-train"), "--config", config, "--tokens", tokens,
                    "--out", out, "--steps", str(steps + 3), "--threads", str(threads)],
                   check=True, capture_output=True)
    # metrics.csv rows every log_every steps; tokens_per_s column, skipping the first window.
    rows = [r.split(",") for r in open(os.path.join(out, "metrics.csv")).read().split("\n")[1:] if r]
    rates = [float(r[9]) for r in rows[1:]] or [float(rows[0][9])]
    return sum(rates) / len(rates)


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--bin", default="build/bin")
    ap.add_argument("--config", default=os.path.join(ROOT, "configs", "dynamics", "tiny.yaml"))
    ap.add_argument("--steps", type=int, default=30)
    ap.add_argument("--threads", type=int, default=2)
    a = ap.parse_args()
    cfg = load_config(a.config)
    with tempfile.TemporaryDirectory() as tmp:
        cpp = cpp_tokens_per_s(a.bin, a.config, a.steps, a.threads, tmp)
    twin = twin_tokens_per_s(cfg, a.steps, a.threads)
    b = cfg["train"]["batch_size"]
    per_step = b * cfg["model"]["context_frames"] * cfg["model"]["grid_h"] * cfg["model"]["grid_w"]
    label = "run (%s, %d threads)" % (os.path.basename(a.config), a.threads)
    print("%-34s %12s %10s" % (label, "tokens/s", "steps/s"))
    print("%-34s %12.0f %10.2f" % ("wm-train (C++, incl. data)", cpp, cpp / per_step))
    print("%-34s %12.0f %10.2f" % ("PyTorch twin (random batches)", twin, twin / per_step))
    print("ratio C++ / PyTorch: %.2fx (goal >= 1.0x)" % (cpp / twin))
    return 0


if __name__ == "__main__":
    sys.exit(main())
