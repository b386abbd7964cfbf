#!/usr/bin/python3
"""`make finetune`: pretrain, then fine-tune on a few demonstrations of an unseen scene (Whale-X
Sec. 4.2, issue 22) with the tiny presets. Pretraining: a large varied-look tabletop set, goals in
one part of the table. Fine-tuning: 20 episodes of a plain-look scene with goals in another part,
`wm-train --init-from` the pretrained model, the pretrained tokenizer reused (frozen). Evaluated
on held-out episodes of the new scene: fine-tuned, from scratch on the same episodes with the same
steps, and the pretrained model as it is. Drives the real executables; every stage is skipped
when its output exists, so a killed run resumes. docs/finetune.md.

  scripts/finetune.py --bin build/bin --config configs/finetune/tiny.yaml --out data/finetune
"""
import csv
import io
import json
import os
import sys
import time

from pipeline_steps import ConfigKeys, Pipeline, load_yaml_config, sha256, start, \
    write_atomically

MODELS = ["finetuned", "scratch", "pretrained"]  # finetune.csv's rows, then copy_last
METRICS = ["psnr", "ssim", "lpips_style", "mse_arm", "mse_object", "delta_tpsnr"]
SUMMARY_METRICS = {"psnr": 1, "mse_arm": -1}  # summary gains, oriented so positive = better
STRIP_ROWS = ["real", "finetuned", "scratch", "pretrained", "copy_last"]


def load_config(path):
    """The config, every key checked; a bad one is one line naming the file and the key."""
    cfg = load_yaml_config(path)
    keys = ConfigKeys(path, cfg)
    get, positive = keys.get, ConfigKeys.POSITIVE
    keys.seed_and_frames()
    for part in ["pretrain", "finetune"]:
        get(f"data.{part}.look", str, lambda v: v in ("varied", "plain"), "varied or plain")
        get(f"data.{part}.goal_region", str)
        get(f"data.{part}.train_episodes", int, *positive)
        get(f"data.{part}.seed", int, *ConfigKeys.NON_NEGATIVE)
    get("data.pretrain.val_episodes", int, *positive)
    get("data.finetune.eval_episodes", int, lambda v: v >= 2, "an integer >= 2 (paired intervals)")
    for key in ["tokenizer.steps", "dynamics.pretrain_steps", "dynamics.finetune_steps",
                "dynamics.threads", "eval.horizon", "eval.resamples"]:
        get(key, int, *positive)
    get("dynamics.freeze", str, lambda v: v in ("", "policy"), "'' or 'policy'")
    get("eval.strips", int, lambda v: v >= 1, "an integer >= 1")
    for key in ["tokenizer.config", "dynamics.config"]:
        keys.existing_file(key)
    return cfg


def summary_from_compare(finetuned, episodes, resamples, seed):
    """finetune_summary.json from the fine-tuned model's compare.csv row (baseline scratch, plain
    rollout): its paired deltas and intervals, oriented so positive = better (a lower-is-better
    metric's delta is negated and its interval negated and swapped)."""
    summary = {"format": "wmkit-finetune-summary", "format_version": 1,
               "candidate": "finetuned", "baseline": "scratch", "rollout": "plain",
               "episodes": episodes, "resamples": resamples, "seed": seed, "level": 0.95,
               "interval": "paired percentile bootstrap over the held-out episodes "
                           "(wm-report compare)"}
    for m, sign in SUMMARY_METRICS.items():
        delta, lo, hi = (float(finetuned[f"{m}_delta{s}"]) if finetuned[f"{m}_delta{s}"] else None
                         for s in ["", "_ci_low", "_ci_high"])
        if sign < 0:  # + 0.0: no negative zero in the JSON
            lo, hi = (None if hi is None else -hi + 0.0), (None if lo is None else -lo + 0.0)
            delta = None if delta is None else -delta + 0.0
        summary[f"{m}_gain_vs_scratch"] = delta
        summary[f"{m}_gain_ci_low"] = lo
        summary[f"{m}_gain_ci_high"] = hi
    return summary


