#!/usr/bin/python3
"""PyTorch twin of the pose kind of the motion model (motion/pose_net.cc, model.kind: pose): the
same modules under the same parameter names, so a C++ checkpoint's tensors load strictly. Used
by test_warp_twin.py and by bench/pose_autoencoder.py and bench/pose_arm.py (whose measured
models docs/motion.md records: the C++ kind is their --renderer deconv autoencoder with its
PoseDynamics)."""
import torch
from torch import nn

from layer_twin import LayerNet
from warp_twin import down, warp


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


def upsampling_stages(width, outputs):
    """Four (nearest x2, 3x3 convolution, ReLU) stages of width, width / 2, width / 4, width / 4
    channels, then a 3x3 convolution to `outputs`."""
    widths, layers = [width, width, width // 2, width // 4, width // 4], []
    for i in range(4):
        layers += [nn.Upsample(scale_factor=2), nn.Conv2d(widths[i], widths[i + 1], 3, 1, 1),
                   nn.ReLU()]
    return nn.Sequential(*layers, nn.Conv2d(widths[-1], outputs, 3, 1, 1))


class DeconvRenderer(nn.Module):
    """A pose -> colour [B, 3, S, S] in [-1, 1] and alpha [B, 1, S, S], upsampled from a 4x4 map
    by four (nearest x2, 3x3 convolution) stages whose width halves towards the full size (a
    DCGAN-style decoder: unlike the spatial-broadcast one it need not compute every pixel from
    the pose alone; ConvTranspose2d is avoided, it is slow on this CPU). With `shade` (the C++
    model.renderer_shade) also a shade [B, 1, S, S] in (0, 1): a third output."""

    def __init__(self, pose_dim, width, image_size, shade=False):
        super().__init__()
        self.start, self.width, self.shade = image_size // 16, width, shade
        self.fc = nn.Linear(pose_dim, width * self.start ** 2)
        self.up = upsampling_stages(width, 5 if shade else 4)
        nn.init.constant_(self.up[-1].bias[3:4], -2.0)  # start mostly transparent, not dead
        if shade:
            nn.init.constant_(self.up[-1].bias[4:], 2.0)  # nearly lit, not saturated

    def forward(self, pose):
        x = torch.relu(self.fc(pose)).view(-1, self.width, self.start, self.start)
        out = self.up(x)
        drawn = torch.tanh(out[:, :3]), torch.sigmoid(out[:, 3:4])
        return drawn + (torch.sigmoid(out[:, 4:]),) if self.shade else drawn


class PoseMover(nn.Module):
    """(start pose p_s, pose p) -> backward flow [B, 2, S, S] in pixels: flow_scale x
    sum_i J_i(p_s) (p - p_s)_i, J upsampled from p_s as the renderer upsamples, its last
    convolution zero at the start (the C++ model.renderer_warp)."""

    def __init__(self, pose_dim, width, image_size, flow_scale):
        super().__init__()
        self.start, self.width, self.flow_scale = image_size // 16, width, flow_scale
        self.fc = nn.Linear(pose_dim, width * self.start ** 2)
        self.up = upsampling_stages(width, 2 * pose_dim)
        nn.init.zeros_(self.up[-1].weight)
        nn.init.zeros_(self.up[-1].bias)

    def forward(self, start_pose, pose):
        x = torch.relu(self.fc(start_pose)).view(-1, self.width, self.start, self.start)
        jacobian = self.up(x)
        b, p, s = pose.shape[0], pose.shape[1], jacobian.shape[-1]
        change = (pose - start_pose).view(b, 1, p, 1, 1)
        return self.flow_scale * (jacobian.view(b, 2, p, s, s) * change).sum(2)


class PoseDynamics(nn.Module):
    """p_{t+1} = p_t + A a_t + g(p_t, a_t) (A linear, g a zero-initialised MLP)."""

    def __init__(self, pose_dim, action_dim):
        super().__init__()
        self.action_map = nn.Linear(action_dim, pose_dim, bias=False)
        self.correction = nn.Sequential(nn.Linear(pose_dim + action_dim, 128), nn.ReLU(),
                                        nn.Linear(128, 128), nn.ReLU(), nn.Linear(128, pose_dim))
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


def over(rgb, alpha, background, shade=None):
    """The drawn arm (colour, alpha) composited over `background` (a frame, or 1: white), whose
    light (frames in [-1, 1]: black is -1) a `shade` multiplies, as a shadow does."""
    if shade is not None:
        background = (background + 1) * shade - 1
    return rgb * alpha + (1 - alpha) * background


def erase(eraser, frames):
    """`frames` with what moves erased by a one-layer LayerNet's mask and fill."""
    masks, fill = eraser.sprites(frames)
    return frames * (1 - masks) + fill * masks


class PoseNet(nn.Module):
    """The pose kind: encoder, renderer, eraser (a whole one-layer LayerNet, as the bench model)
    and dynamics; imagine() is the C++ Imagine before its clamp."""

    def __init__(self, action_dim, pose_dim=16, channels=32, width=64, image_size=64,
                 shade=False, warp_scale=None):
        super().__init__()
        self.encoder = PoseEncoder(pose_dim, channels, image_size)
        self.renderer = DeconvRenderer(pose_dim, width, image_size, shade)
        self.eraser = LayerNet(1, layers=1, channels=channels, image_size=image_size)
        self.dynamics = PoseDynamics(pose_dim, action_dim)
        # the C++ model.renderer_warp, with model.flow_scale
        self.mover = None if warp_scale is None else PoseMover(pose_dim, width, image_size,
                                                               warp_scale)

    def start(self, first):
        """(background, moving layer [B, 4, S, S] or None, pose) of the start frames."""
        masks, fill = self.eraser.sprites(first)
        moving = None if self.mover is None else torch.cat([first * masks, masks], 1)
        return first * (1 - masks) + fill * masks, moving, self.encoder(first)

    def draw(self, pose, start):
        """The frame drawn from `pose` over what start() gave: the moving layer moved to it
        (premultiplied) over the background, then the renderer's drawing."""
        background, moving, start_pose = start
        if moving is not None:
            moved = warp(moving, self.mover(start_pose, pose))
            background = moved[:, :3] + (1 - moved[:, 3:]) * background
        rgb, alpha, *shade = self.renderer(pose)
        return over(rgb, alpha, background, *shade)

    def imagine(self, first, actions):
        start = self.start(first)
        frames = [self.draw(pose, start) for pose in self.dynamics(start[2], actions).unbind(1)]
        return torch.stack(frames, 1)
