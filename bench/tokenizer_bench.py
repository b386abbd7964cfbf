#!/usr/bin/python3
"""Tokenizer speed: wm-tokenize (C++, LibTorch) vs its PyTorch twin (tests/tokenize/vqvae_twin.py)
in one run, on the same config, data, batch size and torch thread count.

  python3 bench/tokenizer_bench.py [--bin build/bin] [--config configs/tokenizer/tiny.yaml]
                                   [--threads N] [--steps 60] [--repeat 5] [--rounds 3]
                                   [--tuned-malloc]

Data: wm-gen-tabletop (160 train episodes, up to 40 steps, 64x64 JPEG; enough frames that the C++
process start-up does not decide the end-to-end row) + wm-ingest, made once in
$BENCH_DIR/tokenizer (default /tmp/wmkit-bench).
  train   C++: `wm-tokenize train --steps N`; steps/s from metrics.csv after its first row
          (start-up and code seeding excluded); its frame loader runs on a second thread,
          overlapped. Twin: the same loop in Python (same frame draws and anchors, code seeding,
          dead-code draws, lr schedule, clipping, torch.optim.AdamW) on frames decoded before
          timing, the same steps timed. Same seed, so the bench also says whether the
          checkpoints are equal.
  encode  "model only" (decoding excluded in both): tokenizer_ref_tool --repeat (Tokenizer::
          Encode) vs the twin's encode of the same float frames, 64 per forward pass.
          "with JPEG decode" (decoding included in both): `wm-tokenize encode` (process start-up,
          checkpoint load, shard read, JPEG decode on a second thread, encode, token dataset
          write) vs the twin after `import torch` (load, scripts/wmshard.py read, cv2 decode,
          encode; nothing written).
Every measurement runs in a fresh process on both sides: glibc's malloc state (which decides how
often big tensors are returned to the kernel and page-faulted back) then starts the same.
CPU columns divide by process CPU time instead of wall time: steadier when other jobs share the
cores. C++ training CPU per step is the difference between an N-step and a 10-step run.
--tuned-malloc runs the C++ tools with MALLOC_MMAP_THRESHOLD_ and MALLOC_TRIM_THRESHOLD_ at 1 GiB
(what mallopt() at tool start-up would do); the twin keeps glibc's defaults.
The sides alternate for --rounds rounds and each keeps its best. Exit codes: 0 ok, 1 a run failed.
"""
import argparse
import csv
import json
import os
import resource
import shutil
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE = os.path.join(HERE, "..")
sys.path.insert(0, os.path.join(SOURCE, "tests", "tokenize"))
sys.path.insert(0, os.path.join(SOURCE, "scripts"))
TUNED = {"MALLOC_MMAP_THRESHOLD_": str(1 << 30), "MALLOC_TRIM_THRESHOLD_": str(1 << 30)}


def run(args, env=None):
    """Runs a process; returns (stdout, its CPU seconds)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    out = subprocess.run([str(a) for a in args], check=True, capture_output=True, text=True,
                         env={**os.environ, **(env or {})})
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return out.stdout, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def worker(kind, *args):
    """This script in a fresh process, measuring the twin; returns its JSON."""
    return json.loads(run([sys.executable, os.path.abspath(__file__), "--worker", kind,
                           *args])[0])


# ---- twin side (run with --worker, one measurement per process) ----

def twin_train(run_dir, shards, skip):
    """The twin trained on the C++ run's stored config, steps skip+1..N timed."""
    import torch
    import vqvae_twin as twin
    tensors, header = twin.read_archive(os.path.join(run_dir, "checkpoint.wmt"))
    config = header["meta"]["config"]
    t = config["train"]
    sampler = twin.FrameSampler([shards], config["data"]["image_key"],
                                config["model"]["image_size"], t["seed"])
    batches = []
    for step in range(t["steps"]):  # frames and, for an anchored tokenizer, the C++ run's anchors
        refs = sampler.batch_refs(step, t["batch_size"])
        anchors = None
        if config["model"].get("anchor_decoder"):
            anchors = sampler.load_anchors(sampler.training_anchors(
                refs, step, t["anchor_max_gap"], t["anchor_dropout"]))
        batches.append((sampler.load(refs), anchors))
    trainer = twin.Trainer(config)
    for step in range(t["steps"]):
        if step == int(skip):
            start, cpu_start = time.perf_counter(), time.process_time()
        out = trainer.train_step(*batches[step])
        out["loss"].item()  # the C++ loop reads the losses back at logged steps
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu_start
    ours = {**{"model/" + k: v for k, v in trainer.model.state_dict().items()},
            **trainer.moments()}
    same = sorted(ours) == sorted(tensors) and all(
        torch.equal(torch.from_numpy(tensors[k]), ours[k]) for k in tensors)
    steps = t["steps"] - int(skip)
    return {"wall": steps / wall, "cpu": steps / cpu, "same": same}


