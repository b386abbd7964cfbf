#!/usr/bin/python3
"""Does a token model lose the block's motion to its own frames? (docs/dynamics.md, "Why the
policies fail inside the model".) From every step s of the first episodes of a token dataset, the
PyTorch twin predicts frames s+1..s+H twice with the logged actions: from the real frames before
each one (teacher forcing), and from its own argmax frames after the real frame s (a plain
rollout, as wm-eval's with the given frame s). Both see the same number of frames, so what
differs is only whose frames they are. Per horizon step and per region of the cells whose code
really changes (bench/dynamics_changed_cells.py's, from the shards' segmentation labels): how often
the argmax is the true code.

  bench/dynamics_own_context.py RUN_DIR/checkpoint.wmt TOKENS_DIR SHARDS_DIR [--episodes 16]
      [--horizon 5]
"""
import argparse
import os
import sys

import numpy as np
import torch

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from dynamics_changed_cells import REGIONS, cell_regions, normalised_actions  # noqa: E402
from dynamics_twin import load_world_model, read_archive  # noqa: E402
from wmshard import Dataset, TokenDataset  # noqa: E402


def next_codes(model, frames, actions):
    """Argmax codes [T, N] of the frames after each of `frames` [T, N]."""
    x = torch.tensor(np.stack(frames))[None]
    a = torch.tensor(np.stack(actions), dtype=torch.float32)[None]
    with torch.no_grad():
        logits, _, _ = model.dynamics(x, a, model.dynamics_z(x, a))
    return logits[0].argmax(-1).numpy()


def episode_hits(model, window, codes, actions, regions, horizon):
    """{(source, k, region): [right, cells]} over every start of one episode."""
    hits = {}
    for s in range(len(codes) - horizon):
        real = next_codes(model, codes[s:s + horizon], actions[s:s + horizon])
        own = [codes[s]]
        for k in range(1, horizon + 1):
            first = max(0, k - window)
            guess = next_codes(model, own[first:k], actions[s + first:s + k])[-1]
            own.append(guess)
            truth, before = codes[s + k], codes[s + k - 1]
            changed = truth != before
            for source, predicted in (("real", real[k - 1]), ("own", guess)):
                for r, name in enumerate(REGIONS):
                    where = changed & (regions[s + k - 1] == r)
                    tally = hits.setdefault((source, k, name), [0, 0])
                    tally[0] += int((predicted[where] == truth[where]).sum())
                    tally[1] += int(where.sum())
    return hits


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("checkpoint")
    parser.add_argument("tokens")
    parser.add_argument("shards")
    parser.add_argument("--episodes", type=int, default=16)
    parser.add_argument("--horizon", type=int, default=5)
    args = parser.parse_args()
    torch.set_num_threads(1)
    tensors, meta = read_archive(args.checkpoint)
    model = load_world_model(tensors, meta["config"]).eval()
    m = meta["config"]["model"]
    # wm-eval's windows hold context_frames - 1 frames: the last position is never trained.
    window = m["context_frames"] - 1
    horizon = min(args.horizon, window)
    data, shards = TokenDataset(args.tokens), Dataset(args.shards)
    total = {}
    for k in range(min(args.episodes, data.num_episodes)):
        e = data.episode(k)
        codes = np.array(e["tokens"]).reshape(len(e["tokens"]), -1)
        gripper = np.array(e["actions"]).reshape(len(codes), -1)[:, 6]
        regions = cell_regions(shards, data.index["episodes"][k], m["grid_h"], gripper)
        for key, (right, cells) in episode_hits(model, window, codes,
                                                normalised_actions(meta, e), regions,
                                                horizon).items():
            total.setdefault(key, [0, 0])
            total[key][0] += right
            total[key][1] += cells
    print(f"{args.checkpoint}: argmax right where the code changes, real / own context "
          f"(cells), by horizon step")
    for name in REGIONS:
        row = [f"{total[('real', k, name)][0] / max(total[('real', k, name)][1], 1):.3f} / "
               f"{total[('own', k, name)][0] / max(total[('own', k, name)][1], 1):.3f} "
               f"({total[('own', k, name)][1]})" for k in range(1, horizon + 1)]
        print(f"  {name:20s} " + "  ".join(row))


if __name__ == "__main__":
    main()
