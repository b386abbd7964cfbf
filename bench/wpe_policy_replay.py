#!/usr/bin/python3
"""Why a policy fails inside the world model: the colour policy replayed on what it was shown.

`make wpe`'s colour policies are deterministic at noise 0, so replaying
scripts/tabletop_colour_policy.py's ColourPolicy on the frames a closed-loop episode showed it
gives back the actions it sent, and its beliefs with them. Per start, on the simulator's frames
(WPE_DIR/strip_sim/<policy>, written by scripts/wpe_strips.py) and on the imagined ones (the
policy's row of WPE_DIR/reports/<model>/strips/episode_K.png): the first step whose actions
differ by over 1 cm, the step the gripper first closes, the step the policy first believes it
holds the block, and how far the block it sees moves from the closing step on (pixels, the most
over the following steps; a carried block moves, one left behind does not). The imagined frames
are the world model's; what the policy makes of them is what this separates from the model's
dynamics (docs/dynamics.md, "Why the policies fail inside the model"). --decoded DIR replaces the imagined frames with DIR/episode_K/frame_SSSS.png, e.g. the
tokenizer's reconstruction of the simulator's own frames (`wm-tokenize encode` of strip_sim, then
`wm-tokenize decode --originals`): what the policy would read from a perfect token model. Then the
frames are the simulator's own, so the policy's reading of each can be compared directly: where it
puts the gripper on the simulator's frame and on the reconstruction of it, from step 6 on (the
same height, the one the simulator replay tracked).

  bench/wpe_policy_replay.py WPE_DIR --model MODEL --episodes 0,...,15 [--policy colour_noise000]
      [--trace K] [--decoded DIR]   (K: print that start's per-step beliefs and actions)
"""
import argparse
import os
import sys
import types

import cv2
import numpy as np

SRC = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(SRC, "scripts"))
import tabletop_colour_policy as colour  # noqa: E402
import wmshard  # noqa: E402
from wpe_strips import strip_row  # noqa: E402


def noiseless(instruction):
    return colour.ColourPolicy(types.SimpleNamespace(seed=0, instruction=instruction), 0.0)


def replay(frames, instruction, trace=False):
    """The policy's actions, `holding` belief, the block it sees and the gripper height it
    believes before each step's action, on `frames` (RGB), step by step."""
    policy = noiseless(instruction)
    actions, holding, blocks, heights = [], [], [], []
    for t, rgb in enumerate(frames):
        block, _, arm = policy.see(rgb)
        blocks.append(None if block is None or block[2] < 2 else np.array(block[:2]))
        heights.append(policy.z)
        obs = types.SimpleNamespace(image=rgb, width=rgb.shape[1], step=t, instruction=instruction)
        actions.append(policy.act(obs))
        holding.append(policy.holding)
        if trace:
            seen = "none" if block is None else f"({block[0]:.0f}, {block[1]:.0f})"
            print(f"  {t:2d} block px {seen:10s} arm px {int(arm.sum()):3d} holding "
                  f"{int(policy.holding)} action [{', '.join(f'{a:+.3f}' for a in actions[-1])}]")
    return np.array(actions), np.array(holding), blocks, heights


def carried(blocks, closed):
    """How far (px) the seen block gets from where it was when the gripper closed."""
    if closed is None or blocks[closed] is None:
        return None
    moves = [np.linalg.norm(b - blocks[closed]) for b in blocks[closed:] if b is not None]
    return f"{max(moves):.0f}"


def gripper_misplaced(real, shown, heights, instruction):
    """cm between where the policy puts the gripper on each real frame and on its counterpart,
    at the height its simulator replay believed (`replay`'s heights)."""
    probe = noiseless(instruction)
    probe.camera = colour.Camera(real[0].shape[1])
    misplaced = []
    for t, (a, b) in enumerate(zip(real, shown)):
        if heights[t] is not None and t >= colour.DESCENT_STEPS:
            probe.z = heights[t]
            seen = [probe.arm_position(probe.see(f)[2]) for f in (a, b)]
            missing = any(x is None for x in seen)
            misplaced.append(np.nan if missing else 100 * np.linalg.norm(seen[0] - seen[1]))
    return misplaced


def first(flags):
    hits = np.nonzero(flags)[0]
    return int(hits[0]) if len(hits) else None


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("wpe_dir")
    parser.add_argument("--model", required=True, help="a closed-loop report under WPE_DIR/reports")
    parser.add_argument("--policy", default="colour_noise000")
    parser.add_argument("--episodes", default="0,1,2,3")
    parser.add_argument("--row", type=int, default=1, help="the policy's row in the strips")
    parser.add_argument("--trace", type=int, default=-1)
    parser.add_argument("--decoded", help="frames to replay instead of the model's strips")
    args = parser.parse_args()
    sim = wmshard.Dataset(os.path.join(args.wpe_dir, "strip_sim", args.policy))
    print("start  differ_from  sim_closes  model_closes  sim_holds  model_holds  "
          "sim_block_moves  model_block_moves")
    misplaced = []
    for k in (int(e) for e in args.episodes.split(",")):
        meta, _, blobs = sim.episode(k)
        real = [cv2.imdecode(np.frombuffer(b, np.uint8), cv2.IMREAD_COLOR)[..., ::-1].copy()
                for b in blobs["image"]]
        if args.decoded:
            folder = os.path.join(args.decoded, f"episode_{k}")
            shown = [cv2.imread(os.path.join(folder, f)) for f in sorted(os.listdir(folder))]
        else:
            shown = strip_row(os.path.join(args.wpe_dir, "reports", args.model, "strips",
                                           f"episode_{k}.png"), args.row)
        imagined = [f[..., ::-1].copy() for f in shown]
        instruction = meta.get("language_instruction", "")
        if args.trace == k:
            print(f"start {k}, simulator:")
        a_sim, h_sim, b_sim, heights = replay(real, instruction, args.trace == k)
        if args.trace == k:
            print(f"start {k}, {args.model}:")
        a_wm, h_wm, b_wm, _ = replay(imagined, instruction, args.trace == k)
        n = min(len(a_sim), len(a_wm))
        differ = first(np.abs(a_sim[:n, :3] - a_wm[:n, :3]).max(axis=1) > 0.01)
        close_sim, close_wm = first(a_sim[:, 6] >= 0.5), first(a_wm[:, 6] >= 0.5)
        print(f"{k:5d}  {str(differ):11s}  {str(close_sim):10s}  {str(close_wm):12s}  "
              f"{str(first(h_sim)):9s}  {str(first(h_wm)):11s}  "
              f"{str(carried(b_sim, close_sim)):15s}  {carried(b_wm, close_wm)}")
        if args.decoded:
            misplaced += gripper_misplaced(real, imagined, heights, instruction)
    if misplaced:
        cm = np.array(misplaced)
        found = cm[~np.isnan(cm)]
        print(f"gripper placed from the reconstructions vs the simulator's frames, {len(cm)} frames "
              f"from step {colour.DESCENT_STEPS}: not found {len(cm) - len(found)}, median "
              f"{np.median(found):.1f} cm, 90th percentile {np.percentile(found, 90):.1f} cm, "
              f"over 1 cm {np.mean(found > 1):.2f}")


if __name__ == "__main__":
    main()
