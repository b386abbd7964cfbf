#!/usr/bin/python3
"""PyTorch twin of the pose kind of the motion model (motion/pose_net.cc, model.kind: pose): the
same modules under the same parameter names, so a C++ checkpoint's tensors load strictly. Used
by test_warp_twin.py and by bench/pose_autoencoder.py and bench/pose_arm.py (whose measured
models docs/motion.md records: the C++ kind is their --renderer deconv autoencoder with its
PoseDynamics)."""
import torch
from torch import nn

from layer_twin import LayerNet
from warp_twin import down


def coordinates(size):
    """[1, 2, S, S] pixel x and y in [-1, 1]."""
    grid = torch.linspace(-1, 1, size)
    ys, xs = torch.meshgrid(grid, grid, indexing="ij")
    return torch.stack([xs, ys])[None]


class PoseEncoder(nn.Module):
    """The given frame (with pixel coordinates, so positions are easy to read out) -> a pose."""

    def __init__(self, pose_dim, c, image_size):
        super().__init__()
        layers = [m for i in range(4) for m in down(5 if i == 0 else c, c)]
        self.cnn = nn.Sequential(*layers)
        self.head = nn.Sequential(nn.Linear((image_size // 16) ** 2 * c, 256), nn.ReLU(),
                                  nn.Linear(256, pose_dim))
        self.register_buffer("grid", coordinates(image_size), persistent=False)

    def forward(self, frame):
        x = torch.cat([frame, self.grid.expand(frame.shape[0], -1, -1, -1)], 1)
        return self.head(self.cnn(x).flatten(1))


class DeconvRenderer(nn.Module):
    """A pose -> colour [B, 3, S, S] in [-1, 1] and alpha [B, 1, S, S], upsampled from a 4x4 map
    by four (nearest x2, 3x3 convolution) stages whose width halves towards the full size (a
    DCGAN-style decoder: unlike the spatial-broadcast one it need not compute every pixel from
    the pose alone; ConvTranspose2d is avoided, it is slow on this CPU)."""

    def __init__(self, pose_dim, width, image_size):
        super().__init__()
        self.start, self.width = image_size // 16, width
        self.fc = nn.Linear(pose_dim, width * self.start ** 2)
        widths, layers = [width, width, width // 2, width // 4, width // 4], []
        for i in range(4):
            layers += [nn.Upsample(scale_factor=2), nn.Conv2d(widths[i], widths[i + 1], 3, 1, 1),
                       nn.ReLU()]
        self.up = nn.Sequential(*layers, nn.Conv2d(widths[-1], 4, 3, 1, 1))
        nn.init.constant_(self.up[-1].bias[3:], -2.0)  # start mostly transparent, not dead

    def forward(self, pose):
        x = torch.relu(self.fc(pose)).view(-1, self.width, self.start, self.start)
        out = self.up(x)
        return torch.tanh(out[:, :3]), torch.sigmoid(out[:, 3:])


class PoseDynamics(nn.Module):
    """p_{t+1} = p_t + A a_t + g(p_t, a_t) (A linear, g a zero-initialised MLP `hidden` wide)."""

    def __init__(self, pose_dim, action_dim, hidden=128):
        super().__init__()
        self.action_map = nn.Linear(action_dim, pose_dim, bias=False)
        self.correction = nn.Sequential(nn.Linear(pose_dim + action_dim, hidden), nn.ReLU(),
                                        nn.Linear(hidden, hidden), nn.ReLU(),
                                        nn.Linear(hidden, pose_dim))
        nn.init.zeros_(self.correction[-1].weight)
        nn.init.zeros_(self.correction[-1].bias)

    def step(self, pose, action):
        return pose + self.action_map(action) + self.correction(torch.cat([pose, action], 1))

    def forward(self, pose, actions):
        """[B, H, P] the poses after each of `actions` [B, H, D] from `pose` [B, P]."""
        out = []
        for t in range(actions.shape[1]):
            pose = self.step(pose, actions[:, t])
            out.append(pose)
        return torch.stack(out, 1)


def over(rgb, alpha, background):
    """The drawn arm (colour, alpha) composited over `background` (a frame, or 1: white)."""
    return rgb * alpha + (1 - alpha) * background


def erase(eraser, frames):
    """`frames` with what moves erased by a one-layer LayerNet's mask and fill."""
    masks, fill = eraser.sprites(frames)
    return frames * (1 - masks) + fill * masks


class PoseNet(nn.Module):
    """The pose kind: encoder, renderer, eraser (a whole one-layer LayerNet, as the bench model)
    and dynamics; imagine() is the C++ Imagine before its clamp."""

    def __init__(self, action_dim, pose_dim=16, channels=32, width=64, image_size=64,
                 dynamics_hidden=128):
        super().__init__()
        self.encoder = PoseEncoder(pose_dim, channels, image_size)
        self.renderer = DeconvRenderer(pose_dim, width, image_size)
        self.eraser = LayerNet(1, layers=1, channels=channels, image_size=image_size)
        self.dynamics = PoseDynamics(pose_dim, action_dim, dynamics_hidden)

    def imagine(self, first, actions):
        background = erase(self.eraser, first)
        frames = []
        for pose in self.dynamics(self.encoder(first), actions).unbind(1):
            frames.append(over(*self.renderer(pose), background))
        return torch.stack(frames, 1)
