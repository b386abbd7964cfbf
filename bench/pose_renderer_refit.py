#!/usr/bin/python3
"""Where the pose kind's blur is (docs/motion.md, "The renderer refitted alone", session 45).

A wm-motion pose run's twin (tests/motion/motion_run.py) with its encoder, eraser and dynamics
frozen; only the renderer is trained further, each training frame drawn from its encoder pose
over a background erased from its episode's first frame (what a rollout draws over) or, with
--pairs, from a frame up to 8 steps away (the autoencoder's pairs). Then scored over the val
episodes against the run's own renderer: open-loop rollouts of the run's dynamics from frame 0
(bench/warp_predictor.py's scores, paired bootstrap of refit minus run) and the frames drawn from
their own poses (arm-region MSE). --fit-poses instead optimises, per val frame, the pose the
run's renderer draws best (no training): what any pose can draw. --sprites K instead trains a
fresh bench/sprite_renderer.py (K sprites placed by affine maps of the pose) in the renderer's
place, first --distill steps towards the run's renderer's colour and alpha (so the placements
start where the run draws the arm), then as above (docs/motion.md, "An arm drawn from sprites;
a wider renderer", session 46; neither kept); --wider W refits the run's renderer with a
second one W wide added, its output started at zero (more capacity).

  bench/pose_renderer_refit.py --run RUN --train TRAIN --val VAL [--steps 4000] [--loss l2|l1]
      [--pairs] [--strip out.png] [--fit-poses] [--sprites K [--distill 1000] [--canvas out.png]]
      [--wider W]
"""
import argparse
import copy
import os
import sys

import numpy as np
import torch

HERE = os.path.dirname(os.path.abspath(__file__))
for sub in ("tests/motion", "tests/tokenize", "scripts"):
    sys.path.insert(0, os.path.join(HERE, "..", sub))
sys.path.insert(0, HERE)
import dynamics_token_recipes as recipes  # noqa: E402
import motion_run  # noqa: E402
import warp_predictor as wp  # noqa: E402
from pose_twin import DeconvRenderer, erase, over  # noqa: E402
from sprite_renderer import SpriteRenderer  # noqa: E402
from tokenizer_goal1 import region_mse, to_uint8  # noqa: E402

ARM, HORIZON, BATCH, PAIR_WINDOW = 1, 8, 16, 8


def draw(renderer, poses, background):
    return over(*renderer(poses), background)


def refit(net, episodes, args):
    """A copy of the run with its renderer trained further (Adam 3e-4) on frozen poses; the
    rest untouched."""
    frames = torch.cat([f for f, _, _ in episodes])
    owner = torch.cat([torch.full((len(f),), k) for k, (f, _, _) in enumerate(episodes)])
    starts = torch.tensor(np.cumsum([0] + [len(f) for f, _, _ in episodes[:-1]]))
    lengths = torch.tensor([len(f) for f, _, _ in episodes])
    with torch.no_grad():
        poses = torch.cat([net.encoder(frames[i:i + 256]) for i in range(0, len(frames), 256)])
        firsts = torch.cat([f[:1] for f, _, _ in episodes])
        first_bg = torch.cat([erase(net.eraser, firsts[i:i + 64])
                              for i in range(0, len(firsts), 64)])
    refitted = copy.deepcopy(net)
    if args.sprites:
        refitted.renderer = SpriteRenderer(poses.shape[1], args.sprites)
    elif args.wider:
        refitted.renderer = WiderRenderer(refitted.renderer, poses.shape[1], args.wider)
    renderer = refitted.renderer.train()
    for p in renderer.parameters():
        p.requires_grad_(True)
    opt = optimizer(renderer)
    if args.sprites:
        distill(renderer, net.renderer, poses, opt, args.distill)
    for step in range(args.steps):
        idx = torch.randint(len(frames), (BATCH,))
        o = owner[idx]
        if args.pairs:
            src = (idx - starts[o] + torch.randint(-PAIR_WINDOW, PAIR_WINDOW + 1, (BATCH,)))
            src = torch.minimum(src.clamp(min=0), lengths[o] - 1) + starts[o]
            with torch.no_grad():
                background = erase(net.eraser, frames[src])
        else:
            background = first_bg[o]
        err = draw(renderer, poses[idx], background) - frames[idx]
        loss = err.abs().mean() if args.loss == "l1" else err.pow(2).mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
        if step % 1000 == 0:
            print(f"step {step} loss {loss.item():.4f}", flush=True)
    return refitted.eval()


