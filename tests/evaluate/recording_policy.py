#!/usr/bin/python3
"""Test policy for tests/evaluate/test_wm_eval_policy.py: answers one constant action and records
what it was shown, so a test can check that wm-eval --policy hands it the decoded imagined frames
and resets it with the simulator's seeds.

    recording_policy.py --out DIR --action a0,a1,a2,a3,a4,a5,a6

Writes DIR/<episode>_<step>.npy (the uint8 [H, W, 3] RGB image) per step and appends
"episode seed instruction" lines to DIR/resets.txt per reset."""
import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.environ.get("WM_SOURCE_DIR",
                                os.path.join(os.path.dirname(__file__), "..", "..")), "scripts"))
import wmpolicy  # noqa: E402

parser = argparse.ArgumentParser()
parser.add_argument("--out", required=True)
parser.add_argument("--action", required=True)
args = parser.parse_args()
os.makedirs(args.out, exist_ok=True)
ACTION = [float(v) for v in args.action.split(",")]


class Recorder:
    def __init__(self, episode):
        with open(os.path.join(args.out, "resets.txt"), "a", encoding="utf-8") as f:
            f.write(f"{episode.id} {episode.seed} {episode.instruction}\n")

    def act(self, obs):
        np.save(os.path.join(args.out, f"{obs.episode}_{obs.step}.npy"), obs.image)
        return ACTION


wmpolicy.serve(Recorder, name="recorder")
