#!/usr/bin/python3
"""The variants of the layered motion model's twin that bench/layer_predictor.py measures
against the recipe (tests/motion/layer_twin.py's LayerNet), each a subclass overriding its hooks,
and the options that pick one (docs/motion.md says what each did; none is in wm-motion)."""
import os
import sys

import cv2
import numpy as np
import torch
from torch.nn import functional as F

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests",
                                "motion"))
import layer_twin as lt  # noqa: E402
from layer_twin import LayerNet  # noqa: E402
from warp_twin import down as wp_down  # noqa: E402


def mlp_inputs(net):
    """The recipe motion MLP's input width: the motion CNN's map flattened, and the maps."""
    return net.motion_mlp[0].in_features


def add_block_labels(lookup, episodes, label=2):
    """The block's true segmentation on each frame of `episodes`, grown by a pixel, into the
    FrameLookup `lookup` (--block-label, --carry-choice)."""
    for frames, seg, _ in episodes:
        block = torch.from_numpy((seg == label).astype(np.float32))[:, None]
        lookup.add(frames, F.max_pool2d(block, 3, 1, 1))


class FrameLookup:
    """Per-frame data that a variant reads beside the given frame (its depth, a label), looked
    up by the frame's bytes, so training windows and scored rollouts from any start get it
    alike without being told where they start."""

    def __init__(self):
        self.table = {}

    def add(self, frames, values):
        """frames [T, 3, S, S] and their values [T, ...]."""
        for frame, value in zip(frames, values):
            self.table[frame.numpy().tobytes()] = value

    def __call__(self, first):
        """[B, ...] the values of the given frames [B, 3, S, S]."""
        return torch.stack([self.table[f.numpy().tobytes()] for f in first])


class VariantLayerNet(LayerNet):
    """Variants measured against the recipe (docs/motion.md): a linear part restricted to a
    similarity (scale and rotation) or a scale (`linear`), and the fill as a correction of the
    given frame (`fill_residual`)."""

    def __init__(self, action_dim, layers, channels, linear="affine", fill_residual=False, **kw):
        super().__init__(action_dim, layers, channels, **kw)
        self.linear, self.fill_residual = linear, fill_residual

    def sprites(self, first):
        masks, fill = super().sprites(first)
        # the fill as a correction of the given frame: at the start the frame is copied
        # whatever the masks, so nothing pushes them to 0 or 1 before the layers move
        return masks, (first + fill if self.fill_residual else fill)

    def increments(self, hidden, action, k):
        inc = super().increments(hidden, action, k)
        if self.linear != "affine":  # [[s, -r], [r, s]]: no shear; "scale": no rotation either
            scale, turn = inc[..., 0], inc[..., 1] * (self.linear == "similarity")
            inc = torch.cat([torch.stack([scale, -turn, turn, scale], -1), inc[..., 4:]], -1)
        return inc


class MarginLayerNet(LayerNet):
    """The layers on a canvas `margin` pixels wider than the frame on every side (`--margin`):
    inside the frame a layer's colours are the given frame's, outside they are drawn by the
    U-Net (a head beside the fill's), so a layer moved inwards brings in what the given frame
    does not show (an arm entering from the edge) instead of its border pixels repeated. The
    U-Net reads the frame zero-padded to the canvas and a channel that says where it is."""

    def __init__(self, action_dim, layers, channels, margin, replicate=False, **kw):
        super().__init__(action_dim, layers, channels, **kw)
        self.margin, self.replicate = margin, replicate
        self.down1 = wp_down(4, channels)
        self.sprite_head = torch.nn.Conv2d(channels + 4, layers + 6, 3, 1, 1)
        torch.nn.init.zeros_(self.sprite_head.weight)
        torch.nn.init.constant_(self.sprite_head.bias, kw.get("mask_bias", 0.0))

    def canvas(self, first):
        """[B, 4, S + 2P, S + 2P]: the frame zero-padded, and 1 where the frame is."""
        inside = torch.ones_like(first[:, :1])
        return F.pad(torch.cat([first, inside], 1), [self.margin] * 4)

    def sprites(self, first):
        """-> masks [B, K, C, C] on the canvas, fill [B, 3, S, S] on the frame; the layers'
        colours [B, 3, C, C] on the canvas are kept for render()."""
        x = self.canvas(first)
        out = self.sprite_head(torch.cat([self.unet(x), x], 1))
        k, p, s = self.layers, self.margin, first.shape[-1]
        inside = x[:, 3:]
        logits = out[:, :k]
        if self.replicate:  # outside: the border's logits and colours plus a learned correction
            border = F.pad(logits[..., p:p + s, p:p + s], [p] * 4, mode="replicate")
            logits = border + logits * (1 - inside)
            colours = F.pad(first, [p] * 4, mode="replicate") + out[:, k + 3:k + 6] * (1 - inside)
        else:
            colours = x[:, :3] * inside + torch.tanh(out[:, k + 3:k + 6]) * (1 - inside)
        if self.training and self.mask_noise > 0:
            logits = logits + self.mask_noise * torch.randn_like(logits)
        self.colours = colours
        return torch.sigmoid(logits), torch.tanh(out[:, k:k + 3, p:p + s, p:p + s])

    def centroids(self, masks):
        return lt.centroids(masks) - self.margin  # frame pixels

    def render(self, first, masks, fill, maps):
        return lt.render(first, masks, fill, maps, first.shape[-1], self.colours, self.margin,
                         "border" if self.replicate else "zeros")


