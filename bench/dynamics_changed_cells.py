#!/usr/bin/python3
"""Issue 20, goal 2 diagnostic (docs/dynamics.md, "Why the model copies"): where a trained
dynamics checkpoint puts its probability in the cells whose code really changes from one frame
to the next. Loads the checkpoint into the PyTorch twin (tests/train/dynamics_twin.py), slides a
context_frames window over the first 16 episodes of a token dataset and reports, over every
position's next-frame prediction:
  p_true_changed   probability of the true code where the code changes
  rank_true        how many codes score above the true one there (0 = argmax)
  p_copy_changed   probability of the previous code there (what argmax keeps)
  p_copy_static    probability of the previous code where the code stays
  acc_changed      argmax accuracy where the code changes (copying scores 0)
  action_tv        total-variation distance of the next-frame distributions when the arm's
                   actions (dims 0-5) are negated: 0 means the model ignores its actions

  bench/dynamics_changed_cells.py RUN_DIR/checkpoint.wmt TOKENS_DIR
"""
import os
import sys

import numpy as np
import torch

SRC = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
sys.path.insert(0, os.path.join(SRC, "tests", "train"))
sys.path.insert(0, os.path.join(SRC, "scripts"))
from dynamics_twin import load_world_model, read_archive  # noqa: E402
from wmshard import TokenDataset  # noqa: E402

EPISODES = 16  # the demo's val split


def normalised_actions(meta, episode):
    stats = next(iter(meta["action_norms"].values()))
    return (np.array(episode["actions"]) - stats["mean"]) / np.array(stats["std"])


def next_frame_log_probs(model, tokens, actions):
    """[T-1, N, K] log-probabilities of frames 1..T-1 from the windows' positions 0..T-2."""
    z = model.dynamics_z(tokens, actions)
    logits, _, _ = model.dynamics(tokens, actions, z)
    return logits[0, :-1].log_softmax(-1)


def main(checkpoint, token_dir):
    torch.set_num_threads(1)
    tensors, meta = read_archive(checkpoint)
    model = load_world_model(tensors, meta["config"]).eval()
    context = meta["config"]["model"]["context_frames"]
    data = TokenDataset(token_dir)
    found = {k: [] for k in ("p_true_changed", "rank_true", "p_copy_changed", "p_copy_static",
                             "acc_changed", "action_tv")}
    for k in range(min(EPISODES, data.num_episodes)):
        e = data.episode(k)
        codes = np.array(e["tokens"]).reshape(len(e["tokens"]), -1)
        actions = normalised_actions(meta, e)
        for s in range(len(codes) - context + 1):
            x = torch.tensor(codes[s:s + context])[None]
            a = torch.tensor(actions[s:s + context], dtype=torch.float32)[None]
            flipped = a.clone()
            flipped[..., :6] = -flipped[..., :6]
            with torch.no_grad():
                lp, lp_flipped = (next_frame_log_probs(model, x, b) for b in (a, flipped))
            target, previous = x[0, 1:], x[0, :-1]
            changed = target != previous
            p_true = lp.gather(-1, target[..., None])[..., 0]
            p_copy = lp.gather(-1, previous[..., None])[..., 0].exp()
            found["p_true_changed"] += p_true.exp()[changed].tolist()
            found["rank_true"] += (lp > p_true[..., None]).sum(-1)[changed].tolist()
            found["p_copy_changed"] += p_copy[changed].tolist()
            found["p_copy_static"] += p_copy[~changed].tolist()
            found["acc_changed"] += (lp.argmax(-1) == target)[changed].float().tolist()
            found["action_tv"].append(0.5 * (lp.exp() - lp_flipped.exp()).abs().sum(-1).mean().item())
    changed = len(found["p_true_changed"])
    print(f"{checkpoint} on {token_dir}: {changed} changed of "
          f"{changed + len(found['p_copy_static'])} predicted cells")
    for name, values in found.items():
        v = np.array(values, dtype=float)
        print(f"  {name:15s} mean {v.mean():.4f}  median {np.median(v):.4f}")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
