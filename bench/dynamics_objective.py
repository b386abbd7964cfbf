#!/usr/bin/python3
"""Issue 20, goal 2 experiment (docs/dynamics.md, "Why the model copies"): the same dynamics body
(the PyTorch twin's DynamicsNet at the tiny preset, policy conditioning off, next-frame
objective) trained two ways on the same token windows, then scored on the val windows where a
cell's code changes:
  ce          cross-entropy over the codes with the copy prior (what wm-train does)
  regression  a Linear(d, latent_dim) head regressing the tokenizer's unit code vector of the
              next frame (loss 1 - cosine); the predicted code is the nearest one
Columns: argmax / nearest-code accuracy where the code changes and where it stays, and the
cosine between the predicted and true code vectors where it changes, next to copying's.

  bench/dynamics_objective.py {ce,regression} STEPS TOKENS_DIR TOKENIZER_CHECKPOINT
  (TOKENS_DIR holds train/ and val/ token datasets: a make-demo RUN/tokens)
"""
import math
import os
import sys
import time

import numpy as np
import torch
import torch.nn.functional as F
import yaml

SRC = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
sys.path.insert(0, os.path.join(SRC, "tests", "train"))
sys.path.insert(0, os.path.join(SRC, "scripts"))
from dynamics_twin import DynamicsNet, read_archive  # noqa: E402
from wmshard import TokenDataset  # noqa: E402

BATCH, MAX_LR, MIN_LR, WARMUP = 8, 1e-3, 1e-4, 50  # as configs/dynamics/tiny.yaml


def load_episodes(directory):
    data = TokenDataset(directory)
    out = []
    for k in range(data.num_episodes):
        e = data.episode(k)
        out.append((np.array(e["tokens"]).reshape(len(e["tokens"]), -1),
                    np.array(e["actions"], np.float32)))
    return out


def learning_rate(step, steps):
    if step < WARMUP:
        return MAX_LR * (step + 1) / WARMUP
    return MIN_LR + 0.5 * (MAX_LR - MIN_LR) * (1 + math.cos(math.pi * (step - WARMUP) /
                                                            max(1, steps - WARMUP)))


class Experiment:
    def __init__(self, objective, token_dir, tokenizer, seed=0):
        tensors, _ = read_archive(tokenizer)
        book = F.normalize(torch.tensor(tensors["model/quantizer.codebook"]), dim=-1)
        self.setup(objective, book,
                   load_episodes(os.path.join(token_dir, "train")),
                   load_episodes(os.path.join(token_dir, "val")), objective == "ce", seed)

    @classmethod
    def on_episodes(cls, objective, book, train, val, copy_prior, seed=0):
        """The same experiment on [(codes [T, N], raw actions [T, 7])] made elsewhere."""
        experiment = cls.__new__(cls)
        experiment.setup(objective, book, train, val, copy_prior, seed)
        return experiment

    def setup(self, objective, book, train, val, copy_prior, seed):
        torch.manual_seed(seed)  # the weights' init: reruns give the same table
        config = yaml.safe_load(open(os.path.join(SRC, "configs", "dynamics", "tiny.yaml")))
        m = config["model"]
        m.update(policy_conditioning=False, copy_prior=copy_prior, num_codes=len(book))
        self.objective, self.context, self.num_codes = objective, m["context_frames"], len(book)
        self.book, self.train, self.val = book, train, val
        actions = np.concatenate([a for _, a in self.train])
        self.mean, self.std = actions.mean(0), actions.std(0) + 1e-6
        self.net = DynamicsNet(m, 0)
        for p in self.net.parameters():
            if p.dim() >= 2:
                torch.nn.init.normal_(p, 0, 0.02)
        self.params = list(self.net.parameters())
        if objective == "regression":
            self.head = torch.nn.Linear(m["d_model"], self.book.shape[1])
            self.params += list(self.head.parameters())

    def windows(self, episodes, k, s):
        codes, actions = episodes[k]
        return (torch.tensor(codes[s:s + self.context])[None],
                torch.tensor((actions[s:s + self.context] - self.mean) / self.std)[None].float())

    def predict(self, x, a):
        """Predicted codes of frames 1..T-1 [B, T-1, N] and the training loss."""
        target = x[:, 1:]
        if self.objective == "ce":
            logits = self.net(x, a, None)[0][:, :-1]
            return logits.argmax(-1), F.cross_entropy(logits.reshape(-1, self.num_codes),
                                                      target.reshape(-1))
        net = self.net
        h = net.transformer(net.token_embed(x) + net.spatial_pos +
                            (net.temporal_pos[:x.shape[1]] + net.action_in(a)).unsqueeze(2))
        v = F.normalize(self.head(h)[:, :-1], dim=-1)  # [B, T-1, N, D]
        return (v @ self.book.T).argmax(-1), (1 - (v * self.book[target]).sum(-1)).mean()

    def fit(self, steps, seed=0):
        rng = np.random.default_rng(seed)
        starts = [(k, s) for k, (c, _) in enumerate(self.train)
                  for s in range(len(c) - self.context + 1)]
        opt = torch.optim.AdamW(self.params, lr=MAX_LR, betas=(0.9, 0.9), weight_decay=0)
        for step in range(steps):
            for group in opt.param_groups:
                group["lr"] = learning_rate(step, steps)
            picked = [self.windows(self.train, *starts[j])
                      for j in rng.integers(0, len(starts), BATCH)]
            x, a = (torch.cat(t) for t in zip(*picked))
            _, loss = self.predict(x, a)
            opt.zero_grad()
            loss.backward()
            torch.nn.utils.clip_grad_norm_(self.params, 1.0)
            opt.step()

    @torch.no_grad()
    def score(self):
        hits = {True: 0, False: 0}
        counts = {True: 0, False: 0}
        cos_pred = cos_copy = 0.0
        for k, (codes, _) in enumerate(self.val):
            for s in range(len(codes) - self.context + 1):
                x, a = self.windows(self.val, k, s)
                predicted, _ = self.predict(x, a)
                target, previous = x[:, 1:], x[:, :-1]
                changed = target != previous
                for flag, cells in ((True, changed), (False, ~changed)):
                    hits[flag] += (predicted == target)[cells].sum().item()
                    counts[flag] += cells.sum().item()
                cos_pred += (self.book[predicted] * self.book[target]).sum(-1)[changed].sum().item()
                cos_copy += (self.book[previous] * self.book[target]).sum(-1)[changed].sum().item()
        n = counts[True]
        return hits[True] / n, hits[False] / counts[False], cos_pred / n, cos_copy / n, n


def main(objective, steps, token_dir, tokenizer):
    torch.set_num_threads(1)
    start = time.time()
    experiment = Experiment(objective, token_dir, tokenizer)
    experiment.fit(steps)
    changed_acc, static_acc, cos_pred, cos_copy, n = experiment.score()
    print(f"{objective}, {steps} steps: accuracy where the code changes {changed_acc:.4f} "
          f"(n {n}), where it stays {static_acc:.4f}; cosine(predicted, true) where it changes "
          f"{cos_pred:.3f} (copy {cos_copy:.3f}); {time.time() - start:.0f} s")


if __name__ == "__main__":
    if len(sys.argv) != 5 or sys.argv[1] not in ("ce", "regression"):
        sys.exit(__doc__)
    main(sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4])