class FollowLayerNet(VariantLayerNet):
    """A layer may follow another's motion this step (`--follow`): the maps applied are
    (I + sum_j g_kj (M_j - I)) M_k, with gates g_kj = sigmoid(.) read by a head beside the
    motion head from the same features (the current frame: is the block in a closed gripper?).
    The gates start near shut (bias `follow_bias`), so the untrained model is the plain one."""

    def __init__(self, action_dim, layers, channels, follow_bias=-4.0, **kw):
        super().__init__(action_dim, layers, channels, **kw)
        self.follow_head = torch.nn.Linear(256, layers * layers)
        torch.nn.init.zeros_(self.follow_head.weight)
        torch.nn.init.constant_(self.follow_head.bias, follow_bias)

    def step_maps(self, current, first, maps, action):
        b, k = current.shape[0], self.layers
        self.hidden = self.motion_hidden(current, first, maps)
        inc = self.increments(self.hidden, action, maps.shape[1])
        others = 1 - torch.eye(k)
        self.gates = torch.sigmoid(self.follow_head(self.hidden)).view(b, k, k) * others
        if getattr(self, "gate_history", None) is not None:  # carry_score's report
            self.gate_history.append(self.gates)
        return inc

    def combine(self, steps):
        eye = torch.eye(3)
        followed = eye + torch.einsum("bkj,bjrc->bkrc", self.gates, steps - eye)
        return followed @ steps


class LabelledBlockNet(FollowLayerNet):
    """`--block-label`: the upper bound of a layer for the block (docs/motion.md, session 23),
    with `--follow`'s gates: one more layer, at the back (in front with `front`), whose mask is
    the block's true segmentation on the given frame (grown by a pixel), looked up by the given
    frame. `order` (with `front`): each step a head chooses between drawing it in front of the
    other layers and behind them (a blend of the two frames, its logit noisy in training as the
    masks' are), so that it can pass behind the gripper before a grasp and go with it after.
    `action_input`: the motion MLP also reads the step's action; `memory` N: and a GRU state of N
    units carried across the rollout's steps."""

    def __init__(self, action_dim, layers, channels, follow_bias=-4.0, front=False,
                 action_input=False, order=False, memory=0, **kw):
        super().__init__(action_dim, layers + 1, channels, follow_bias, **kw)
        self.labels, self.front, self.action_input = FrameLookup(), front or order, action_input
        extra = (action_dim if action_input else 0) + memory
        if extra:  # b and J read the step's action too (whether the gripper is closed), a memory
            self.motion_mlp[0] = torch.nn.Linear(mlp_inputs(self) + extra, 256)
        self.order_head = torch.nn.Linear(256, 1) if order else None
        if order:  # starts behind: the recipe's block is in the background
            torch.nn.init.zeros_(self.order_head.weight)
            torch.nn.init.constant_(self.order_head.bias, -2.0)
        # `memory` units carried across a rollout's steps (a GRU over the MLP's output and the
        # action): whether the block was grasped is not in the imagined frame
        self.memory = torch.nn.GRUCell(256 + action_dim, memory) if memory else None
        self.state = None

    def forward(self, first, actions, frames_in=None, fixed=None):
        if self.memory is not None:
            self.state = torch.zeros(first.shape[0], self.memory.hidden_size)
        return super().forward(first, actions, frames_in, fixed)

    def step_maps(self, current, first, maps, action):
        self.action = action  # for motion_features
        inc = super().step_maps(current, first, maps, action)
        if self.memory is not None:
            self.state = self.memory(torch.cat([self.hidden, action], 1), self.state)
        if self.order_head is not None:
            logit = self.order_head(self.hidden)
            if self.training and self.mask_noise > 0:
                logit = logit + self.mask_noise * torch.randn_like(logit)
            self.in_front = torch.sigmoid(logit)[:, :, None, None]
            if getattr(self, "order_history", None) is not None:  # carry_score's report
                self.order_history.append(float(self.in_front[0]))
        return inc

    def render(self, first, masks, fill, maps):
        front = super().render(first, masks, fill, maps)
        if self.order_head is None:
            return front
        behind = list(range(1, self.layers)) + [0]
        back = super().render(first, masks[:, behind], fill, maps[:, behind])
        return self.in_front * front + (1 - self.in_front) * back

    def motion_features(self, current, first):
        features = [super().motion_features(current, first)]
        if self.action_input:
            features.append(self.action)
        if self.memory is not None:
            features.append(self.state)
        return torch.cat(features, 1)

    def sprites(self, first):
        masks, fill = super().sprites(first)
        block = self.labels(first)
        if self.front:  # drawn over the arm's layers, whose masks hold a margin of table
            return torch.cat([block, masks[:, 1:]], 1), fill
        return torch.cat([masks[:, :-1], block], 1), fill


