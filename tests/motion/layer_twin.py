#!/usr/bin/python3
"""PyTorch twin of the layered motion model (motion/layer_net.cc, model.kind: layers): the same
modules under the same parameter names, so a C++ checkpoint's tensors load strictly. Used by
test_warp_twin.py and by bench/layer_predictor.py."""
import torch
from torch import nn
from torch.nn import functional as F

from warp_twin import down, up

AFFINE = 6  # per layer and step: linear part (4, about the centroid) and translation (2)


class LayerNet(nn.Module):
    def __init__(self, action_dim, layers=3, channels=32, flow_scale=4.0, mask_bias=0.0,
                 mask_noise=0.0, image_size=64):
        super().__init__()
        self.mask_noise = mask_noise
        c, k = channels, layers
        self.layers, self.action_dim, self.flow_scale = k, action_dim, flow_scale
        # the sprites: masks and the fill behind them, from the start frame (a U-Net)
        self.down1, self.down2, self.down3 = down(3, c), down(c, c), down(c, c)
        self.middle = nn.Sequential(nn.Conv2d(c, c, 3, 1, 1), nn.ReLU())
        self.up3, self.up2, self.up1 = up(c, c), up(2 * c, c), up(2 * c, c)
        self.sprite_head = nn.Conv2d(c + 3, k + 3, 3, 1, 1)
        nn.init.zeros_(self.sprite_head.weight)
        nn.init.constant_(self.sprite_head.bias, mask_bias)
        # the motion: per layer b_k and J_k from the current frame and the layers' maps so far
        # four halvings in one flat Sequential (as C++, which cannot nest them)
        self.motion_cnn = nn.Sequential(*[m for i in range(4) for m in down(6 if i == 0 else c, c)])
        cells = (image_size // 16) ** 2  # the motion CNN's map, flattened
        self.motion_mlp = nn.Sequential(nn.Linear(cells * c + k * AFFINE, 256), nn.ReLU())
        self.motion_head = nn.Linear(256, k * AFFINE * (action_dim + 1))
        nn.init.zeros_(self.motion_head.weight)
        nn.init.zeros_(self.motion_head.bias)

    def sprites(self, first):
        """-> masks [B, K, S, S] in (0, 1) on the start frame's pixels, fill [B, 3, S, S]."""
        out = self.sprite_head(torch.cat([self.unet(first), first], 1))
        logits = out[:, :self.layers]
        if self.training and self.mask_noise > 0:  # noisy logits pay off only when saturated
            logits = logits + self.mask_noise * torch.randn_like(logits)
        return torch.sigmoid(logits), torch.tanh(out[:, self.layers:])

    def unet(self, x):
        """The sprite U-Net's features [B, C, S, S] of `x` (three halvings and back)."""
        h1 = self.down1(x)
        h2 = self.down2(h1)
        u = self.up3(self.middle(self.down3(h2)))
        return self.up1(torch.cat([self.up2(torch.cat([u, h2], 1)), h1], 1))

    def step_maps(self, current, first, maps, action):
        """[B, K, 6] affine increments for this step: b + J a (linear part 0.2 tanh(.), translation
        in flow_scale pixels)."""
        return self.increments(self.motion_hidden(current, first, maps), action, maps.shape[1])

    def motion_hidden(self, current, first, maps):
        """[B, 256] the motion MLP's output for the layers at `maps` (a hook for variants)."""
        feats = self.motion_features(current, first)
        state = (maps[:, :, :2, :] - torch.eye(3)[:2]).flatten(1)  # [B, K * 6]
        return self.motion_mlp(torch.cat([feats, state * 0.05], 1))

    def increments(self, hidden, action, k):
        """[B, K, 6] b + J a for `k` layers from the motion MLP's output."""
        b, d = hidden.shape[0], self.action_dim
        out = self.motion_head(hidden).view(b, k, AFFINE, d + 1)
        inc = out[..., 0] + (out[..., 1:] * action.view(b, 1, 1, d)).sum(-1)
        # bounded linear part: a step never shrinks or shears a layer to a singular map
        return torch.cat([0.2 * torch.tanh(inc[..., :4]), inc[..., 4:] * self.flow_scale], -1)

    def motion_features(self, current, first):
        """[B, F] what the motion MLP reads of the frames (a hook for bench variants)."""
        return self.motion_cnn(torch.cat([current, first], 1)).flatten(1)

    def forward(self, first, actions, frames_in=None, fixed=None):
        """Open-loop frames [B, H, 3, S, S] after `first` under normalised actions [B, H, D];
        `frames_in` [B, H, 3, S, S] (teacher forcing) replaces the imagined current frames the
        motion CNN reads; `fixed` [B, H, K, 6] replaces the predicted increments (--ceiling)."""
        b, h = actions.shape[:2]
        masks, fill = self.sprites(first)
        self.last_masks = masks  # for fit()'s mask penalty
        centre0 = self.centroids(masks)  # [B, K, 2] on the start frame
        maps = torch.eye(3).expand(b, self.layers, 3, 3)
        current, out, increments = first, [], []
        for t in range(h):
            inc = (self.step_maps(current.detach(), first, maps, actions[:, t]) if fixed is None
                   else fixed[:, t])
            increments.append(inc)
            centre = apply(maps, centre0)
            maps = self.combine(increment(inc, centre)) @ maps
            frame = self.render(first, masks, fill, maps)
            out.append(frame)
            current = frame if frames_in is None else frames_in[:, t]
        self.last_increments = torch.stack(increments, 1)  # [B, H, K, 6], for --ceiling
        return torch.stack(out, 1)

    def centroids(self, masks):
        """[B, K, 2] the layers' centroids in frame pixels (a hook for bench variants)."""
        return centroids(masks)

    def render(self, first, masks, fill, maps):
        """The imagined frame (a hook for bench variants)."""
        return render(first, masks, fill, maps, first.shape[-1])

    def combine(self, steps):
        """[B, K, 3, 3] this step's maps per layer -> the maps applied (a hook for variants in
        bench/layer_variants.py; the model itself applies each layer's own)."""
        return steps


def centroids(masks):
    """[B, K, S, S] -> [B, K, 2] mask-weighted mean pixel (x, y)."""
    s = masks.shape[-1]
    grid = torch.arange(s, dtype=masks.dtype)
    w = masks.sum((2, 3)) + 1e-6
    x = (masks.sum(2) * grid).sum(-1) / w
    y = (masks.sum(3) * grid).sum(-1) / w
    return torch.stack([x, y], -1)


def apply(maps, points):
    """[B, K, 3, 3] affine maps of [B, K, 2] points."""
    return (maps[..., :2, :2] @ points[..., None])[..., 0] + maps[..., :2, 2]


def increment(inc, centre):
    """[B, K, 6] (linear part about `centre`, translation) -> [B, K, 3, 3] maps:
    p' = centre + L (p - centre) + t."""
    lin = torch.eye(2) + inc[..., :4].view(*inc.shape[:2], 2, 2)
    shift = centre + inc[..., 4:] - (lin @ centre[..., None])[..., 0]
    top = torch.cat([lin, shift[..., None]], -1)
    bottom = torch.tensor([0.0, 0.0, 1.0]).expand(*inc.shape[:2], 1, 3)
    return torch.cat([top, bottom], -2)


def render(first, masks, fill, maps, s, colours=None, margin=0, padding="border",
           background=None):
    """The layers of `first` moved by `maps` (source -> imagined pixels), composited front
    (layer 0) to back over the background: `first` where no layer covers it, `fill` where one
    does. bench/layer_variants.py's --margin passes masks and `colours` [B, 3, C, C] on a canvas
    `margin` pixels wider than the frame on each side; its --template passes the `background`
    the layers are composited over."""
    b, k = masks.shape[:2]
    c = s + 2 * margin
    inv = torch.linalg.inv(maps)  # imagined pixel -> source pixel
    coords = torch.arange(s, dtype=first.dtype)
    ys, xs = torch.meshgrid(coords, coords, indexing="ij")
    pix = torch.stack([xs, ys, torch.ones_like(xs)], -1).view(1, 1, s * s, 3)
    src = ((pix @ inv.transpose(-1, -2))[..., :2] + margin).view(b * k, s, s, 2) / (c - 1) * 2 - 1
    colours = first if colours is None else colours
    layer = torch.cat([colours[:, None] * masks[:, :, None], masks[:, :, None]], 2)
    moved = F.grid_sample(layer.view(b * k, 4, c, c), src, mode="bilinear",
                          padding_mode=padding, align_corners=True).view(b, k, 4, s, s)
    frame_masks = masks[..., margin:margin + s, margin:margin + s]
    if background is None:
        visible = torch.prod(1 - frame_masks, 1, keepdim=True)
        background = visible * first + (1 - visible) * fill
    out = background
    for j in reversed(range(k)):
        out = moved[:, j, :3] + (1 - moved[:, j, 3:]) * out
    return out