class WiderRenderer(torch.nn.Module):
    """The run's renderer plus a deconv renderer `width` wide whose output starts at zero,
    added before the tanh and sigmoid: more capacity that starts where the run is."""

    def __init__(self, base, pose_dim, width):
        super().__init__()
        self.base, self.extra = base, DeconvRenderer(pose_dim, width, base.start * 16)
        torch.nn.init.zeros_(self.extra.up[-1].weight)
        torch.nn.init.zeros_(self.extra.up[-1].bias)

    @staticmethod
    def logits(r, pose):
        return r.up(torch.relu(r.fc(pose)).view(-1, r.width, r.start, r.start))

    def forward(self, pose):
        out = self.logits(self.base, pose) + self.logits(self.extra, pose)
        return torch.tanh(out[:, :3]), torch.sigmoid(out[:, 3:])


def optimizer(renderer):
    """Adam 3e-4; a sprite's pixels 1e-2 (each is one parameter that must move its logit by a
    few units, as the layers' template pixels learned 10x faster)."""
    sprites = [p for n, p in renderer.named_parameters() if n == "sprites"]
    rest = [p for n, p in renderer.named_parameters() if n != "sprites"]
    return torch.optim.Adam([{"params": rest}, {"params": sprites, "lr": 1e-2}], lr=3e-4)


def distill(renderer, teacher, poses, opt, steps):
    """Train `renderer` to draw the teacher's colour (where it is opaque) and alpha."""
    for step in range(steps):
        idx = torch.randint(len(poses), (BATCH,))
        with torch.no_grad():
            rgb_t, alpha_t = teacher(poses[idx])
        rgb, alpha = renderer(poses[idx])
        loss = (alpha - alpha_t).pow(2).mean() + (rgb * alpha - rgb_t * alpha_t).pow(2).mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
        if step % 500 == 0:
            print(f"distill step {step} loss {loss.item():.4f}", flush=True)


def write_canvas(path, renderer):
    """Each sprite's colour over blue where its alpha is 0, beside its alpha (white = 1)."""
    with torch.no_grad():
        colour = torch.tanh(renderer.sprites[:, :3]) * 0.5 + 0.5
        alpha = torch.sigmoid(renderer.sprites[:, 3:])
        blue = torch.tensor([0.0, 0.0, 1.0]).view(1, 3, 1, 1)
        shown = torch.cat([colour * alpha + blue * (1 - alpha), alpha.expand(-1, 3, -1, -1)], 3)
    rows = [(x.permute(1, 2, 0).numpy() * 255) for x in shown]
    wp.write_strip(path, rows)


@torch.no_grad()
def rollout(net, frames, actions):
    return to_uint8(net.imagine(frames[:1], actions)[0])


def own_pose_arm(net, frames, seg):
    """Arm-region MSE of frames 1..H drawn from their own encoder poses over frame 0's
    background."""
    with torch.no_grad():
        drawn = draw(net.renderer, net.encoder(frames[1:HORIZON + 1]),
                     erase(net.eraser, frames[:1]))
    return np.nanmean(region_mse(to_uint8(frames[1:HORIZON + 1]), to_uint8(drawn),
                                 seg[1:HORIZON + 1], ARM))


def fitted_pose_arm(net, frames, seg, steps=300):
    """The same with each frame's pose optimised for the run's renderer (Adam from the
    encoder's pose, squared error): the best that renderer can draw."""
    background = erase(net.eraser, frames[:1])
    target = frames[1:HORIZON + 1]
    with torch.no_grad():
        start = net.encoder(target)
    pose = start.clone().requires_grad_(True)
    opt = torch.optim.Adam([pose], lr=0.05)
    for _ in range(steps):
        loss = (draw(net.renderer, pose, background) - target).pow(2).mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
    with torch.no_grad():
        drawn = draw(net.renderer, pose, background)
    return np.nanmean(region_mse(to_uint8(target), to_uint8(drawn), seg[1:HORIZON + 1], ARM))


