#!/usr/bin/python3
"""PyTorch twin of wmkit's VQ-VAE tokenizer (tokenize/vqvae.{h,cc}, tokenizer.cc, trainer.cc).

Written from the C++ sources and docs/tokenizer.md, for the reference check
(tests/tokenize/test_vqvae_twin.py) and the speed comparison (bench/tokenizer_bench.py):

  read_archive(path)     WMTENSR1 reader from the documented layout (docs/metrics-lpips.md
                         "Weights file"): magic, header, alignment, length, CRC32C of each tensor
  load_checkpoint(path)  VqVae built from the archive's meta "config", loaded from
                         "model/<path>"; module paths equal the C++ ones (encoder.0.weight,
                         quantizer.codebook, quantizer.steps_since_used), all names must match
  encode, decode, reconstruct, encoder_features
                         Tokenizer's API (chunks of 64 frames, no grad)
  Trainer                one step of wm-tokenize train: the same init order, frame sampler
                         (SplitMix64), code seeding and dead-code draws (mt19937_64), lr
                         schedule, grad clipping and torch.optim.AdamW
"""
import json
import math
import os
import struct
import sys

import crc32c
import cv2
import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

SOURCE = os.environ.get("WM_SOURCE_DIR", os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                                      "..", ".."))
DTYPES = {"float32": "<f4", "float64": "<f8", "float16": "<f2", "int32": "<i4", "int64": "<i8",
          "uint8": "u1"}
# ModelConfig's defaults (tokenize/config.h): ConfigFromJson keeps them for absent keys.
MODEL_DEFAULTS = {"image_size": 64, "patch_size": 8, "stem_factor": 1, "encoder": "conv",
                  "encoder_channels": 64, "encoder_layers": 1,
                  "decoder_channels": 64, "decoder_layers": 1, "min_channels": 0, "latent_dim": 32,
                  "num_codes": 1024, "l2_normalize": True, "beta": 0.25, "dead_code_steps": 100,
                  "detail_weight": 0.0, "anchor_decoder": False, "anchor_flow": False,
                  "change_weight": 0.0, "levels": 1}
CHUNK = 64  # tokenizer.cc kChunk: frames per forward pass
M64 = (1 << 64) - 1


def read_archive(path):
    """{name: ndarray} and the header of a wmkit tensor archive; AssertionError on any defect."""
    with open(path, "rb") as f:
        blob = f.read()
    assert blob[:8] == b"WMTENSR1", f"{path}: bad magic {blob[:8]!r}"
    (n,) = struct.unpack_from("<Q", blob, 8)
    header = json.loads(blob[16:16 + n].decode("utf-8"))
    assert header["format"] == "wmkit-tensors" and header["version"] == 1, f"{path}: format"
    start = 16 + n
    assert start % 64 == 0 and header["data_length"] % 64 == 0, f"{path}: alignment"
    assert len(blob) == start + header["data_length"], f"{path}: truncated or appended bytes"
    out = {}
    for name, e in header["tensors"].items():
        dtype = np.dtype(DTYPES[e["dtype"]])
        assert e["offset"] % 64 == 0, f"{path}: {name}: offset {e['offset']}"
        assert e["length"] == int(np.prod(e["shape"], dtype=np.int64)) * dtype.itemsize, name
        assert e["offset"] + e["length"] <= header["data_length"], f"{path}: {name}: bounds"
        raw = blob[start + e["offset"]:start + e["offset"] + e["length"]]
        assert crc32c.crc32c(raw) == e["crc32c"], f"{path}: {name}: CRC32C mismatch"
        out[name] = np.frombuffer(raw, dtype).reshape(e["shape"]).copy()
    return out, header


def model_config(config_json):
    """The "model" section of a stored TokenizerConfig, defaults filled in."""
    return {**MODEL_DEFAULTS, **config_json.get("model", {})}


class ResBlock(nn.Module):
    """x + conv1x1(relu(conv3x3(relu(x)))), as vqvae.cc ResBlockImpl."""

    def __init__(self, channels):
        super().__init__()
        self.conv1 = nn.Conv2d(channels, channels, 3, padding=1)
        self.conv2 = nn.Conv2d(channels, channels, 1)

    def forward(self, x):
        return x + self.conv2(torch.relu(self.conv1(torch.relu(x))))