class Finetune(Pipeline):
    def __init__(self, args):
        super().__init__(args, "finetune", load_config)

    def data(self):
        """Two generations: the pretraining set (its val split: the pretraining run's validation
        loss) and the new scene (its val split: the held-out evaluation episodes)."""
        d = self.cfg["data"]
        for part in ["pretrain", "finetune"]:
            p, raw = d[part], os.path.join("raw", part)
            self.generate(raw, d["size"], d["policies"], p["train_episodes"],
                          p.get("val_episodes", p.get("eval_episodes")), p["seed"], p["look"],
                          p["goal_region"])
            for split in ["train", "val"]:
                self.ingest(raw, split, f"{part}_{split}")

    def tokenizer(self):
        """Trained on the pretraining set only; every split is encoded with it, so the new scene's
        tokens come from the pretrained tokenizer unchanged (frozen)."""
        t = self.cfg["tokenizer"]
        self.train_tokenizer(t["config"], t["steps"], self.cfg["seed"], "pretrain_train",
                             "pretrain_val")
        for split in ["pretrain_train", "pretrain_val", "finetune_train", "finetune_val"]:
            self.encode(split)

    def dynamics(self, name, tokens, val_tokens, steps, *extra):
        d = self.cfg["dynamics"]
        self.train_dynamics(self.path(name, "dynamics"), d["config"], tokens, val_tokens, steps,
                            self.cfg["seed"], d["threads"], *extra)

    def train_all(self):
        d = self.cfg["dynamics"]
        self.timed("pretrain", self.dynamics, "pretrained", "pretrain_train", "pretrain_val",
                   d["pretrain_steps"])
        # The held-out episodes are only logged as validation loss; nothing selects on them.
        freeze = ["--freeze", d["freeze"]] if d["freeze"] else []
        self.timed("finetune", self.dynamics, "finetuned", "finetune_train", "finetune_val",
                   d["finetune_steps"], "--init-from", self.path("pretrained", "dynamics"),
                   *freeze)
        self.timed("scratch", self.dynamics, "scratch", "finetune_train", "finetune_val",
                   d["finetune_steps"])

    def evaluate_all(self):
        e = self.cfg["eval"]
        self.evaluate("reports", MODELS, [self.path(m, "dynamics") for m in MODELS],
                      "finetune_val", e["horizon"], self.cfg["seed"], e["resamples"],
                      e["strips"], self.cfg["dynamics"]["threads"])
        # The paired bootstrap over episodes is wm-report compare's (docs/reports.md).
        reports = self.path("reports")
        self.tool("wm-report", "compare", *[os.path.join(reports, m) for m in MODELS],
                  "--baseline", "scratch", "--metrics", ",".join(METRICS), "--out",
                  self.path("compare.csv"), "--markdown", self.path("compare.md"), "--seed",
                  self.cfg["seed"], "--resamples", e["resamples"])

    def compare_rows(self):
        with open(self.path("compare.csv"), encoding="utf-8") as f:
            return {(r["checkpoint"], r["rollout"]): r for r in csv.DictReader(f)}

    def init_from(self, model):
        with open(self.path(model, "dynamics", "checkpoint.json"), encoding="utf-8") as f:
            return json.load(f).get("init_from")

    def write_csv(self, rows):
        header = ["model", "rollout", "init_from_sha256", "train_episodes", "train_steps",
                  "n_episodes"]
        for m in METRICS:
            header += [m, f"{m}_ci_low", f"{m}_ci_high", f"{m}_vs_scratch",
                       f"{m}_vs_scratch_ci_low", f"{m}_vs_scratch_ci_high", f"{m}_vs_copy_last",
                       f"{m}_vs_copy_last_ci_low", f"{m}_vs_copy_last_ci_high"]
        d = self.cfg["data"]
        steps = {"finetuned": self.cfg["dynamics"]["finetune_steps"],
                 "scratch": self.cfg["dynamics"]["finetune_steps"],
                 "pretrained": self.cfg["dynamics"]["pretrain_steps"]}
        episodes = {"finetuned": d["finetune"]["train_episodes"],
                    "scratch": d["finetune"]["train_episodes"],
                    "pretrained": d["pretrain"]["train_episodes"]}
        n = self.episode_counts()
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(header)
        for model, rollout in [*((m, "plain") for m in MODELS), ("scratch", "copy_last")]:
            r = rows[(model, rollout)]
            is_model = rollout == "plain"
            parent = self.init_from(model) if is_model else None
            row = ["copy_last" if not is_model else model, rollout,
                   parent["checkpoint_sha256"] if parent else "",
                   episodes[model] if is_model else "", steps[model] if is_model else "",
                   n[(model, rollout)]]
            for m in METRICS:
                row += [r.get(f"{m}{s}", "") for s in ["", "_ci_low", "_ci_high"]]
                # compare.csv's delta is against the baseline's row of the same rollout, so for
                # copy_last it is copy_last - copy_last: left empty here.
                row += [r.get(f"{m}_delta{s}", "") if is_model else ""
                        for s in ["", "_ci_low", "_ci_high"]]
                row += [r.get(f"{m}_vs_copy_last{s}", "") for s in ["", "_ci_low", "_ci_high"]]
            w.writerow(row)
        write_atomically(self.path("finetune.csv"), buf.getvalue())

    def episode_counts(self):
        """(model, rollout) -> episodes scored, from the reports' summary.csv psnr rows."""
        n = {}
        for model in MODELS:
            with open(self.path("reports", model, "summary.csv"), encoding="utf-8") as f:
                for r in csv.DictReader(f):
                    if r["metric"] == "psnr":
                        n[(model, r["rollout"])] = r["n"]
        return n

    def write_summary(self, rows):
        summary = summary_from_compare(rows[("finetuned", "plain")],
                                       int(self.episode_counts()[("finetuned", "plain")]),
                                       self.cfg["eval"]["resamples"], self.cfg["seed"])
        write_atomically(self.path("finetune_summary.json"), json.dumps(summary, indent=2) + "\n")
        return summary

    def strips(self):
        """strips/episode_K.png: the real frames, each model's plain rollout and copy_last on the
        same held-out episode, cut from wm-eval's strips (geometry: evaluate/episode_strip.h)."""
        import cv2
        import numpy as np
        label_w, header_h, gap = 144, 24, 2
        out_dir = self.path("strips")
        os.makedirs(out_dir, exist_ok=True)
        source = self.path("reports", "finetuned", "strips")
        for name in sorted(os.listdir(source)):
            if not (name.startswith("episode_") and name.endswith(".png")):
                continue
            images = {m: cv2.imread(os.path.join(self.path("reports", m, "strips"), name))
                      for m in MODELS}
            if any(img is None for img in images.values()):
                sys.exit(f"finetune: {name} is missing or unreadable in a report's strips/")
            base = images["finetuned"]
            cell = self.cfg["data"]["size"] * -(-192 // self.cfg["data"]["size"])

            def row(img, r):
                y = header_h + r * (cell + gap)
                return img[y:y + cell + gap].copy()

            # wm-eval --rollout plain: row 0 real, 1 plain, 2 copy_last (episode_strip.h)
            rows = [row(base, 0), *(row(images[m], 1) for m in MODELS), row(base, 2)]
            for r, label in zip(rows, STRIP_ROWS):
                r[:, :label_w] = base[header_h // 2, 0]  # the strip's background
                cv2.putText(r, label, (6, cell // 2 + 5), cv2.FONT_HERSHEY_SIMPLEX, 0.6,
                            (235, 235, 235), 1, cv2.LINE_AA)
            picture = np.concatenate([base[:header_h], *rows])
            ok, png = cv2.imencode(".png", picture)
            if not ok:
                sys.exit(f"finetune: cannot encode {name}")
            write_atomically(os.path.join(out_dir, name), png.tobytes())

    def manifest(self, started):
        models = {}
        for m in MODELS:
            with open(self.path(m, "dynamics", "checkpoint.json"), encoding="utf-8") as f:
                ckpt = json.load(f)
            models[m] = {"checkpoint_sha256": sha256(self.path(m, "dynamics", "checkpoint.wmt")),
                         "config_hash": ckpt.get("config_hash"), "step": ckpt.get("step"),
                         "init_from": ckpt.get("init_from"), "data": ckpt.get("data")}
        splits = ["pretrain_train", "pretrain_val", "finetune_train", "finetune_val"]
        manifest = {
            "format": "wmkit-finetune-manifest", "format_version": 1,
            "config": self.cfg, "config_sha256": sha256(self.config_path),
            "tokenizer_sha256": sha256(self.path("tokenizer", "checkpoint.wmt")),
            "shard_index_sha256": {s: sha256(self.path("shards", s, "index.json"))
                                   for s in splits},
            "models": models,
            "reports": {m: sha256(self.path("reports", m, "manifest.json")) for m in MODELS},
            "files": {f: sha256(self.path(f))
                      for f in ["finetune.csv", "finetune_summary.json", "compare.csv"]},
            "stage_seconds_this_invocation": self.stage_seconds,
            "wall_seconds_this_invocation": round(time.time() - started, 1)}
        write_atomically(self.path("manifest.json"), json.dumps(manifest, indent=2) + "\n")


def markdown(path):
    """finetune.csv as the README's table: means with intervals, deltas to scratch."""
    with open(path, encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    shown = ["psnr", "ssim", "mse_arm", "mse_object", "delta_tpsnr"]
    fmt = lambda r, m: "" if not r[m] else (
        f"{float(r[m]):.4g} [{float(r[m + '_ci_low']):.4g}, {float(r[m + '_ci_high']):.4g}]"
        if r[m + "_ci_low"] else f"{float(r[m]):.4g}")
    out = ["| model | " + " | ".join(shown) + " | Δ psnr vs scratch | Δ mse_arm vs scratch |",
           "|---|" + "---|" * (len(shown) + 2)]
    for r in rows:
        delta = lambda m: "" if not r[m + "_vs_scratch"] else (
            f"{float(r[m + '_vs_scratch']):+.4g} [{float(r[m + '_vs_scratch_ci_low']):+.4g}, "
            f"{float(r[m + '_vs_scratch_ci_high']):+.4g}]")
        out.append(f"| {r['model']} | " + " | ".join(fmt(r, m) for m in shown) +
                   f" | {delta('psnr')} | {delta('mse_arm')} |")
    return "\n".join(out) + "\n"


def main():
    f, started = start(__doc__, Finetune, "finetune")
    f.timed("data", f.data)
    f.timed("tokenizer", f.tokenizer)
    f.train_all()
    f.timed("evaluate", f.evaluate_all)
    rows = f.compare_rows()
    f.write_csv(rows)
    summary = f.write_summary(rows)
    f.strips()
    table = markdown(f.path("finetune.csv"))
    write_atomically(f.path("finetune.md"), table)
    f.manifest(started)
    print(table)
    print(json.dumps({k: v for k, v in summary.items() if "gain" in k}, indent=2))
    print(f"finetune finished in {time.time() - started:.0f} s: {f.path('finetune.csv')}")


if __name__ == "__main__":
    main()
