#!/usr/bin/python3
"""The colour policy seeing the world through a tokenizer: the closed-loop ceiling of any token
world model with that tokenizer (docs/dynamics.md, "Why the policies fail inside the model").

A wmkit policy (scripts/wmpolicy.py) for wm-sim-policy: each frame the simulator renders is encoded
and decoded by the tokenizer (its PyTorch twin, tests/tokenize/vqvae_twin.py) with the episode's
first frame as the anchor, exactly as wm-eval decodes an imagined frame, and the reconstruction is
what scripts/tabletop_colour_policy.py's policy is shown; the first frame is shown as it is, as in
wm-eval's closed loop. The simulator still acts on the true actions, so the values wm-sim-policy
reports are what the policies achieve when they read the tokenizer's frames and the world's
dynamics are perfect. --blur SIGMA shows it the frames under a Gaussian blur instead (a control:
how much softening the policy stands).

  wm-sim-policy ... --policy "colour_tok=bench/tokenized_colour_policy.py --tokenizer RUN --noise 0"
"""
import argparse
import os
import sys

import cv2
import numpy as np
import torch

SRC = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(SRC, "scripts"))
sys.path.insert(0, os.path.join(SRC, "tests", "tokenize"))
import tabletop_colour_policy as colour  # noqa: E402
import vqvae_twin  # noqa: E402
import wmpolicy  # noqa: E402


def planar(rgb):
    """uint8 [S, S, 3] -> float [1, 3, S, S] in [-1, 1], C-contiguous (vqvae_twin's note)."""
    return torch.from_numpy(
        np.ascontiguousarray(rgb.transpose(2, 0, 1), dtype=np.float32))[None] / 127.5 - 1


def rgb8(frame):
    """tokenize::PlanarToRgb8: round((x + 1) * 127.5), clamped."""
    out = torch.round((frame[0] + 1) * 127.5).clamp(0, 255).to(torch.uint8)
    return np.ascontiguousarray(out.permute(1, 2, 0).numpy())


class TokenizedColourPolicy:
    def __init__(self, episode, tokenizer, noise, blur):
        self.inner = colour.ColourPolicy(episode, noise)
        self.tokenizer, self.blur, self.anchor = tokenizer, blur, None

    def act(self, obs):
        if self.blur > 0:
            obs.image = cv2.GaussianBlur(obs.image, (0, 0), self.blur)
            return self.inner.act(obs)
        frame = planar(obs.image)
        if self.anchor is None:
            self.anchor = frame
        else:
            codes = vqvae_twin.encode(self.tokenizer, frame)
            obs.image = rgb8(vqvae_twin.decode(self.tokenizer, codes, self.anchor))
        return self.inner.act(obs)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tokenizer", help="a wm-tokenize run directory")
    parser.add_argument("--blur", type=float, default=0.0, help="Gaussian blur SIGMA instead")
    parser.add_argument("--noise", type=float, default=0.0, help="action noise SIGMA")
    args = parser.parse_args()
    if (args.tokenizer is None) == (args.blur <= 0):
        parser.error("give --tokenizer or --blur")
    torch.set_num_threads(1)
    tokenizer = vqvae_twin.load_checkpoint(args.tokenizer)[0] if args.tokenizer else None
    wmpolicy.serve(lambda episode: TokenizedColourPolicy(episode, tokenizer, args.noise, args.blur),
                   name="tabletop_colour_tokenized",
                   info={"noise": args.noise, "blur": args.blur,
                         "tokenizer": os.path.abspath(args.tokenizer) if args.tokenizer else ""})


if __name__ == "__main__":
    main()