def paired(found, key, rng):
    """Mean of refit minus run over episodes, with its 95% bootstrap interval."""
    d = np.array([s[key] for s in found["refit"]]) - np.array([s[key] for s in found["run"]])
    boot = [rng.choice(d, len(d)).mean() for _ in range(2000)]
    return d.mean(), *np.percentile(boot, [2.5, 97.5])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--run", required=True, help="wm-motion run directory (pose kind)")
    ap.add_argument("--train", required=True)
    ap.add_argument("--val", required=True)
    ap.add_argument("--steps", type=int, default=4000)
    ap.add_argument("--loss", choices=("l2", "l1"), default="l2")
    ap.add_argument("--pairs", action="store_true",
                    help="backgrounds of frames up to 8 steps away instead of the first frame")
    ap.add_argument("--fit-poses", action="store_true")
    ap.add_argument("--sprites", type=int, default=0, metavar="K",
                    help="a fresh sprite renderer of K parts instead of the run's")
    ap.add_argument("--distill", type=int, default=1000,
                    help="--sprites: steps towards the run's renderer first")
    ap.add_argument("--canvas", help="--sprites: PNG of the learned sprites")
    ap.add_argument("--wider", type=int, default=0, metavar="W", help="the run's renderer "
                    "plus a zero-started deconv renderer W wide (more capacity)")
    ap.add_argument("--strip", help="PNG: real, run, refit rows of val episodes 0-3")
    args = ap.parse_args()
    torch.set_num_threads(1)
    torch.manual_seed(0)
    net, norm = motion_run.load_run(args.run, "pose")
    for p in net.parameters():
        p.requires_grad_(False)
    val = recipes.load(args.val)
    if args.fit_poses:
        own = [own_pose_arm(net, f, s) for f, s, _ in val]
        fit = [fitted_pose_arm(net, f, s) for f, s, _ in val]
        print(f"arm MSE from the encoder's poses {np.mean(own):.0f}, "
              f"from fitted poses {np.mean(fit):.0f}")
        return
    train = recipes.load(args.train)
    refitted = refit(net, train, args)
    for name, model in (("run", net), ("refit", refitted)):  # fitted, or still averaging?
        fit = [own_pose_arm(model, f, s) for f, s, _ in train[:16]]
        print(f"{name}: frames of training episodes 0-15 from their own poses: arm MSE "
              f"{np.mean(fit):.0f}")
    if args.canvas:
        write_canvas(args.canvas, refitted.renderer)
    found = {"run": [], "refit": [], "copy_last": []}
    own, rows = {"run": [], "refit": []}, []
    for k, (frames, seg, acts) in enumerate(val):
        actions = torch.tensor(norm(acts[:HORIZON]))[None]
        preds = {"run": rollout(net, frames, actions), "refit": rollout(refitted, frames, actions)}
        real, scored = wp.window_scores(frames, seg, preds)
        for name in found:
            found[name].append(scored[name])
        for name, model in (("run", net), ("refit", refitted)):
            own[name].append(own_pose_arm(model, frames, seg))
        if k < 4:
            rows += [np.concatenate(list(x), 1) for x in (real, preds["run"], preds["refit"])]
    means, rng = wp.means(found), np.random.default_rng(0)
    for name in ("run", "refit"):
        m, c = means[name], means["copy_last"]
        print(f"{name}: PSNR {m['psnr']:.2f} (copy_last {c['psnr']:.2f}), SSIM {m['ssim']:.3f}, "
              f"arm {m['arm'] / c['arm']:.2f}x (step 8 {m['arm8'] / c['arm8']:.2f}x), "
              f"block {m['obj'] / c['obj']:.2f}x copy_last's; frames from their own poses: "
              f"arm MSE {np.mean(own[name]):.0f}")
    for key in ("psnr", "ssim", "arm", "obj"):
        print("refit - run %s %+.3f [%+.3f, %+.3f]" % (key, *paired(found, key, rng)))
    if args.strip:
        wp.write_strip(args.strip, rows)


if __name__ == "__main__":
    main()