class KeypointLayerNet(LayerNet):
    """`--keypoints`: the motion MLP also reads where each channel of the motion CNN's 16 x 16
    features peaks, as a spatial soft-argmax (x, y) per channel (the deep spatial autoencoder's
    feature points, Finn et al. 2016): the step's motion in the image depends on where the
    gripper is and how large it looks, which a 4 x 4 map after four halvings blurs."""

    def __init__(self, action_dim, layers, channels, **kw):
        super().__init__(action_dim, layers, channels, **kw)
        self.motion_mlp = torch.nn.Sequential(
            torch.nn.Linear(mlp_inputs(self) + 2 * channels, 256), torch.nn.ReLU())

    def motion_features(self, current, first):
        half = self.motion_cnn[:4](torch.cat([current, first], 1))  # [B, C, 16, 16]
        weights = torch.softmax(half.flatten(2), -1).view_as(half)
        grid = torch.linspace(-1, 1, half.shape[-1])
        points = torch.cat([(weights.sum(2) * grid).sum(-1), (weights.sum(3) * grid).sum(-1)], 1)
        return torch.cat([self.motion_cnn[4:](half).flatten(1), points], 1)


class DepthLayerNet(LayerNet):
    """`--depth`: the motion CNN also reads the given frame's depth image (the dataset's
    steps/observation/depth, as RGB-D robots record it): how far an action moves the arm in the
    image depends on how far the gripper is from the camera, which one 64 px RGB frame leaves
    uncertain. add_depths() gives it the episodes' depths, looked up by the given frame."""

    def __init__(self, action_dim, layers, channels, **kw):
        super().__init__(action_dim, layers, channels, **kw)
        self.motion_cnn[0] = torch.nn.Conv2d(7, channels, 4, 2, 1)
        self.depths = FrameLookup()

    def add_depths(self, episodes, directory):
        """`episodes` as recipes.load read them from `directory`."""
        for (frames, _, _), depth in zip(episodes, load_depths(directory)):
            self.depths.add(frames, depth)

    def motion_features(self, current, first):
        depth = self.depths(first)
        return self.motion_cnn(torch.cat([current, first, depth], 1)).flatten(1)


def load_depths(directory):
    """[T, 1, S, S] per episode: steps/observation/depth (mm) as (d - 700) / 250."""
    import wmshard
    ds, out = wmshard.Dataset(directory), []
    for k in range(ds.num_episodes):
        _, _, blobs = ds.episode(k)
        mm = np.stack([cv2.imdecode(np.frombuffer(b, np.uint8), cv2.IMREAD_UNCHANGED)
                       for b in blobs["depth"]]).astype(np.float32)
        out.append(torch.from_numpy((mm - 700) / 250)[:, None])
    return out


