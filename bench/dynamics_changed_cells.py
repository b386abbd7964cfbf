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

With the token dataset's shards (segmentation labels: configs/segmentation/tabletop.yaml's 1 =
arm, 2 = block) the changed cells are also split by what changes in them: `block moves` (the
block's pixels differ between the two frames in that cell: uncovered or pushed with the gripper
open, `block moves, closed` with it closed, mostly carried), `arm`
(the arm in either frame, the block still) and `rest` (shadows, flicker).

  bench/dynamics_changed_cells.py RUN_DIR/checkpoint.wmt TOKENS_DIR [SHARDS_DIR] [EPISODES]
"""
import os
import sys

import cv2
import numpy as np
import torch

SRC = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
sys.path.insert(0, os.path.join(SRC, "tests", "train"))
sys.path.insert(0, os.path.join(SRC, "scripts"))
from dynamics_twin import load_world_model, read_archive  # noqa: E402
from wmshard import Dataset, TokenDataset  # noqa: E402

EPISODES = 16  # the demo's val split
REGIONS = ("rest", "arm", "block moves", "block moves, closed")  # cell_regions' values


def normalised_actions(meta, episode):
    stats = next(iter(meta["action_norms"].values()))
    return (np.array(episode["actions"]) - stats["mean"]) / np.array(stats["std"])


def cell_regions(shards, meta, grid, gripper):
    """[T-1, grid*grid] region of each next-frame cell: an index into REGIONS."""
    _, _, blobs = shards.episode(meta["source_episode"])
    labels = np.stack([cv2.imdecode(np.frombuffer(b, np.uint8), cv2.IMREAD_UNCHANGED)
                       for b in blobs["segmentation"][:meta["num_frames"]]])  # the whole episode
    size = labels.shape[1] // grid

    def per_cell(mask):  # [T, H, W] -> [T, grid*grid]: any pixel set in the cell
        t = mask.shape[0]
        return mask.reshape(t, grid, size, grid, size).any(axis=(2, 4)).reshape(t, -1)

    block, arm = labels == 2, labels == 1
    moved = per_cell(block[1:] ^ block[:-1])
    armed = per_cell(arm[1:] | arm[:-1])
    closed = (np.asarray(gripper[:len(labels) - 1]) >= 0.5)[:, None]  # the action into the frame
    return np.where(moved, np.where(closed, 3, 2), np.where(armed, 1, 0))


def next_frame_log_probs(model, tokens, actions):
    """[T-1, N, K] log-probabilities of frames 1..T-1 from the windows' positions 0..T-2."""
    z = model.dynamics_z(tokens, actions)
    logits, _, _ = model.dynamics(tokens, actions, z)
    return logits[0, :-1].log_softmax(-1)


def main(checkpoint, token_dir, shards_dir=None, episodes=EPISODES):
    torch.set_num_threads(1)
    tensors, meta = read_archive(checkpoint)
    model = load_world_model(tensors, meta["config"]).eval()
    context = meta["config"]["model"]["context_frames"]
    data = TokenDataset(token_dir)
    shards = Dataset(shards_dir) if shards_dir else None
    found = {k: [] for k in ("p_true_changed", "rank_true", "p_copy_changed", "p_copy_static",
                             "acc_changed", "action_tv")}
    by_region = {name: {"p_true_changed": [], "acc_changed": [], "p_copy_changed": []}
                 for name in REGIONS}
    grid = meta["config"]["model"]["grid_h"]
    for k in range(min(episodes, data.num_episodes)):
        e = data.episode(k)
        codes = np.array(e["tokens"]).reshape(len(e["tokens"]), -1)
        actions = normalised_actions(meta, e)
        gripper = np.array(e["actions"]).reshape(len(e["tokens"]), -1)[:, 6]
        regions = cell_regions(shards, data.index["episodes"][k], grid, gripper) if shards else None
        for s in range(len(codes) - context + 1):
            x = torch.tensor(codes[s:s + context])[None]
            a = torch.tensor(actions[s:s + context], dtype=torch.float32)[None]
            flipped = a.clone()
            flipped[..., :6] = -flipped[..., :6]
            with torch.no_grad():
                lp, lp_flipped = (next_frame_log_probs(model, x, b) for b in (a, flipped))
            target, previous = x[0, 1:], x[0, :-1]
            changed = target != previous
            log_p_true = lp.gather(-1, target[..., None])[..., 0]
            p_true = log_p_true.exp()
            p_copy = lp.gather(-1, previous[..., None])[..., 0].exp()
            right = (lp.argmax(-1) == target).float()
            found["p_true_changed"] += p_true[changed].tolist()
            found["rank_true"] += (lp > log_p_true[..., None]).sum(-1)[changed].tolist()
            found["p_copy_changed"] += p_copy[changed].tolist()
            found["p_copy_static"] += p_copy[~changed].tolist()
            found["acc_changed"] += right[changed].tolist()
            found["action_tv"].append(0.5 * (lp.exp() - lp_flipped.exp()).abs().sum(-1).mean().item())
            if regions is not None:
                region = torch.tensor(regions[s:s + context - 1])
                for r, name in enumerate(REGIONS):
                    where = changed & (region == r)
                    by_region[name]["p_true_changed"] += p_true[where].tolist()
                    by_region[name]["acc_changed"] += right[where].tolist()
                    by_region[name]["p_copy_changed"] += p_copy[where].tolist()
    changed = len(found["p_true_changed"])
    print(f"{checkpoint} on {token_dir}: {changed} changed of "
          f"{changed + len(found['p_copy_static'])} predicted cells")
    for name, values in found.items():
        v = np.array(values, dtype=float)
        print(f"  {name:15s} mean {v.mean():.4f}  median {np.median(v):.4f}")
    for region, values in by_region.items() if shards else ():
        cells = len(values["p_true_changed"])
        print(f"  changed cells where {region}: {cells}  " + "  ".join(
            f"{name} {np.mean(v):.4f}" for name, v in values.items() if cells))


if __name__ == "__main__":
    if len(sys.argv) not in (3, 4, 5):
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2], *sys.argv[3:4], *[int(a) for a in sys.argv[4:5]])