def twin_encode(run_dir, frames_path, threads, repeat):
    import torch
    import vqvae_twin as twin
    torch.set_num_threads(int(threads))
    model, config, _ = twin.load_checkpoint(run_dir)
    size = config["model"]["image_size"]
    x = torch.from_numpy(np.fromfile(frames_path, np.float32).reshape(-1, 3, size, size))
    twin.encode(model, x)  # warm-up, as the tool's
    start, cpu_start = time.perf_counter(), time.process_time()
    for _ in range(int(repeat)):
        twin.encode(model, x)
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu_start
    return {"wall": len(x) * int(repeat) / wall, "cpu": len(x) * int(repeat) / cpu}


def twin_end_to_end(run_dir, shards, tokens_dir, threads):
    import torch
    import vqvae_twin as twin
    import wmshard
    torch.set_num_threads(int(threads))
    start, cpu_start = time.perf_counter(), time.process_time()
    model, config, _ = twin.load_checkpoint(run_dir)
    size, key = config["model"]["image_size"], config["data"]["image_key"]
    data, codes = wmshard.Dataset(shards), []
    for k in range(data.num_episodes):
        x = np.stack([twin.decode_frame(b, size) for b in data.episode(k)[2][key]])
        codes.append(twin.encode(model, torch.from_numpy(x)))
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu_start
    tokens = wmshard.TokenDataset(tokens_dir)
    same = all(np.array_equal(np.array(tokens.episode(k)["tokens"]).ravel(), c.numpy().ravel())
               for k, c in enumerate(codes))
    n = sum(len(c) for c in codes)
    return {"wall": n / wall, "cpu": n / cpu, "frames": n, "same": same}


# ---- C++ side and the comparison ----

EPISODES = 160


def make_data(bin_dir, work):
    shards = os.path.join(work, f"shards-{EPISODES}")
    if not os.path.exists(os.path.join(shards, "index.json")):
        raw = os.path.join(work, "raw")
        run([os.path.join(bin_dir, "wm-gen-tabletop"), "--out", raw, "--train-episodes", EPISODES,
             "--val-episodes", 1, "--size", 64, "--max-steps", 40, "--seed", 1])
        run([os.path.join(bin_dir, "wm-ingest"), "--format", "rlds", "--input",
             os.path.join(raw, "wm_tabletop/1.0.0"), "--split", "train", "--output", shards,
             "--configs", os.path.join(SOURCE, "configs"), "--log-level", "warn"])
    return shards


def cpp_train(bin_dir, config, shards, out, steps, threads, env):
    """(steps/s after the first metrics row, that row's step, process CPU s, stored config)."""
    import vqvae_twin as twin
    shutil.rmtree(out, ignore_errors=True)
    _, cpu = run([os.path.join(bin_dir, "wm-tokenize"), "train", "--config", config, "--data",
                  shards, "--out", out, "--steps", steps, "--threads", threads], env)
    stored = twin.read_archive(os.path.join(out, "checkpoint.wmt"))[1]["meta"]["config"]
    with open(os.path.join(out, "metrics.csv")) as f:
        rows = list(csv.DictReader(f))
    seconds, done = 0.0, 0
    for prev, row in zip(rows, rows[1:]):
        n = int(row["step"]) - int(prev["step"])
        seconds += n * stored["train"]["batch_size"] / float(row["frames_per_s"])
        done += n
    return (done / seconds if done else 0.0), int(rows[0]["step"]), cpu, stored