class WideMlpLayerNet(LayerNet):
    """`--mlp-width W`: the motion MLP as two hidden layers of W units instead of one of 256, for
    whether the predictor underfits (docs/motion.md, session 27) for want of capacity there."""

    def __init__(self, action_dim, layers, channels, width, **kw):
        super().__init__(action_dim, layers, channels, **kw)
        self.motion_mlp = torch.nn.Sequential(
            torch.nn.Linear(mlp_inputs(self), width), torch.nn.ReLU(),
            torch.nn.Linear(width, width), torch.nn.ReLU())
        self.motion_head = torch.nn.Linear(width, layers * lt.AFFINE * (action_dim + 1))
        torch.nn.init.zeros_(self.motion_head.weight)
        torch.nn.init.zeros_(self.motion_head.bias)


TEMPLATE_LR = 10.0


class TemplateLayerNet(LayerNet):
    """`--template T`: behind the given frame's layers, one more layer that is learned once for
    all episodes (its colours and mask on a T x T canvas: the arm as it looks anywhere), placed
    on each given frame by a head that reads the frame, then moved by its own maps like the
    others. It can draw what the given frame does not show: an arm entering from the frame's
    edge, its link beyond the border. Its mask starts near 0, so the untrained model is the
    recipe's."""

    def __init__(self, action_dim, layers, channels, size=96, bias=-4.0, **kw):
        super().__init__(action_dim, layers, channels, **kw)
        self.size, k = size, layers + 1
        self.template = torch.nn.Parameter(torch.cat([torch.zeros(3, size, size),
                                                      torch.full((1, size, size), bias)]))
        self.motion_mlp = torch.nn.Sequential(
            torch.nn.Linear(mlp_inputs(self) + lt.AFFINE, 256), torch.nn.ReLU())
        self.motion_head = torch.nn.Linear(256, k * lt.AFFINE * (action_dim + 1))
        self.place_head = torch.nn.Linear(256, lt.AFFINE)
        for layer in (self.motion_head, self.place_head):
            torch.nn.init.zeros_(layer.weight)
            torch.nn.init.zeros_(layer.bias)

    def param_groups(self):
        """The template's pixels learn `TEMPLATE_LR` times faster: Adam moves a parameter by
        about the learning rate per step, and at the net's 1e-3 a mask logit cannot cross from
        hidden to shown within the run (measured: it stayed below 0.02)."""
        rest = [p for p in self.parameters() if p is not self.template]
        return [{"params": rest}, {"params": [self.template], "lr_scale": TEMPLATE_LR}]

    def placement(self, first):
        """[B, 3, 3] template pixels -> the given frame's pixels: the canvas's centre on the
        frame's, then a map read from the frame (linear part 0.5 tanh, translation 16 px)."""
        b, s, t = first.shape[0], first.shape[-1], self.size
        feats = self.motion_features(first, first)
        state = torch.zeros(b, (self.layers + 1) * lt.AFFINE)
        p = self.place_head(self.motion_mlp(torch.cat([feats, state], 1)))
        lin = torch.eye(2) + 0.5 * torch.tanh(p[:, :4]).view(b, 2, 2)
        centre = torch.full((b, 2), (t - 1) / 2)
        shift = (s - 1) / 2 + 16 * p[:, 4:] - (lin @ centre[..., None])[..., 0]
        top = torch.cat([lin, shift[..., None]], -1)
        return torch.cat([top, torch.tensor([0.0, 0.0, 1.0]).expand(b, 1, 3)], 1)

    def forward(self, first, actions, frames_in=None, fixed=None):
        b, h = actions.shape[:2]
        k = self.layers
        masks, fill = self.sprites(first)
        self.last_masks = masks
        place = self.placement(first)
        middle = torch.full((b, 1, 2), (self.size - 1) / 2)
        centre0 = torch.cat([self.centroids(masks), lt.apply(place[:, None], middle)], 1)
        maps = torch.eye(3).expand(b, k + 1, 3, 3)
        current, out, increments = first, [], []
        for t in range(h):
            inc = (self.step_maps(current.detach(), first, maps, actions[:, t]) if fixed is None
                   else fixed[:, t])
            increments.append(inc)
            maps = lt.increment(inc, lt.apply(maps, centre0)) @ maps
            frame = self.draw(first, masks, fill, maps, place)
            out.append(frame)
            current = frame if frames_in is None else frames_in[:, t]
        self.last_increments = torch.stack(increments, 1)
        return torch.stack(out, 1)

    def draw(self, first, masks, fill, maps, place):
        """The template moved by its map after its placement, over the background, under the
        frame's layers."""
        s, k = first.shape[-1], self.layers
        logit = self.template[3:]
        if self.training and self.mask_noise > 0:
            logit = logit + self.mask_noise * torch.randn_like(logit)
        mask = torch.sigmoid(logit)
        sprite = torch.cat([torch.tanh(self.template[:3]) * mask, mask])
        inv = torch.linalg.inv(maps[:, k] @ place)  # frame pixel -> template pixel
        coords = torch.arange(s, dtype=first.dtype)
        ys, xs = torch.meshgrid(coords, coords, indexing="ij")
        pix = torch.stack([xs, ys, torch.ones_like(xs)], -1).view(1, s * s, 3)
        src = (pix @ inv.transpose(-1, -2))[..., :2].view(-1, s, s, 2) / (self.size - 1) * 2 - 1
        moved = F.grid_sample(sprite.expand(first.shape[0], -1, -1, -1), src, mode="bilinear",
                              padding_mode="zeros", align_corners=True)
        visible = torch.prod(1 - masks, 1, keepdim=True)
        background = visible * first + (1 - visible) * fill
        background = moved[:, :3] + (1 - moved[:, 3:]) * background
        return lt.render(first, masks, fill, maps[:, :k], s, background=background)