def distances(flat, codes):
    """VectorQuantizerImpl::Distances: ||z||^2 - 2 z.e + ||e||^2, [..., K], the same expression
    (and kernels) as the C++."""
    return flat.pow(2).sum(-1, True) - 2 * flat.matmul(codes.t()) + codes.pow(2).sum(1)


class VectorQuantizer(nn.Module):
    """VectorQuantizerImpl, with its residual levels (model.levels) as submodules "level1", ...:
    Euclidean codebooks, level k quantising the unit latents minus the codes levels 0..k-1
    chose; the decoder reads the codes summed (straight-through on the sum)."""

    def __init__(self, num_codes, dim, l2_normalize, levels=1):
        super().__init__()
        self.num_codes, self.dim, self.l2_normalize = num_codes, dim, l2_normalize
        init = (torch.randn(num_codes, dim) if l2_normalize else
                torch.empty(num_codes, dim).uniform_(-1.0 / num_codes, 1.0 / num_codes))
        self.codebook = nn.Parameter(init)  # [K, D]
        self.register_buffer("steps_since_used", torch.zeros(num_codes, dtype=torch.int64))
        self.levels = [self]
        for k in range(1, levels):  # created after level 0's codebook, as in C++
            self.add_module(f"level{k}", VectorQuantizer(num_codes, dim, False))
            self.levels.append(getattr(self, f"level{k}"))

    def codes(self):
        return F.normalize(self.codebook, dim=1) if self.l2_normalize else self.codebook

    def unit(self, z_e):  # [B, D, h, w] -> [N, D] as the lookup compares them
        flat = z_e.permute(0, 2, 3, 1).reshape(-1, self.dim)
        return F.normalize(flat, dim=1) if self.l2_normalize else flat

    def choose(self, flat, before=None):
        """Choose: per level (input [N, D] detached, indices [N], codes [N, D] with grad), and
        the chosen codes summed over the levels (no gradient)."""
        out, total = [], None
        for k, level in enumerate(self.levels):
            inp = flat.detach() if k == 0 else flat.detach() - total
            if before is not None:
                before(level, inp)
            codes = level.codes()
            idx = distances(inp, codes).argmin(1)
            q = codes.index_select(0, idx)
            total = q.detach() if total is None else total + q.detach()
            out.append((inp, idx, q))
        return out, total

    @staticmethod
    def stack_indices(indices, B, h, w):  # [N] per level -> [B, h, w] or [B, L, h, w]
        if len(indices) == 1:
            return indices[0].view(B, h, w)
        return torch.stack(indices, 1).view(B, h, w, len(indices)).permute(0, 3, 1, 2) \
            .contiguous()

    def forward(self, z_e):
        B, D, h, w = z_e.shape
        flat = self.unit(z_e)  # [N, D]
        choices, total = self.choose(flat)
        codebook_loss = None
        for inp, _, q in choices:
            loss = F.mse_loss(q, inp)  # VQ-VAE eq. 3, second term, per level
            codebook_loss = loss if codebook_loss is None else codebook_loss + loss
        st = flat + (total - flat).detach()  # straight-through: forward = codes, grad -> z_e
        idx = choices[0][1]
        counts = torch.bincount(idx, minlength=self.num_codes).double()
        p = counts / idx.shape[0]
        return {"z_q": st.view(B, h, w, D).permute(0, 3, 1, 2).contiguous(),  # [B, D, h, w]
                "indices": self.stack_indices([c[1] for c in choices], B, h, w),
                "codebook_loss": codebook_loss,
                "commitment": F.mse_loss(flat, total),  # third term (x beta)
                "level_inputs": [c[0] for c in choices],
                "level_indices": [c[1] for c in choices],
                "perplexity": torch.exp(-(p * torch.log(p + 1e-10)).sum()).item(),
                "usage": (counts > 0).sum().item() / self.num_codes}

    def lookup(self, indices):  # [B, h, w] or [B, L, h, w] -> [B, D, h, w]
        per_level = [indices] if indices.dim() == 3 else indices.unbind(1)
        total = None
        for level, idx in zip(self.levels, per_level):
            q = level.codes().index_select(0, idx.flatten())
            total = q if total is None else total + q
        B, h, w = per_level[0].shape
        return total.view(B, h, w, self.dim).permute(0, 3, 1, 2).contiguous()

    @torch.no_grad()
    def seed_from_latents(self, z_e, rng):
        def seed(level, inp):
            src = torch.tensor([rng() % inp.shape[0] for _ in range(level.num_codes)])
            level.codebook.copy_(inp.index_select(0, src))
        self.choose(self.unit(z_e), seed)

    @torch.no_grad()
    def reseed_dead(self, indices, inputs, dead_after, rng):
        used = torch.bincount(indices, minlength=self.num_codes) > 0
        self.steps_since_used.add_(1).masked_fill_(used, 0)
        if dead_after <= 0:
            return 0
        dead = (self.steps_since_used >= dead_after).nonzero().flatten()
        if dead.numel() == 0:
            return 0
        src = torch.tensor([rng() % inputs.shape[0] for _ in range(dead.numel())])
        self.codebook.index_copy_(0, dead, inputs.index_select(0, src))
        self.steps_since_used.index_fill_(0, dead, 0)
        return dead.numel()

    @torch.no_grad()
    def update_usage_and_reseed(self, out, dead_after, rng):
        return sum(level.reseed_dead(idx, inp, dead_after, rng) for level, idx, inp in
                   zip(self.levels, out["level_indices"], out["level_inputs"]))