def measure_round(args, shards, work, env):
    """One round of every measurement: {row: [C++ wall, twin wall, C++ CPU, twin CPU]}."""
    run_dir, short_dir = os.path.join(work, "run"), os.path.join(work, "run-short")
    wall, skip, cpu, config = cpp_train(args.bin, args.config, shards, run_dir, args.steps,
                                        args.threads, env)
    threads = config["train"]["threads"]
    cpu_short = cpp_train(args.bin, args.config, shards, short_dir, skip, threads, env)[2]
    t = worker("train", run_dir, shards, skip)
    out = {"train": [wall, t["wall"], (args.steps - skip) / max(1e-9, cpu - cpu_short), t["cpu"]],
           "same_train": t["same"], "skip": skip, "threads": threads, "config": config}
    frames_path = os.path.join(work, "frames.f32")
    if not os.path.exists(frames_path):
        import vqvae_twin as twin
        sampler = twin.FrameSampler([shards], "image", config["model"]["image_size"], 0)
        np.concatenate([sampler.frames(0, k) for k in range(16)])[:512].tofile(frames_path)
    r = json.loads(run([os.path.join(args.bin, "tokenizer_ref_tool"), "--checkpoint", run_dir,
                        "--frames", frames_path, "--threads", threads, "--repeat",
                        args.repeat], env)[0])
    t = worker("encode", run_dir, frames_path, threads, args.repeat)
    out["model"] = [r["encode_frames_per_second"], t["wall"],
                    r["frames"] / r["encode_cpu_seconds"], t["cpu"]]
    out["model_frames"] = r["frames"]
    tokens = os.path.join(work, "tokens")
    shutil.rmtree(tokens, ignore_errors=True)
    start = time.perf_counter()
    _, cpu = run([os.path.join(args.bin, "wm-tokenize"), "encode", "--checkpoint", run_dir,
                  "--data", shards, "--out", tokens, "--threads", threads], env)
    wall = time.perf_counter() - start
    t = worker("e2e", run_dir, shards, tokens, threads)
    out["e2e"] = [t["frames"] / wall, t["wall"], t["frames"] / cpu, t["cpu"]]
    out["e2e_frames"], out["same_codes"] = t["frames"], t["same"]
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--bin", default=os.path.join(SOURCE, "build", "bin"))
    ap.add_argument("--config", default=os.path.join(SOURCE, "configs", "tokenizer", "tiny.yaml"))
    ap.add_argument("--threads", type=int, default=0, help="torch threads (0: the config's)")
    ap.add_argument("--steps", type=int, default=60, help="training steps per run (> 10)")
    ap.add_argument("--repeat", type=int, default=5, help="timed encode passes (model only)")
    ap.add_argument("--rounds", type=int, default=3, help="alternating runs; best of each kept")
    ap.add_argument("--tuned-malloc", action="store_true",
                    help="C++ tools with glibc mmap/trim thresholds at 1 GiB")
    ap.add_argument("--worker", nargs="+", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        kind, *rest = args.worker
        fn = {"train": twin_train, "encode": twin_encode, "e2e": twin_end_to_end}[kind]
        print(json.dumps(fn(*rest)))
        return 0
    import torch
    work = os.path.join(os.environ.get("BENCH_DIR", "/tmp/wmkit-bench"), "tokenizer")
    os.makedirs(work, exist_ok=True)
    shards = make_data(args.bin, work)
    env = TUNED if args.tuned_malloc else None
    best, same_train, same_codes = {}, True, True
    for _ in range(args.rounds):
        r = measure_round(args, shards, work, env)
        for row in ("train", "model", "e2e"):
            best[row] = [max(a, b) for a, b in zip(best.get(row, [0.0] * 4), r[row])]
        same_train &= r["same_train"]
        same_codes &= r["same_codes"]
    m, t = r["config"]["model"], r["config"]["train"]
    g = m["image_size"] // m["patch_size"]
    print(f"tokenizer {os.path.basename(args.config)}: {m['image_size']}x{m['image_size']} -> "
          f"{g}x{g} tokens of {m['num_codes']} codes, batch {t['batch_size']}, {r['threads']} "
          f"torch thread(s), torch {torch.__version__}, {os.cpu_count()} cores, best of "
          f"{args.rounds}, C++ malloc {'tuned' if args.tuned_malloc else 'glibc defaults'}")
    print(f"{'':38} {'--- per wall second ---':>24}   {'--- per CPU second ---':>24}")
    print(f"{'':38} {'C++':>8} {'twin':>8} {'ratio':>6}   {'C++':>8} {'twin':>8} {'ratio':>6}"
          "  goal")
    rows = [(f"train steps/s (steps {r['skip'] + 1}..{args.steps})", best["train"], ">= 1.0"),
            (f"encode frames/s, model only ({r['model_frames']})", best["model"], ">= 1.2"),
            (f"encode frames/s, +JPEG decode ({r['e2e_frames']})", best["e2e"], ">= 1.2")]
    for label, (cw, tw, cc, tc), goal in rows:
        print(f"{label:38} {cw:>8.1f} {tw:>8.1f} {cw / tw:>6.2f}   {cc:>8.1f} {tc:>8.1f} "
              f"{cc / tc:>6.2f}  {goal}")
    print(f"twin checkpoint == C++ checkpoint bit for bit: {'yes' if same_train else 'NO'}; "
          f"wm-tokenize encode codes == twin codes: {'yes' if same_codes else 'NO'}")
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except (subprocess.CalledProcessError, OSError, ValueError) as e:
        detail = getattr(e, "stderr", "") or ""
        print(f"tokenizer_bench: {e} {detail.strip()[-500:]}", file=sys.stderr)
        sys.exit(1)