class SummedActionNet(LayerNet):
    """`--summed`: each layer's map after step t is read at once from the given frame and the
    actions summed over steps 1..t, instead of being composed of increments each read off the
    imagined frame before it. In the tabletop simulator (as on end-effector-delta robots) the
    gripper's pose after t steps is its start pose plus the summed actions, so where it is in
    the image is a function of the given frame and that sum: nothing compounds, and no step
    reads an imagined frame that may already be wrong. The map keeps the recipe's form, linear
    in what the step reads (the sum and the step's action) with coefficients that depend on
    it: p_t = b + J [sum_t, a_t], read about the layer's centroid on the given frame.
    `hybrid`: the motion CNN reads the imagined frame as well, as the recipe's; `step_input`:
    the MLP reads the step's index too (t / 8, beyond training's range past its unroll)."""

    SUM_SCALE = 4.0  # normalised actions summed over a few steps, brought back near unit size

    def __init__(self, action_dim, layers, channels, hybrid=False, step_input=True,
                 linear_scale=0.5, **kw):
        super().__init__(action_dim, layers, channels, **kw)
        self.hybrid, self.step_input, self.linear_scale = hybrid, step_input, linear_scale
        reads = 2 * action_dim  # the sum and the step's action
        width = self.motion_mlp[0].out_features
        cells = mlp_inputs(self) - layers * lt.AFFINE
        self.motion_mlp[0] = torch.nn.Linear(cells + reads + 1, width)
        self.motion_head = torch.nn.Linear(width, layers * lt.AFFINE * (reads + 1))
        torch.nn.init.zeros_(self.motion_head.weight)
        torch.nn.init.zeros_(self.motion_head.bias)

    def forward(self, first, actions, frames_in=None, fixed=None):
        b, h, d = actions.shape
        k, reads = self.layers, 2 * d
        masks, fill = self.sprites(first)
        self.last_masks = masks
        centre0 = self.centroids(masks)
        given = self.motion_cnn(torch.cat([first, first], 1)).flatten(1)
        summed = torch.cumsum(actions, 1) / self.SUM_SCALE
        current, out = first, []
        for t in range(h):
            feats = (self.motion_cnn(torch.cat([current.detach(), first], 1)).flatten(1)
                     if self.hybrid else given)
            read = torch.cat([summed[:, t], actions[:, t]], 1)
            step = torch.full((b, 1), (t + 1) / 8.0 if self.step_input else 0.0)
            hidden = self.motion_mlp(torch.cat([feats, read, step], 1))
            o = self.motion_head(hidden).view(b, k, lt.AFFINE, reads + 1)
            p = o[..., 0] + (o[..., 1:] * read.view(b, 1, 1, reads)).sum(-1)
            p = torch.cat([self.linear_scale * torch.tanh(p[..., :4]),
                           p[..., 4:] * self.flow_scale], -1)
            frame = self.render(first, masks, fill, lt.increment(p, centre0))
            out.append(frame)
            current = frame if frames_in is None else frames_in[:, t]
        return torch.stack(out, 1)