@torch.no_grad()
def detail_weight(images, alpha):
    """DetailWeight: 1 + alpha * min(1, d / 0.25), d = max over channels of |image - its 7x7 box
    blur| (padding not counted), [B, 1, H, W]."""
    blur = F.avg_pool2d(images, 7, stride=1, padding=3, count_include_pad=False)
    return 1 + alpha * ((images - blur).abs().amax(1, keepdim=True) / 0.25).clamp(max=1)


def changed_pixels(images, anchors):
    """ChangedPixels: 1 where a channel moved by over 30 levels since a real (not blank) anchor."""
    changed = (images - anchors).abs().amax(1, keepdim=True) > 30.0 / 127.5
    real = anchors.abs().amax((1, 2, 3), keepdim=True) > 0
    return (changed & real).to(images.dtype)


def move_by_flow(images, flow):
    """MoveByFlow: `images` resampled at each pixel's position plus the flow (pixels)."""
    size = images.shape[-1]
    offset = F.interpolate(flow, size=(size, size), mode="bilinear",
                           align_corners=False).permute(0, 2, 3, 1) * (2.0 / size)
    identity = F.affine_grid(torch.eye(2, 3).expand(len(images), 2, 3),
                             [len(images), 3, size, size], align_corners=False)
    return F.grid_sample(images, identity + offset, mode="bilinear", padding_mode="border",
                         align_corners=False)


