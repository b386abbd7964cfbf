"""A renderer for the pose kind drawn from learned sprites (docs/motion.md, "An arm drawn from
sprites; a wider renderer", session 46; not kept): K RGBA canvases, parameters shared by every
frame, each placed on the frame by an affine map read from the pose (a spatial transformer,
Jaderberg et al. 2015) and composited back to front. The deconv renderer draws every pose's
arm anew from a 4x4 map, and on 1000 episodes it averages into a blob; a sprite is one drawing,
moved exactly, so it stays as sharp as its placements agree.

The canvas is twice the frame's height at the frame's pixel size (the arm's link runs up out of
the frame from wherever the gripper is); the base placement shows its lower half.

Measured: on the demo's frozen poses the sprites learn the link and its shadow sharp but draw the
gripper as ghosts; trained with the encoder the pose never starts."""
import torch
from torch import nn
from torch.nn import functional as F


class SpriteRenderer(nn.Module):
    def __init__(self, pose_dim, parts=4, image_size=64, hidden=256, seed=0):
        super().__init__()
        g = torch.Generator().manual_seed(seed)
        self.size = image_size
        # colour (pre-tanh) and alpha logit; the alpha starts faint with noise, so the parts
        # differ and none starts dead
        sprites = torch.zeros(parts, 4, 2 * image_size, image_size)
        sprites[:, 3] = -4.0 + 0.5 * torch.randn(parts, 2 * image_size, image_size, generator=g)
        self.sprites = nn.Parameter(sprites)
        self.place = nn.Sequential(nn.Linear(pose_dim, hidden), nn.ReLU(),
                                   nn.Linear(hidden, hidden), nn.ReLU(),
                                   nn.Linear(hidden, parts * 6))
        with torch.no_grad():  # frame (x, y) -> canvas (x, 0.5 y + 0.5): its lower half
            self.place[-1].weight.mul_(0.01)
            base = torch.tensor([1.0, 0.0, 0.0, 0.0, 0.5, 0.5])
            self.place[-1].bias.copy_(base.repeat(parts))

    def layers(self, pose):
        """[B, K, 4, S, S] each part's colour (in [-1, 1]) and alpha on the frame."""
        b, k = pose.shape[0], self.sprites.shape[0]
        theta = self.place(pose).view(b * k, 2, 3)
        grid = F.affine_grid(theta, (b * k, 4, self.size, self.size), align_corners=False)
        canvas = self.sprites[None].expand(b, -1, -1, -1, -1).reshape(b * k, 4,
                                                                       *self.sprites.shape[2:])
        # outside the canvas: transparent (alpha logit -20, so zeros padding is not half alpha)
        drawn = F.grid_sample(canvas - _OFFSET, grid, align_corners=False) + _OFFSET
        drawn = drawn.view(b, k, 4, self.size, self.size)
        return torch.cat([torch.tanh(drawn[:, :, :3]), torch.sigmoid(drawn[:, :, 3:])], 2)

    def forward(self, pose):
        """(colour [B, 3, S, S], alpha [B, 1, S, S]) of the parts composited back to front,
        so that over(colour, alpha, background) draws them."""
        parts = self.layers(pose)
        premultiplied = torch.zeros_like(parts[:, 0, :3])
        alpha = torch.zeros_like(parts[:, 0, 3:])
        for k in range(parts.shape[1]):
            a = parts[:, k, 3:]
            premultiplied = parts[:, k, :3] * a + (1 - a) * premultiplied
            alpha = a + (1 - a) * alpha
        return premultiplied / alpha.clamp(min=1e-6), alpha


_OFFSET = torch.tensor([0.0, 0.0, 0.0, -20.0]).view(1, 4, 1, 1)
