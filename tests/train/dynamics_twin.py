#!/usr/bin/python3
"""PyTorch twin of wmkit's dynamics model (train/world_model.h), written in plain PyTorch from the
description in docs/dynamics.md, with the C++ parameter names so a wm-train tensor archive loads
with load_state_dict(strict=True). Used by test_dynamics_twin.py (forward equality to 1e-5) and
bench/dynamics_bench.py (training speed)."""
import json
import math
import struct

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn



def action_dim(m):
    """model.action_dim: the data's action width; configs without the key take 7."""
    return m.get("action_dim", 7)


def read_archive(path):
    """{name: ndarray}, meta of a WMTENSR1 archive (docs/metrics-lpips.md)."""
    blob = open(path, "rb").read()
    assert blob[:8] == b"WMTENSR1", "magic"
    n = struct.unpack_from("<Q", blob, 8)[0]
    header = json.loads(blob[16:16 + n])
    dtypes = {"float32": "<f4", "int64": "<i8", "float64": "<f8", "int32": "<i4", "uint8": "u1"}
    out = {}
    for name, e in header["tensors"].items():
        start = 16 + n + e["offset"]
        out[name] = np.frombuffer(blob[start:start + e["length"]], dtypes[e["dtype"]]).reshape(
            e["shape"]).copy()
    return out, header.get("meta", {})


class Norm(nn.Module):
    def __init__(self, dim, rms):
        super().__init__()
        self.rms = rms
        self.weight = nn.Parameter(torch.ones(dim))
        if not rms:
            self.bias = nn.Parameter(torch.zeros(dim))

    def forward(self, x):
        if self.rms:
            return x * torch.rsqrt(x.pow(2).mean(-1, keepdim=True) + 1e-6) * self.weight
        return F.layer_norm(x, (x.shape[-1],), self.weight, self.bias, 1e-5)


