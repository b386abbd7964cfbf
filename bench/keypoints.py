"""A pose made of keypoints, for bench/pose_autoencoder.py's --renderer keypoint (session 32).

A pose vector read by a fully connected head and drawn by a decoder from a 4x4 map (session 31)
draws a smooth arm without fingers: every pixel of it is a function of all the pose's numbers.
Here the pose is K points (x, y) in the frame, each the expected position of a softmax heatmap
(Jakab et al. 2018, "Unsupervised learning of object landmarks by factorized spatial
embeddings"; Minderer et al. 2019, "Unsupervised learning of object structure and dynamics
from videos", whose keypoints are also moved by a learned dynamics), and the renderer draws
from a Gaussian blob at each point, through convolutions: what it draws near a point depends
on the points near it, and a point that moves moves what it draws.
"""
import torch
from torch import nn

import pose_arm


def conv(i, o, k=3, stride=1):
    return nn.Sequential(nn.Conv2d(i, o, k, stride, (k - 1) // 2 if stride == 1 else 1),
                         nn.ReLU())


class KeypointEncoder(nn.Module):
    """A frame [B, 3, S, S] -> K keypoints [B, 2K] (x0, y0, x1, ...) in [-1, 1]: K heatmaps at a
    quarter of the size, each a softmax over its pixels, read out as its expected position.
    With `canvas` c > 1 the frame is padded (grey) to c times its size first and the points lie
    in [-c, c]: an arm above the frame, seen by its shadow, has somewhere to be."""

    def __init__(self, keypoints, c, image_size, canvas=1.0):
        super().__init__()
        self.cnn = nn.Sequential(conv(5, c), conv(c, c, 4, 2), conv(c, c), conv(c, c, 4, 2),
                                 conv(c, c), nn.Conv2d(c, keypoints, 1))
        size = 4 * round(canvas * image_size / 4)
        self.pad = (size - image_size) // 2
        extent = size / image_size
        self.register_buffer("grid", extent * pose_arm.coordinates(size), persistent=False)
        self.register_buffer("points", extent * pose_arm.coordinates(size // 4).flatten(2)[0].T,
                             persistent=False)  # [N, 2] the heatmap pixels' (x, y)

    def heatmaps(self, frame):
        frame = nn.functional.pad(frame, [self.pad] * 4)
        x = torch.cat([frame, self.grid.expand(frame.shape[0], -1, -1, -1)], 1)
        return torch.softmax(self.cnn(x).flatten(2), -1)  # [B, K, N]

    def forward(self, frame):
        return (self.heatmaps(frame) @ self.points).flatten(1)


class KeypointRenderer(nn.Module):
    """K keypoints [B, 2K] -> colour [B, 3, S, S] in [-1, 1] and alpha [B, 1, S, S]: a Gaussian
    blob (`sigma`, in [-1, 1] units) per keypoint beside the pixel coordinates, through a small
    U-Net (full size, half, quarter; nearest upsampling), its output alpha started at
    sigmoid(-2) and colour grey (session 31: a saturated start kills the alpha). With `offsets`
    also each pixel's offset from each keypoint (2K channels, clipped to [-1, 1]): a keypoint
    outside the frame has no blob in it, but its offsets say where it is."""

    def __init__(self, keypoints, width, image_size, sigma, offsets=False):
        super().__init__()
        w, self.sigma, self.offsets = width, sigma, offsets
        inputs = (3 if offsets else 1) * keypoints + 2
        self.at_full = nn.Sequential(conv(inputs, w), conv(w, w))
        self.at_half = nn.Sequential(conv(w, 2 * w, 4, 2), conv(2 * w, 2 * w))
        self.at_quarter = nn.Sequential(conv(2 * w, 2 * w, 4, 2), conv(2 * w, 2 * w),
                                     nn.Upsample(scale_factor=2), conv(2 * w, 2 * w))
        self.up = nn.Sequential(conv(4 * w, 2 * w), nn.Upsample(scale_factor=2), conv(2 * w, w))
        self.out = nn.Sequential(conv(2 * w, w), nn.Conv2d(w, 4, 3, 1, 1))
        nn.init.zeros_(self.out[-1].bias)
        nn.init.constant_(self.out[-1].bias[3:], -2.0)
        self.register_buffer("grid", pose_arm.coordinates(image_size), persistent=False)

    def blobs(self, pose):
        """[B, K, S, S] a Gaussian at each keypoint (and [B, 2K, S, S] offsets, if asked)."""
        points = pose.view(pose.shape[0], -1, 2)[:, :, :, None, None]  # [B, K, 2, 1, 1]
        offsets = self.grid[:, None] - points
        blobs = torch.exp(-offsets.pow(2).sum(2) / (2 * self.sigma ** 2))
        if not self.offsets:
            return blobs
        return torch.cat([blobs, offsets.flatten(1, 2).clamp(-1, 1)], 1)

    def forward(self, pose):
        b = pose.shape[0]
        full = self.at_full(torch.cat([self.blobs(pose), self.grid.expand(b, -1, -1, -1)], 1))
        half = self.at_half(full)
        up = self.up(torch.cat([half, self.at_quarter(half)], 1))
        out = self.out(torch.cat([full, up], 1))
        return torch.tanh(out[:, :3]), torch.sigmoid(out[:, 3:])