class PeekLayerNet(LayerNet):
    """`--peek`, a diagnostic (as bench/warp_predictor.py's for the warp kind): the motion CNN
    reads the real frame each step leads to in place of the imagined frame it starts from, so
    the answer is in its input. If its rollouts still miss the arm by what the recipe's do,
    the motion CNN and MLP cannot read a layer's place off a frame precisely enough, whatever
    the frame holds; if they come near the fitted maps' ceiling, what the recipe lacks is
    information (rollouts scored with it mean nothing else)."""

    def __init__(self, action_dim, layers, channels, **kw):
        super().__init__(action_dim, layers, channels, **kw)
        self.futures = FrameLookup()

    def add_futures(self, episodes, horizon=8):
        for frames, _, _ in episodes:
            last = len(frames) - 1
            self.futures.add(frames, torch.stack([
                frames[[min(t + s, last) for s in range(1, horizon + 1)]]
                for t in range(len(frames))]))

    def forward(self, first, actions, frames_in=None, fixed=None):
        self.peeked, self.step = self.futures(first), 0
        return super().forward(first, actions, frames_in, fixed)

    def step_maps(self, current, first, maps, action):
        self.step += 1
        return super().step_maps(self.peeked[:, self.step - 1], first, maps, action)


class CarryChoiceNet(LayerNet):
    """`--carry-choice`: session 23's labelled block layer (its mask the block's true
    segmentation on the given frame, behind the learned layers), which never moves by itself
    but may, from some step on, be carried by one of the learned layers: its map is then that
    layer's motion since that step. Which carry (none, or layer j from step s) is a choice, not
    a blend: training renders every choice and learns from the best one per window (winner
    takes all, as multiple-choice learning), and a head learns, per step, whether a carry
    starts now and with which layer (cross-entropy to the winner). A deterministic blend of
    "carried" and "left" is what a frame L1 makes of a gate the model is unsure of: a block
    that fades or shrinks (session 28). Rollouts take the head's most likely class each step."""

    TIE = 1e-5  # a choice must beat the earlier ones by this much (none first, late carries next)

    def __init__(self, action_dim, layers, channels, learned=False, **kw):
        super().__init__(action_dim, layers + 1, channels, **kw)
        self.labels, self.targets, self.aux_loss = FrameLookup(), None, None
        self.learned = learned
        width = self.motion_mlp[0].out_features
        self.carry_head = torch.nn.Linear(width + action_dim, layers + 1)  # not yet, layer j
        torch.nn.init.zeros_(self.carry_head.weight)
        with torch.no_grad():  # starts at "not yet" (p = 0.71 against three layers)
            self.carry_head.bias.copy_(torch.tensor([2.0] + [0.0] * layers))

    def sprites(self, first):
        masks, fill = super().sprites(first)
        if self.learned:  # --carry-learned: the carried layer's mask is learned too
            return masks, fill
        return torch.cat([masks[:, :-1], self.labels(first)], 1), fill

    def step_maps(self, current, first, maps, action):
        hidden = self.motion_hidden(current, first, maps)
        # the head learns from the motion's features, not into them
        self.carry_logits = self.carry_head(torch.cat([hidden.detach(), action], 1))
        inc = self.increments(hidden, action, self.layers)
        return torch.cat([inc[:, :-1], torch.zeros_like(inc[:, -1:])], 1)  # the block: still

    def options(self, h):
        """[(layer, start step)] the carries a window may take; (None, h): none."""
        return [(None, h)] + [(j, s) for s in reversed(range(h)) for j in range(self.layers - 1)]

    @staticmethod
    def carried(history, j, s):
        """[B, H, 3, 3] the block's maps when layer j carries it from step s."""
        maps = torch.stack(history, 1)
        if j is None:
            return torch.eye(3).expand(maps.shape[0], maps.shape[1], 3, 3)
        before = torch.eye(3).expand(maps.shape[0], 3, 3) if s == 0 else maps[:, s - 1, j]
        moved = maps[:, :, j] @ torch.linalg.inv(before)[:, None]
        steps = torch.arange(maps.shape[1])[None, :, None, None]
        return torch.where(steps >= s, moved, torch.eye(3))

    def draw(self, first, masks, fill, history, block_maps):
        """[B, H, 3, S, S] the frames with the block at `block_maps` [B, H, 3, 3]."""
        return torch.stack([self.render(first, masks, fill, torch.cat(
            [m[:, :-1], block_maps[:, t, None]], 1)) for t, m in enumerate(history)], 1)

    def forward(self, first, actions, frames_in=None, fixed=None):
        b, h = actions.shape[:2]
        masks, fill = self.sprites(first)
        self.last_masks = masks if self.learned else masks[:, :-1]
        centre0 = self.centroids(masks)
        maps = torch.eye(3).expand(b, self.layers, 3, 3)
        current, history, logits = first, [], []
        started = torch.full((b,), -1)  # rollouts: the layer carrying the block, from when
        since = torch.zeros(b, dtype=torch.long)
        for t in range(h):
            inc = self.step_maps(current.detach(), first, maps, actions[:, t])
            maps = lt.increment(inc, lt.apply(maps, centre0)) @ maps
            history.append(maps)
            logits.append(self.carry_logits)
            if not self.training:
                choice = self.carry_logits.argmax(1) - 1
                begin = (started < 0) & (choice >= 0)
                since = torch.where(begin, torch.full_like(since, t), since)
                started = torch.where(begin, choice, started)
            block = self.rollout_carry(history, started, since) if not self.training else \
                torch.eye(3).expand(b, 1, 3, 3)
            current = self.render(first, masks, fill, torch.cat([maps[:, :-1], block[:, -1:]], 1))
        if not self.training:
            return self.draw(first, masks, fill, history, self.rollout_carry(history, started,
                                                                             since, all_steps=True))
        return self.train_choice(first, masks, fill, history, torch.stack(logits, 1))

    def rollout_carry(self, history, started, since, all_steps=False):
        """[B, T, 3, 3] (the last step's, or every step's) block maps of a rollout's carries."""
        per_option = {}
        out = []
        for i in range(len(started)):
            j = int(started[i])
            key = (None, len(history)) if j < 0 else (j, int(since[i]))
            if key not in per_option:
                per_option[key] = self.carried(history, *key)
            out.append(per_option[key][i])
        maps = torch.stack(out)
        return maps if all_steps else maps[:, -1:]

    def train_choice(self, first, masks, fill, history, logits):
        """The winning carry's frames per window; its cross-entropy into self.aux_loss."""
        h, real = len(history), self.targets
        options = self.options(h)
        with torch.no_grad():
            losses = torch.stack([(self.draw(first, masks, fill, history,
                                             self.carried(history, j, s)) - real).abs()
                                  .mean((1, 2, 3, 4)) for j, s in options], 1)
        best = losses.min(1, keepdim=True).values
        winner = ((losses <= best + self.TIE).float().cumsum(1) == 0).sum(1)  # first within TIE
        block = torch.stack([self.carried(history, *options[int(w)])[i]
                             for i, w in enumerate(winner)])
        frames = self.draw(first, masks, fill, history, block)
        target = torch.zeros(len(winner), h, dtype=torch.long)
        weight = torch.ones(len(winner), h)
        for i, w in enumerate(winner.tolist()):
            j, s = options[w]
            if j is not None:
                target[i, s] = j + 1
                weight[i, s + 1:] = 0  # once carried, no more to choose
        ce = F.cross_entropy(logits.flatten(0, 1), target.flatten(), reduction="none")
        self.aux_loss = (ce * weight.flatten()).sum() / weight.sum()
        self.carries = getattr(self, "carries", 0) + int((winner > 0).sum())
        self.windows = getattr(self, "windows", 0) + len(winner)
        return frames


