#!/usr/bin/python3
"""Closed-loop episodes of one policy in the simulator beside the same policy in the world
models, from the same first frames (the README's WPE pictures), after `make wpe`:

    scripts/wpe_strips.py WPE_DIR --policy colour_noise000 --episodes 0,1,2 --out strips.png

Runs the policy (its command from --policies, configs/policies/tabletop.yaml) in the simulator on
the first val episodes with wm-sim-policy's dataset (seed 0, 64 px, plain look: what make wpe's
truth used; the policy is reset with the same seeds as in the world models' rollout 0), ingests it,
and stacks per episode: the simulator's frames, then the policy's row of each world model's
closed-loop strip (WPE_DIR/reports/<model>/strips/episode_K.png: exactly the imagined frames the
policy was shown), every --every-th step up to --steps; each row says how its episode ended
(WPE_DIR/truth/policy_episodes.csv, the reports' wm_episodes.csv). Writes one PNG. Needs the wmkit tools in
--bin and Debian's python3-opencv and python3-yaml."""
import argparse
import os
import subprocess
import sys

import cv2
import numpy as np
import yaml

SRC = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(SRC, "scripts"))
import wmshard  # noqa: E402

# evaluate/episode_strip.h geometry: label column, header row, gap; 64 px frames drawn 3x.
STRIP_LABEL, STRIP_HEADER, STRIP_GAP, STRIP_SCALE, SIZE = 144, 24, 2, 3, 64
LABEL_WIDTH, CELL = 250, 80  # this picture's label column and cell size (1.25x)


def run(*args):
    p = subprocess.run([str(a) for a in args], capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"wpe_strips: {' '.join(map(str, args[:2]))} failed:\n{p.stderr}")


def simulator_frames(args, command, episodes):
    """The policy's true closed-loop episodes (RGB frames), simulated and ingested once."""
    sim, shards = (os.path.join(args.wpe_dir, "strip_sim", d) for d in ("rlds", args.policy))
    if not os.path.exists(os.path.join(shards, "index.json")):
        run(os.path.join(args.bin, "wm-sim-policy"), "--out", sim, "--size", SIZE, "--look",
            "plain", "--seed", 0, "--split", "val", "--episodes", max(episodes) + 1,
            "--max-steps", args.horizon, "--policy", f"{args.policy}={command}")
        run(os.path.join(args.bin, "wm-ingest"), "--format", "rlds", "--input",
            os.path.join(sim, "wm_tabletop_sim", "1.0.0"), "--split", args.policy, "--output",
            shards, "--mapping", os.path.join(SRC, "configs", "datasets", "wm_tabletop.yaml"),
            "--threads", 1)
    data = wmshard.Dataset(shards)
    out = {}
    for k in episodes:
        _, _, blobs = data.episode(k)
        out[k] = [cv2.imdecode(np.frombuffer(b, np.uint8), cv2.IMREAD_COLOR) for b in blobs["image"]]
    return out


def strip_row(path, row):
    """The frames (BGR, 64 px) of row `row` of a wm-eval strip; row 0 is the logged episode."""
    strip = cv2.imread(path)
    if strip is None:
        sys.exit(f"wpe_strips: cannot read {path} (was it among wm-eval's --strips?)")
    cell = SIZE * STRIP_SCALE
    y = STRIP_HEADER + row * (cell + STRIP_GAP)
    frames, x = [], STRIP_LABEL
    while x + cell <= strip.shape[1]:
        frames.append(strip[y:y + cell:STRIP_SCALE, x:x + cell:STRIP_SCALE])
        x += cell + STRIP_GAP
    return frames


def labelled_row(label, frames, steps, ended):
    """One picture row: the label, then frames at `steps` (after the episode: grey)."""
    row = np.full((CELL, LABEL_WIDTH + len(steps) * (CELL + 2), 3), 255, np.uint8)
    for i, line in enumerate(label.split("\n")):
        cv2.putText(row, line, (6, 30 + 22 * i), cv2.FONT_HERSHEY_SIMPLEX, 0.55, (0, 0, 0), 1,
                    cv2.LINE_AA)
    for j, t in enumerate(steps):
        x = LABEL_WIDTH + j * (CELL + 2)
        if t < len(frames) and t <= ended:
            row[:, x:x + CELL] = cv2.resize(frames[t], (CELL, CELL), interpolation=cv2.INTER_NEAREST)
        else:
            row[:, x:x + CELL] = 200
    return row


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("wpe_dir")
    parser.add_argument("--policy", default="colour_noise000")
    parser.add_argument("--policies", default=os.path.join(SRC, "configs", "policies",
                                                           "tabletop.yaml"))
    parser.add_argument("--models", default="motion,dynamics")
    parser.add_argument("--episodes", default="0,1,2")
    parser.add_argument("--steps", type=int, default=24)
    parser.add_argument("--every", type=int, default=2)
    parser.add_argument("--horizon", type=int, default=40)
    parser.add_argument("--bin", default=os.path.join(SRC, "build", "bin"))
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    with open(args.policies, encoding="utf-8") as f:
        specs = {p["name"]: p for p in yaml.safe_load(f)["policies"]}
    episodes = [int(k) for k in args.episodes.split(",")]
    sim = simulator_frames(args, specs[args.policy]["command"], episodes)
    names = sorted(specs)  # strip rows: the logged episode, then the policies by name
    steps = list(range(0, args.steps + 1, args.every))
    header = np.full((24, LABEL_WIDTH + len(steps) * (CELL + 2), 3), 255, np.uint8)
    for j, t in enumerate(steps):
        cv2.putText(header, f"step {t}", (LABEL_WIDTH + j * (CELL + 2) + 4, 17),
                    cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 0), 1, cv2.LINE_AA)
    blocks = [header]
    truth = {tuple(r.split(",")[:2]): r.split(",") for r in open(os.path.join(
        args.wpe_dir, "truth", "policy_episodes.csv")).read().splitlines()[1:]}
    for k in episodes:
        t = truth[(args.policy, str(k))]
        end = f"success at {t[5]}" if t[3] == "1" else "no success"
        blocks.append(labelled_row(f"episode {k}: simulator\n({end})", sim[k], steps,
                                   len(sim[k]) - 1))
        for model in args.models.split(","):
            report = os.path.join(args.wpe_dir, "reports", model)
            rows = {tuple(r.split(",")[:2]): r.split(",")
                    for r in open(os.path.join(report, "wm_episodes.csv")).read().splitlines()[1:]}
            r = rows[(args.policy, str(k))]
            end = f"success at {r[7]}" if r[5] == "1" else "no success"
            frames = strip_row(os.path.join(report, "strips", f"episode_{k}.png"),
                               1 + names.index(args.policy))
            blocks.append(labelled_row(f"{model} model\n({end})", frames, steps, int(r[7])))
        blocks.append(np.full((8, header.shape[1], 3), 255, np.uint8))
    cv2.imwrite(args.out, np.vstack(blocks), [cv2.IMWRITE_PNG_COMPRESSION, 9])
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