class VqVae(nn.Module):
    """VqVaeImpl: modules are created in the C++ order, so torch.manual_seed gives the same
    initial weights, and registered in its order (encoder, decoder, quantizer)."""

    def __init__(self, c):
        super().__init__()
        self.beta, self.detail_weight = c["beta"], c["detail_weight"]
        f = c["stem_factor"]  # pixel unshuffle before the first conv, pixel shuffle after the last
        downs = int(math.log2(c["patch_size"] // f))
        mc = c["min_channels"]

        def width(channels, level):  # halved per level above the token grid, floor min_channels
            return max(mc, channels >> level) if mc > 0 else channels

        ce, cd, d = c["encoder_channels"], c["decoder_channels"], c["latent_dim"]
        if c["encoder"] == "cell_local":  # 1x1 convs on each unshuffled patch
            p = c["patch_size"]
            enc = [nn.PixelUnshuffle(p), nn.Conv2d(3 * p * p, ce, 1)]
            for _ in range(2):
                enc += [nn.ReLU(), nn.Conv2d(ce, ce, 1)]
        else:
            enc = [nn.PixelUnshuffle(f)] if f > 1 else []  # [B, 3f^2, H/f, W/f]
            enc += [nn.Conv2d(3 * f * f, width(ce, downs), 3, padding=1), nn.ReLU()]
            for level in range(downs, 0, -1):  # each halves H and W
                enc += [nn.Conv2d(width(ce, level), width(ce, level - 1), 4, stride=2,
                                  padding=1), nn.ReLU()]
            enc += [ResBlock(ce) for _ in range(c["encoder_layers"])]
        enc += [nn.ReLU(), nn.Conv2d(ce, d, 1)]  # [B, D, h, w]
        encoder = nn.Sequential(*enc)
        dec = [nn.Conv2d(d, cd, 3, padding=1)]
        dec += [ResBlock(cd) for _ in range(c["decoder_layers"])]
        for level in range(downs):  # each doubles H and W
            dec += [nn.ReLU(), nn.ConvTranspose2d(width(cd, level), width(cd, level + 1), 4,
                                                  stride=2, padding=1)]
        top, pixels = width(cd, downs), 3 * f * f
        self.f, self.anchored = f, c["anchor_decoder"]
        if not self.anchored:
            dec += [nn.ReLU(), nn.Conv2d(top, pixels, 3, padding=1)]
            dec += [nn.PixelShuffle(f)] if f > 1 else []  # [B, 3, H, W]
        decoder = nn.Sequential(*dec)
        self.encoder, self.decoder = encoder, decoder
        if self.anchored:  # created in the C++ order: anchor_stem, merge, head
            self.anchor_stem = nn.Sequential(*([nn.PixelUnshuffle(f)] if f > 1 else []),
                                             nn.Conv2d(pixels, top, 3, padding=1))
            self.merge = nn.Sequential(nn.ReLU(), nn.Conv2d(2 * top, top, 3, padding=1),
                                       ResBlock(top))
            self.head = nn.Sequential(nn.ReLU(), nn.Conv2d(top, pixels, 3, padding=1))
            with torch.no_grad():  # the correction starts at zero: decoded = anchor
                self.head[1].weight.zero_()
                self.head[1].bias.zero_()
        self.quantizer = VectorQuantizer(c["num_codes"], d, c["l2_normalize"], c["levels"])
        self.change_weight, self.anchor_flow = c["change_weight"], None
        if c["anchor_flow"]:  # created last, as in C++; zero flow at the start
            self.anchor_flow = nn.Conv2d(top, 2, 3, padding=1)
            with torch.no_grad():
                self.anchor_flow.weight.zero_()
                self.anchor_flow.bias.zero_()

    def decode(self, z_q, anchors=None):
        """VqVaeImpl::Decode; anchors None = blank (zeros)."""
        if not self.anchored:
            return self.decoder(z_q)
        h = self.decoder(z_q)
        if anchors is None:
            anchors = torch.zeros(z_q.shape[0], 3, h.shape[2] * self.f, h.shape[3] * self.f)
        h = self.merge(torch.cat([h, self.anchor_stem(anchors)], 1))
        if self.anchor_flow is not None:
            anchors = move_by_flow(anchors, self.anchor_flow(h))
        base = F.pixel_unshuffle(anchors, self.f) if self.f > 1 else anchors
        y = self.head(h) + base
        return F.pixel_shuffle(y, self.f) if self.f > 1 else y

    def latents(self, images, anchors=None):
        """The encoder's output [B, D, h, w]; the C++ encoder reads the frame alone (benches
        override this to let it see the anchor too)."""
        return self.encoder(images)

    def forward(self, images, anchors=None):  # [B, 3, H, W] in [-1, 1]
        quant = self.quantizer(self.latents(images, anchors))
        recon = self.decode(quant["z_q"], anchors)
        error = (recon - images).abs()
        recon_l1 = error.mean()
        term = recon_l1
        changes = self.change_weight > 0 and anchors is not None
        if self.detail_weight > 0 or changes:  # normalised by the mean weight: L1's scale
            w = detail_weight(images, self.detail_weight)
            if changes:
                w = w + self.change_weight * changed_pixels(images, anchors)
            term = (w * error).mean() / w.mean()
        loss = term + quant["codebook_loss"] + self.beta * quant["commitment"]
        return {"reconstruction": recon, "quant": quant, "recon_l1": recon_l1, "loss": loss}


def load_checkpoint(path):
    """(VqVae in eval mode, full config JSON, archive header) from a run dir or .wmt file."""
    if os.path.isdir(path):
        path = os.path.join(path, "checkpoint.wmt")
    tensors, header = read_archive(path)
    config = header["meta"]["config"]
    model = VqVae(model_config(config))
    state = {k[len("model/"):]: torch.from_numpy(v) for k, v in tensors.items()
             if k.startswith("model/")}
    own = model.state_dict()
    assert sorted(state) == sorted(own), \
        f"{path}: names differ: archive only {sorted(set(state) - set(own))}, " \
        f"twin only {sorted(set(own) - set(state))}"
    for k, v in state.items():
        assert v.dtype == own[k].dtype and v.shape == own[k].shape, \
            f"{path}: {k}: archive {v.dtype}{list(v.shape)}, " \
            f"twin {own[k].dtype}{list(own[k].shape)}"
    model.load_state_dict(state)
    return model.eval(), config, header


@torch.no_grad()
def encode(model, frames, anchors=None):  # [n, 3, S, S] -> [n, g, g] int64
    return torch.cat([model.quantizer(model.latents(
        frames[i:i + CHUNK], None if anchors is None else anchors[i:i + CHUNK]))["indices"]
        for i in range(0, len(frames), CHUNK)])


@torch.no_grad()
def decode(model, codes, anchors=None):  # [n, g, g] -> [n, 3, S, S], clamped like Decode
    return torch.cat([model.decode(model.quantizer.lookup(codes[i:i + CHUNK]),
                                   None if anchors is None else anchors[i:i + CHUNK]).clamp(-1, 1)
                      for i in range(0, len(codes), CHUNK)])


@torch.no_grad()
def encode_episode(model, frames, margin):
    """Tokenizer::EncodeEpisode: consecutive frames' codes with hysteresis `margin`
    (VectorQuantizer::StickyIndices: keep the previous frame's code while its distance is within
    `margin` of the nearest code's)."""
    if margin <= 0:
        return encode(model, frames)
    assert len(model.quantizer.levels) == 1, "code hysteresis needs one quantiser level"
    z = torch.cat([model.encoder(frames[i:i + CHUNK]) for i in range(0, len(frames), CHUNK)])
    T, D, h, w = z.shape
    flat = z.permute(0, 2, 3, 1).reshape(T, h * w, D)
    if model.quantizer.l2_normalize:
        flat = F.normalize(flat, dim=2)
    dist = distances(flat, model.quantizer.codes())
    best, kept = dist.argmin(2), []
    for t in range(T):
        if t == 0:
            kept.append(best[0])
            continue
        d_prev = dist[t].gather(1, kept[-1].unsqueeze(1)).squeeze(1)
        d_best = dist[t].gather(1, best[t].unsqueeze(1)).squeeze(1)
        kept.append(torch.where(d_prev <= d_best + margin, kept[-1], best[t]))
    return torch.stack(kept).view(T, h, w)


def reconstruct(model, frames, anchors=None):
    return decode(model, encode(model, frames), anchors)


def previous_frames(frames):
    """tokenizer_ref_tool's anchors for an anchored tokenizer: frame i-1 for frame i, blank for
    frame 0."""
    return torch.cat([torch.zeros_like(frames[:1]), frames[:-1]])


@torch.no_grad()
def encoder_features(model, frames):
    """Activations after each encoder ReLU, then the latent (Tokenizer::EncoderFeatures)."""
    out, x = [], frames
    for layer in model.encoder:
        x = layer(x)
        if isinstance(layer, nn.ReLU):
            out.append(x)
    return out + [x]


class Mt19937_64:
    """std::mt19937_64 (seed, operator()): the C++ code-seeding and dead-code draws."""

    def __init__(self, seed):
        self.mt = [seed & M64]
        for i in range(1, 312):
            prev = self.mt[-1]
            self.mt.append((6364136223846793005 * (prev ^ (prev >> 62)) + i) & M64)
        self.i = 312

    def __call__(self):
        if self.i >= 312:
            mt = self.mt
            for k in range(312):
                y = (mt[k] & 0xFFFFFFFF80000000) | (mt[(k + 1) % 312] & 0x7FFFFFFF)
                mt[k] = mt[(k + 156) % 312] ^ (y >> 1) ^ (0xB5026F5AA96619E9 if y & 1 else 0)
            self.i = 0
        y = self.mt[self.i]
        self.i += 1
        y ^= (y >> 29) & 0x5555555555555555
        y ^= (y << 17) & 0x71D67FFFEDA60000
        y ^= (y << 37) & 0xFFF7EEE000000000
        return y ^ (y >> 43)


def mix64(x):
    """SplitMix64's finaliser (core/mix_bits.h MixBits)."""
    x = (x + 0x9E3779B97F4A7C15) & M64
    x = ((x ^ (x >> 30)) * 0xBF58476D1CE4E5B9) & M64
    x = ((x ^ (x >> 27)) * 0x94D049BB133111EB) & M64
    return x ^ (x >> 31)


def flicker_counts(codes, frames, patch, levels=30):
    """validation.cc CountFlicker, in numpy: codes [T, g, g] of one episode (or [T, L, g, g]:
    a cell changes when any level's code does, as CellCodes), frames [T, S, S, 3] uint8 levels
    (any numeric dtype) -> (token changes in cells where no pixel changed by more than `levels`
    in any channel, all token changes, cells compared)."""
    changed = codes[1:] != codes[:-1]  # [T-1, g, g]
    if changed.ndim == 4:
        changed = changed.any(1)
    diff = np.abs(frames[1:].astype(np.int32) - frames[:-1].astype(np.int32)).max(3)
    t, g = diff.shape[0], diff.shape[1] // patch
    moved = diff.reshape(t, g, patch, g, patch).max((2, 4)) > levels
    return int((changed & ~moved).sum()), int(changed.sum()), int(changed.size)


def decode_frame(encoded, size):
    """tokenize::DecodeFrame: imdecode, BGR->RGB, INTER_AREA resize, [3, S, S] in [-1, 1]."""
    bgr = cv2.imdecode(np.frombuffer(encoded, np.uint8), cv2.IMREAD_COLOR)
    rgb = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)
    if rgb.shape[:2] != (size, size):
        rgb = cv2.resize(rgb, (size, size), interpolation=cv2.INTER_AREA)
    # C order: a channels-last array would send the convolutions down another oneDNN path, whose
    # sums round differently from the C++ run's.
    planar = np.ascontiguousarray(rgb.transpose(2, 0, 1)).astype(np.float32)
    return planar / np.float32(127.5) - np.float32(1)


class FrameSampler:
    """tokenize::FrameSampler without a mixture file: dataset by step count, episode, step; each
    draw a SplitMix64 hash of (seed, step, slot). Decoded episodes are cached (`frames`)."""

    def __init__(self, dirs, image_key, size, seed):
        sys.path.insert(0, os.path.join(SOURCE, "scripts"))
        import wmshard
        self.datasets = [wmshard.Dataset(d) for d in dirs]
        self.image_key, self.size, self.seed, self.cache = image_key, size, seed, {}
        counts = [float(d.index["num_steps"]) for d in self.datasets]
        self.prefix = list(np.cumsum(counts) / sum(counts))
        self.prefix[-1] = 1.0
        self.steps = []  # per dataset: num_steps of each episode, from the shard footers
        for d in self.datasets:
            self.steps.append([e[2] for j in range(len(d.index["shards"]))
                               for e in d.shard(j).entries])

    def batch_refs(self, step, batch_size):
        refs = []
        for b in range(batch_size):
            key = mix64(self.seed ^ mix64((step * 0x10000 + b) & M64))
            u = (mix64((key + 1) & M64) >> 11) * 2.0 ** -53
            ds = 0
            while ds + 1 < len(self.prefix) and u >= self.prefix[ds]:
                ds += 1
            episode = mix64((key + 2) & M64) % len(self.steps[ds])
            refs.append((ds, episode, mix64((key + 3) & M64) % self.steps[ds][episode]))
        return refs

    def training_anchors(self, refs, step, max_gap, dropout):
        """FrameSampler::TrainingAnchors: [(ref, blank)], draws MixBits(key + 4), MixBits(key + 5)."""
        out = []
        for b, (ds, episode, t) in enumerate(refs):
            key = mix64(self.seed ^ mix64((step * 0x10000 + b) & M64))
            u = (mix64((key + 4) & M64) >> 11) * 2.0 ** -53
            span = min(t, max_gap)
            blank = span == 0 or u < dropout
            if not blank:
                t -= 1 + mix64((key + 5) & M64) % span
            out.append(((ds, episode, t), blank))
        return out

    def load_anchors(self, anchors):  # [B, 3, S, S], blank = zeros
        x = self.load([r for r, _ in anchors]).clone()
        for b, (_, blank) in enumerate(anchors):
            if blank:
                x[b] = 0
        return x

    def frames(self, ds, episode):  # [T, 3, S, S] float32
        if (ds, episode) not in self.cache:
            blobs = self.datasets[ds].episode(episode)[2][self.image_key]
            self.cache[ds, episode] = np.stack([decode_frame(b, self.size) for b in blobs])
        return self.cache[ds, episode]

    def load(self, refs):  # [B, 3, S, S]
        return torch.from_numpy(np.stack([self.frames(d, e)[s] for d, e, s in refs])).contiguous()


def learning_rate_at(t, step):
    """trainer.cc LearningRateAt: linear warmup, then cosine to min_lr at train.steps."""
    if step < t["warmup_steps"]:
        return t["max_lr"] * (step + 1) / t["warmup_steps"]
    span = max(1, t["steps"] - t["warmup_steps"])
    progress = min(1.0, (step - t["warmup_steps"]) / span)
    return t["min_lr"] + 0.5 * (t["max_lr"] - t["min_lr"]) * (1.0 + math.cos(math.pi * progress))


class Trainer:
    """wm-tokenize train's step loop (trainer.cc TrainTokenizer) on CPU, with torch.optim.AdamW.
    `config` is the full TokenizerConfig JSON; "train" needs every key (checkpoints store all)."""

    def __init__(self, config):
        self.cfg, self.t = model_config(config), config["train"]
        torch.set_num_threads(self.t["threads"])
        torch.use_deterministic_algorithms(True)
        torch.manual_seed(self.t["seed"])
        self.model = VqVae(self.cfg)
        self.optimizer = torch.optim.AdamW(self.model.parameters(), lr=self.t["max_lr"],
                                           betas=(self.t["beta1"], self.t["beta2"]), eps=1e-8,
                                           weight_decay=self.t["weight_decay"])
        self.reseed_rng = Mt19937_64(self.t["seed"] ^ 0x9E3779B97F4A7C15)
        self.step = 0

    def train_step(self, images, anchors=None):  # [B, 3, S, S]; the forward's output dict
        for group in self.optimizer.param_groups:
            group["lr"] = learning_rate_at(self.t, self.step)
        self.optimizer.zero_grad(set_to_none=False)
        if self.step == 0:
            self.model.quantizer.seed_from_latents(self.model.encoder(images), self.reseed_rng)
        out = self.model(images, anchors)
        out["loss"].backward()
        if self.t["grad_clip"] > 0:
            nn.utils.clip_grad_norm_(self.model.parameters(), self.t["grad_clip"])
        self.optimizer.step()
        out["reseeded"] = self.model.quantizer.update_usage_and_reseed(
            out["quant"], self.cfg["dead_code_steps"], self.reseed_rng)
        self.step += 1
        return out

    def moments(self):
        """{"adamw/exp_avg/<path>": ..., "adamw/exp_avg_sq/<path>": ...} like the checkpoint."""
        out = {}
        for name, p in self.model.named_parameters():
            state = self.optimizer.state.get(p, {})
            for key in ("exp_avg", "exp_avg_sq"):
                if key in state:
                    out[f"adamw/{key}/{name}"] = state[key]
        return out