class PeekKeypointNet(PeekLayerNet, KeypointLayerNet):
    """`--peek --keypoints`: whether the motion MLP reading feature points places the layers
    when the answer is in its input."""


def add_arguments(ap):
    """The options that pick a variant (build()); without them the net is the recipe's."""
    ap.add_argument("--linear", choices=("affine", "similarity", "scale"), default="affine",
                    help="what a step may do to a layer besides moving it")
    ap.add_argument("--fill-residual", action="store_true",
                    help="the fill is the given frame plus a learned correction")
    ap.add_argument("--follow", action="store_true",
                    help="a layer may follow another's motion, gated per step by the state")
    ap.add_argument("--follow-bias", type=float, default=-4.0, help="the gates' initial logit")
    ap.add_argument("--margin", type=int, default=0, metavar="P",
                    help="the layers on a canvas P pixels wider on each side, drawn outside")
    ap.add_argument("--margin-replicate", action="store_true",
                    help="--margin's canvas starts as the frame's border repeated (the recipe)")
    ap.add_argument("--mlp-width", type=int, default=0, metavar="W",
                    help="the motion MLP as two hidden layers of W units")
    ap.add_argument("--depth", action="store_true",
                    help="the motion CNN also reads the given frame's depth image")
    ap.add_argument("--keypoints", action="store_true",
                    help="the motion MLP also reads the motion CNN's features' soft-argmax points")
    ap.add_argument("--template", type=int, default=0, metavar="T",
                    help="behind the frame's layers a layer learned for all episodes on a T x T "
                         "canvas, placed on each given frame by a head")
    ap.add_argument("--template-bias", type=float, default=-4.0,
                    help="the template's initial mask logit")
    ap.add_argument("--block-label", action="store_true",
                    help="one more layer whose mask is the block's true segmentation, with "
                         "--follow's gates (an upper bound, as session 23's)")
    ap.add_argument("--block-front", action="store_true",
                    help="--block-label's layer in front of the others instead of behind")
    ap.add_argument("--block-order", action="store_true",
                    help="with --block-label: each step, the block's layer drawn in front of "
                         "the others or behind them, as a head chooses")
    ap.add_argument("--memory", type=int, default=0, metavar="N",
                    help="with --block-label: N GRU units carried across a rollout's steps, "
                         "read by the motion MLP")
    ap.add_argument("--summed", action="store_true",
                    help="each layer's map read at once from the given frame and the actions "
                         "summed so far, not composed of per-step increments")
    ap.add_argument("--hybrid", action="store_true",
                    help="with --summed: the motion CNN reads the imagined frame too")
    ap.add_argument("--no-step-input", action="store_true",
                    help="with --summed: the MLP does not read the step's index")
    ap.add_argument("--peek", action="store_true",
                    help="a diagnostic: the motion CNN reads the real frame each step leads to")
    ap.add_argument("--carry-choice", action="store_true",
                    help="the labelled block layer carried by a learned layer from a step on, "
                         "chosen (winner takes all), not blended")
    ap.add_argument("--carry-learned", action="store_true",
                    help="with --carry-choice: the carried layer's mask learned, not the label")
    ap.add_argument("--action-input", action="store_true",
                    help="with --block-label: the motion MLP reads the step's action too")


