#!/usr/bin/python3
"""PyTorch twin of the motion model (motion/warp_net.cc): the same modules under the same
parameter names, so a C++ checkpoint's tensors load strictly. Used by test_warp_twin.py and by
bench/warp_predictor.py."""
import torch
import torch.nn.functional as F
from torch import nn

RGB, GATE, FLOW_BIAS, JACOBIAN = 0, 3, 4, 6


def down(i, o):
    return nn.Sequential(nn.Conv2d(i, o, 4, 2, 1), nn.ReLU())


def up(i, o):
    return nn.Sequential(nn.ConvTranspose2d(i, o, 4, 2, 1), nn.ReLU())


def warp(image, flow):
    """out(p) = image(p + flow(p)), bilinear, border, pixel centres at integer coordinates."""
    _, _, h, w = image.shape
    xs = torch.arange(w, dtype=image.dtype).view(1, 1, w)
    ys = torch.arange(h, dtype=image.dtype).view(1, h, 1)
    gx = (xs + flow[:, 0]) / float(w - 1) * 2 - 1
    gy = (ys + flow[:, 1]) / float(h - 1) * 2 - 1
    return F.grid_sample(image, torch.stack([gx, gy], -1), mode="bilinear",
                         padding_mode="border", align_corners=True)


class WarpNet(nn.Module):
    def __init__(self, model, action_dim):
        super().__init__()
        c = model["channels"]
        self.flow_scale, self.gate_bias = model["flow_scale"], model["gate_bias"]
        self.jacobian, self.action_dim = model["action_jacobian"], action_dim
        self.down1, self.down2, self.down3 = down(6, c), down(c, c), down(c, c)
        self.action_in = nn.Linear(action_dim, c)
        self.middle = nn.Sequential(nn.Conv2d(c, c, 3, 1, 1), nn.ReLU(), nn.Conv2d(c, c, 3, 1, 1),
                                    nn.ReLU())
        self.up3, self.up2, self.up1 = up(c, c), up(2 * c, c), up(2 * c, c)
        self.head = nn.Conv2d(c + 6, JACOBIAN + (2 * action_dim if self.jacobian else 0), 3, 1, 1)
        nn.init.zeros_(self.head.weight)
        nn.init.zeros_(self.head.bias)

    def forward(self, current, previous, action):
        """-> (next, flow, gate) as motion/warp_net.h's WarpStep."""
        inp = torch.cat([current, previous], 1)
        h1 = self.down1(inp)
        h2 = self.down2(h1)
        u = self.up3(self.middle(self.down3(h2) + self.action_in(action)[:, :, None, None]))
        u = self.up1(torch.cat([self.up2(torch.cat([u, h2], 1)), h1], 1))
        out = self.head(torch.cat([u, inp], 1))
        flow = out[:, FLOW_BIAS:JACOBIAN]
        if self.jacobian:
            b, _, h, w = out.shape
            jac = out[:, JACOBIAN:].view(b, 2, self.action_dim, h, w)
            flow = flow + (jac * action.view(b, 1, self.action_dim, 1, 1)).sum(2)
        flow = flow * self.flow_scale
        gate = torch.sigmoid(out[:, GATE:GATE + 1] + self.gate_bias)
        rgb = torch.tanh(out[:, RGB:RGB + 3])
        return (1 - gate) * warp(current, flow) + gate * rgb, flow, gate


@torch.no_grad()
def imagine(net, first, actions):
    """[B, H, 3, S, S]: open-loop frames after `first` under normalised actions [B, H, D]."""
    current = previous = first
    frames = []
    for h in range(actions.shape[1]):
        nxt = net(current, previous, actions[:, h])[0].clamp(-1, 1)
        frames.append(nxt)
        previous, current = current, nxt
    return torch.stack(frames, 1)