class Attention(nn.Module):
    def __init__(self, dim, heads):
        super().__init__()
        self.heads = heads
        self.qkv = nn.Linear(dim, 3 * dim)
        self.proj = nn.Linear(dim, dim)

    def forward(self, x, causal, rope=False):
        m, l, d = x.shape
        q, k, v = self.qkv(x).view(m, l, 3, self.heads, d // self.heads).permute(2, 0, 3, 1, 4)
        if rope:
            q, k = rotate(q), rotate(k)
        scores = q @ k.transpose(-2, -1) / math.sqrt(d // self.heads)
        if causal:
            future = torch.ones(l, l, dtype=torch.bool, device=x.device).triu(1)
            scores = scores.masked_fill(future, float("-inf"))
        return self.proj((scores.softmax(-1) @ v).transpose(1, 2).reshape(m, l, d))


def rotate(x):
    """Rotary time (RoFormer): pair (i, i + hd/2) of frame l turned by l * 10000^(-2i/hd)."""
    length, hd = x.shape[-2], x.shape[-1]
    inv_freq = 10000.0 ** (-torch.arange(hd // 2, dtype=torch.float64) / (hd // 2))
    angle = torch.arange(length, dtype=torch.float64)[:, None] * inv_freq[None, :]
    cos, sin = angle.cos().to(x.dtype), angle.sin().to(x.dtype)
    x1, x2 = x[..., :hd // 2], x[..., hd // 2:]
    return torch.cat([x1 * cos - x2 * sin, x1 * sin + x2 * cos], -1)


class StBlock(nn.Module):
    def __init__(self, dim, heads, mlp_ratio, rms, causal_time=True, rope_time=False,
                 adaptive_norm="none"):
        super().__init__()
        self.causal_time = causal_time
        self.rope_time = rope_time
        self.norm1, self.norm2, self.norm3 = Norm(dim, rms), Norm(dim, rms), Norm(dim, rms)
        self.spatial, self.temporal = Attention(dim, heads), Attention(dim, heads)
        self.fc1, self.fc2 = nn.Linear(dim, mlp_ratio * dim), nn.Linear(mlp_ratio * dim, dim)
        if adaptive_norm != "none":  # adaLN: shift, scale, gate per sublayer from the frame's cond
            self.modulation = nn.Linear(dim, 9 * dim)
            self.gate_start = 0.0 if adaptive_norm == "zero" else 1.0

    def forward(self, x, cond=None):
        """x [B, T, N, D]; cond [B, T, D] with adaptive norm."""
        b, t, n, d = x.shape
        ident = (lambda h: h, lambda y: y)
        mods = [ident] * 3
        if hasattr(self, "modulation"):
            terms = self.modulation(F.silu(cond)).chunk(9, -1)  # 9x [B, T, D]
            mods = []
            for i in range(3):
                shift, scale, gate = terms[3 * i], terms[3 * i + 1], terms[3 * i + 2]
                gate = gate + self.gate_start
                mods.append(self._modulation(shift, scale, gate, i, b, t, n, d))
        x = x.reshape(b * t, n, d)
        x = x + mods[0][1](self.spatial(mods[0][0](self.norm1(x)), False))
        x = x.view(b, t, n, d).transpose(1, 2).reshape(b * n, t, d)
        x = x + mods[1][1](self.temporal(mods[1][0](self.norm2(x)), self.causal_time,
                                         self.rope_time))
        x = x.view(b, n, t, d).transpose(1, 2)
        return x + mods[2][1](self.fc2(F.gelu(self.fc1(mods[2][0](self.norm3(x))))))

    @staticmethod
    def _modulation(shift, scale, gate, sublayer, b, t, n, d):
        """(modulate, gate) for the sublayer's input layout: frames, grid positions, [B,T,N,D]."""
        layout = [lambda v: v.reshape(b * t, 1, d),
                  lambda v: v.unsqueeze(1).expand(b, n, t, d).reshape(b * n, t, d),
                  lambda v: v.unsqueeze(2)][sublayer]
        shift, scale, gate = layout(shift), layout(scale), layout(gate)
        return (lambda h: h * (1 + scale) + shift, lambda y: y * gate)


class StTransformer(nn.Module):
    def __init__(self, dim, heads, mlp_ratio, rms, layers, causal_time=True, rope_time=False,
                 adaptive_norm="none"):
        super().__init__()
        self.blocks = nn.ModuleList(
            [StBlock(dim, heads, mlp_ratio, rms, causal_time, rope_time, adaptive_norm)
             for _ in range(layers)])
        self.norm = Norm(dim, rms)

    def forward(self, x, cond=None):
        for block in self.blocks:
            x = block(x, cond)
        return self.norm(x)


class PolicyEmbedding(nn.Module):
    def __init__(self, m, p):
        super().__init__()
        d, zdim, n = p["d_model"], p["categories"] * p["classes"], m["grid_h"] * m["grid_w"]
        rms = m["norm"] == "rmsnorm"
        self.p = p
        self.token_embed = nn.Embedding(m["num_codes"], d)
        self.spatial_pos = nn.Parameter(torch.zeros(n, d))
        self.temporal_pos = nn.Parameter(torch.zeros(m["context_frames"], d))
        a = action_dim(m)
        self.posterior_action = nn.Linear(a, d)
        self.prior_action = nn.Linear(a, d)
        self.decoder_prev_action = nn.Linear(a, d)
        self.decoder_z = nn.Linear(zdim, d)
        self.decoder_start = nn.Parameter(torch.zeros(d))
        args = (d, p["num_heads"], m["mlp_ratio"], rms)
        self.posterior = StTransformer(*args, p["posterior_layers"], causal_time=False)
        self.prior = StTransformer(*args, p["prior_layers"])
        self.decoder = StTransformer(*args, p["decoder_layers"])
        self.posterior_head = nn.Linear(d, zdim)
        self.prior_head = nn.Linear(d, zdim)
        self.decoder_head = nn.Linear(d, 2 * a)

    def embed(self, tokens, extra):
        t = tokens.shape[1]
        return self.token_embed(tokens) + self.spatial_pos + (
            self.temporal_pos[:t] + extra).unsqueeze(2)

    def prior_logits(self, tokens, actions):
        b, t = tokens.shape[:2]
        h = self.prior(self.embed(tokens, self.prior_action(actions))).mean(2)
        return self.prior_head(h).view(b, t, self.p["categories"], self.p["classes"])

    def forward(self, tokens, actions, noise):
        b, t = tokens.shape[:2]
        c, k = self.p["categories"], self.p["classes"]
        hq = self.posterior(self.embed(tokens, self.posterior_action(actions)))
        post = self.posterior_head(hq.mean((1, 2))).view(b, c, k)
        prior = self.prior_logits(tokens, actions)
        index = (post.detach() - torch.log(-torch.log(noise))).argmax(-1)
        probs = post.softmax(-1)
        z = (F.one_hot(index, k).to(post.dtype) + probs - probs.detach()).view(b, c * k)
        prev = torch.cat([self.decoder_start.expand(b, 1, -1),
                          self.decoder_prev_action(actions[:, :t - 1])], 1)
        hd = self.decoder(self.embed(tokens, prev + self.decoder_z(z).unsqueeze(1))).mean(2)
        mean, log_std = self.decoder_head(hd).chunk(2, -1)
        return post, prior, mean, log_std.clamp(self.p["log_std_min"], self.p["log_std_max"])


class DynamicsNet(nn.Module):
    def __init__(self, m, z_dim):
        super().__init__()
        d, n = m["d_model"], m["grid_h"] * m["grid_w"]
        self.z_dim = z_dim
        # A residual tokenizer's codes per cell; level l's code c is embedding row l * (K + 1) + c.
        self.levels = m.get("levels", 1)
        self.token_embed = nn.Embedding(self.levels * (m["num_codes"] + 1), d)
        self.spatial_pos = nn.Parameter(torch.zeros(n, d))
        self.rope_time = m.get("temporal_positions", "learned") == "rope"
        if not self.rope_time:  # rotary time rotates queries and keys instead
            self.temporal_pos = nn.Parameter(torch.zeros(m["context_frames"], d))
        self.action_start = nn.Parameter(torch.zeros(d))
        self.action_in = nn.Linear(action_dim(m), d)
        if z_dim:
            self.z_in = nn.Linear(z_dim, d)
        self.transformer = StTransformer(d, m["num_heads"], m["mlp_ratio"],
                                         m["norm"] == "rmsnorm", m["num_layers"],
                                         rope_time=self.rope_time,
                                         adaptive_norm=m.get("adaptive_norm", "none"))
        self.num_codes = m["num_codes"]
        self.next_frame = m.get("objective", "masked") == "next_frame"
        if m.get("tied_token_head", False):
            self.token_bias = nn.Parameter(torch.zeros(self.levels * m["num_codes"]))
        else:
            self.token_head = nn.Linear(d, self.levels * m["num_codes"])
        self.reward_head = nn.Linear(d, 2)
        if m.get("copy_prior", False):
            self.copy_gate = nn.Linear(d, self.levels)

    def embed_codes(self, tokens):
        """[B, T, levels * cells] (level-major) -> [B, T, cells, D]: the sum over levels."""
        b, t = tokens.shape[:2]
        first_row = torch.arange(self.levels).view(-1, 1) * (self.num_codes + 1)
        return self.token_embed(tokens.reshape(b, t, self.levels, -1) + first_row).sum(2)

    def token_major(self, x):
        """Per-cell outputs [B, T, cells, levels * C] -> per-token [B, T, levels * cells, C]."""
        b, t, cells = x.shape[:3]
        return x.reshape(b, t, cells, self.levels, -1).permute(0, 1, 3, 2, 4).reshape(
            b, t, self.levels * cells, -1)

    def forward(self, tokens, actions, z):
        """Logits of frame j at position j ("masked") or of frame j+1 ("next_frame")."""
        b, t = tokens.shape[:2]
        k = self.num_codes
        if self.next_frame:  # position j: frame j, a_j, z_j
            cond = self.action_in(actions)
            if self.z_dim:
                cond = cond + self.z_in(z)
        else:  # position j: frame j, a_{j-1}, z_{j-1}
            cond = torch.cat([self.action_start.expand(b, 1, -1),
                              self.action_in(actions[:, :t - 1])], 1)
            if self.z_dim:
                cond = cond + F.pad(self.z_in(z[:, :t - 1]), (0, 0, 1, 0))
        frame_cond = cond  # what adaLN reads: the frame's action and z, not its window slot
        if not self.rope_time:
            cond = cond + self.temporal_pos[:t]
        h = self.transformer(self.embed_codes(tokens) + self.spatial_pos + cond.unsqueeze(2),
                             frame_cond)
        reward, terminal = self.reward_head(h.mean(2)).unbind(-1)
        if hasattr(self, "token_head"):
            logits = self.token_head(h)
        else:  # tied: each level's code rows of the input embedding (not its mask row)
            rows = self.token_embed.weight.view(self.levels, k + 1, -1)[:, :k]
            logits = F.linear(h, rows.reshape(self.levels * k, -1), self.token_bias)
        logits = self.token_major(logits)
        if hasattr(self, "copy_gate"):  # bonus on the code the predicted cell had a frame earlier
            prev = tokens if self.next_frame else torch.cat(
                [torch.full_like(tokens[:, :1], k), tokens[:, :-1]], 1)
            gate = self.token_major(self.copy_gate(h)) * (prev < k).unsqueeze(-1).to(h.dtype)
            logits = logits.scatter_add(-1, prev.clamp(max=k - 1).unsqueeze(-1), gate)
        return logits, reward, terminal


class WorldModel(nn.Module):
    def __init__(self, config):
        super().__init__()
        m, p = config["model"], config["policy"]
        self.config = config
        z_dim = p["categories"] * p["classes"] if m["policy_conditioning"] else 0
        self.dynamics = DynamicsNet(m, z_dim)
        self.policy = PolicyEmbedding(m, p) if m["policy_conditioning"] else None

    def policy_tokens(self, tokens):
        """The policy embedding reads the first level (a residual tokenizer's coarse codes)."""
        m = self.config["model"]
        return tokens[:, :, :m["grid_h"] * m["grid_w"]]

    def dynamics_z(self, tokens, actions):
        if self.policy is None:
            return None
        with torch.no_grad():
            prior = self.policy.prior_logits(self.policy_tokens(tokens), actions)
            return prior.softmax(-1).flatten(2)

    def losses(self, tokens, actions, rewards, terminals, mask, z_noise, action_mask=None):
        """The training objective (WHALE eq. 4 + eq. 5 + reward terms) as the C++ computes it.
        `action_mask` [B, 1, D] (1 real, 0 padding of a narrower dataset): padding is zeroed
        before every action layer and left out of the policy NLL."""
        t_cfg, k = self.config["train"], self.config["model"]["num_codes"]
        out, z = {}, None
        keep = torch.ones_like(actions) if action_mask is None else action_mask.expand_as(actions)
        actions = actions * keep
        if self.policy is not None:
            post, prior, mean, log_std = self.policy(self.policy_tokens(tokens), actions, z_noise)
            nll = ((0.5 * ((actions - mean) * torch.exp(-log_std)).pow(2) + log_std +
                    0.5 * math.log(2 * math.pi)) * keep).sum(-1).sum(1).mean()
            log_q = post.log_softmax(-1).unsqueeze(1)
            log_p = prior.log_softmax(-1)
            kl = (log_q.exp() * (log_q - log_p)).sum((-2, -1)).sum(1).mean()
            out["policy_nll"], out["policy_kl"] = nll, kl
            z = prior.detach().softmax(-1).flatten(2)
        if self.dynamics.next_frame:  # clean input; position j is scored on frame j+1
            logits, reward, terminal = self.dynamics(tokens, actions, z)
            logits, target, mask = logits[:, :-1], tokens[:, 1:], mask[:, 1:]
        else:  # MaskGIT: the masked tokens are the targets
            logits, reward, terminal = self.dynamics(tokens.masked_fill(mask, k), actions, z)
            target = tokens
        ce = F.cross_entropy(logits.reshape(-1, k), target.reshape(-1), reduction="none")
        m = mask.reshape(-1).float()
        out["token_ce"] = (ce * m).sum() / m.sum().clamp_min(1)
        out["reward_mse"] = F.mse_loss(reward, rewards)  # position j: step j
        out["terminal_bce"] = F.binary_cross_entropy_with_logits(terminal, terminals)
        total = (out["token_ce"] + t_cfg["reward_weight"] * out["reward_mse"] +
                 t_cfg["terminal_weight"] * out["terminal_bce"])
        if self.policy is not None:
            total = total + t_cfg["policy_weight"] * (nll + self.config["policy"]["kl_beta"] * kl)
        out["total"] = total
        return out


def load_world_model(tensors, config):
    model = WorldModel(config)
    state = {name[len("model/"):]: torch.from_numpy(a) for name, a in tensors.items()
             if name.startswith("model/")}
    model.load_state_dict(state, strict=True)
    return model