def build(args, action_dim, train, val):
    """The net add_arguments' options pick; `train`, `val`: the episodes (recipes.load) whose
    per-frame data a variant reads (--depth, --block-label)."""
    mask = dict(mask_bias=args.mask_bias, mask_noise=args.mask_noise)
    d, k, c = action_dim, args.layers, args.channels
    if args.block_label:
        net = LabelledBlockNet(d, k, c, args.follow_bias, args.block_front, args.action_input,
                               args.block_order, args.memory, **mask)
        for episodes in (train, val):
            add_block_labels(net.labels, episodes)
    elif args.carry_choice:
        net = CarryChoiceNet(d, k, c, args.carry_learned, **mask)
        for episodes in (train, val):
            add_block_labels(net.labels, episodes)
    elif args.peek:
        net = (PeekKeypointNet if args.keypoints else PeekLayerNet)(d, k, c, **mask)
        for episodes in (train, val):
            net.add_futures(episodes)
    elif args.summed:
        net = SummedActionNet(d, k, c, args.hybrid, not args.no_step_input, **mask)
    elif args.follow:
        net = FollowLayerNet(d, k, c, args.follow_bias, linear=args.linear,
                             fill_residual=args.fill_residual, **mask)
    elif args.mlp_width:
        net = WideMlpLayerNet(d, k, c, args.mlp_width, **mask)
    elif args.depth:
        net = DepthLayerNet(d, k, c, **mask)
        net.add_depths(train, args.train)
        net.add_depths(val, args.val)
    elif args.keypoints:
        net = KeypointLayerNet(d, k, c, **mask)
    elif args.template:
        net = TemplateLayerNet(d, k, c, args.template, args.template_bias, **mask)
    elif args.margin:
        net = MarginLayerNet(d, k, c, args.margin, args.margin_replicate, **mask)
    elif args.linear != "affine" or args.fill_residual:
        net = VariantLayerNet(d, k, c, args.linear, args.fill_residual, **mask)
    else:
        net = LayerNet(d, k, c, **mask)
    return net
