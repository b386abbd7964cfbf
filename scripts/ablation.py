#!/usr/bin/python3
"""`make ablation`: WHALE Table 2 on the embedded tabletop data - the dynamics model with and
without policy conditioning, each rolled out plainly and with retracing, on episodes of seen and
of unseen policies. Drives the real executables; every stage is skipped when its output exists,
so a killed run resumes without redoing finished variants. docs/ablation.md.

  scripts/ablation.py --bin build/bin --config configs/ablation/tiny.yaml --out data/ablation
"""
import argparse
import csv
import io
import json
import math
import os
import time

import yaml

from pipeline_steps import run, sha256, write_atomically

METRICS = ["fvd_style", "psnr", "ssim", "lpips_style", "mse_arm", "mse_object",
           "mse_background", "value_gap", "spearman"]
ROLLOUTS = ["plain", "retrace", "copy_last", "tokenizer_recon"]
SPLITS = ["seen", "unseen"]


class Ablation:
    def __init__(self, args):
        self.bin, self.out = args.bin, args.out
        with open(args.config, encoding="utf-8") as f:
            self.cfg = yaml.safe_load(f)
        self.config_path = args.config
        self.log = os.path.join(self.out, "ablation.log")
        os.makedirs(self.out, exist_ok=True)

    def path(self, *parts):
        return os.path.join(self.out, *parts)

    def tool(self, name, *args):
        run([os.path.join(self.bin, name), *map(str, args)], self.log, "ablation")

    def data(self):
        """Seen policies give the training split and the seen split; the unseen policies come
        from a second generation with another seed, so no episode is shared."""
        d, seed = self.cfg["data"], self.cfg["seed"]
        gens = {"seen": (d["seen_policies"], d["train_episodes"], seed),
                "unseen": (d["unseen_policies"], 1, seed + 1)}
        for name, (policies, train, gen_seed) in gens.items():
            raw = self.path("raw", name)
            if not os.path.exists(os.path.join(raw, "wm_tabletop", "1.0.0", "dataset_info.json")):
                self.tool("wm-gen-tabletop", "--out", raw, "--size", d["size"], "--policies",
                          policies, "--train-episodes", train, "--val-episodes",
                          d["eval_episodes"], "--seed", gen_seed, "--look",
                          d.get("look", "varied"))
        splits = {"train": ("seen", "train"), "seen": ("seen", "val"), "unseen": ("unseen", "val")}
        for split, (raw, tfds_split) in splits.items():
            if not os.path.exists(self.path("shards", split, "index.json")):
                self.tool("wm-ingest", "--format", "rlds", "--input",
                          self.path("raw", raw, "wm_tabletop", "1.0.0"), "--split", tfds_split,
                          "--output", self.path("shards", split))

    def tokenizer(self):
        t = self.cfg["tokenizer"]
        ckpt = self.path("tokenizer", "checkpoint.wmt")
        resume = ["--resume"] if os.path.exists(ckpt) else []
        self.tool("wm-tokenize", "train", "--config", t["config"], "--data",
                  self.path("shards", "train"), "--out", self.path("tokenizer"), "--steps",
                  t["steps"], "--seed", self.cfg["seed"], *resume)
        for split in ["train", *SPLITS]:
            self.tool("wm-tokenize", "encode", "--checkpoint", self.path("tokenizer"), "--data",
                      self.path("shards", split), "--out", self.path("tokens", split))

    def dynamics(self, variant):
        """One model per variant: the dynamics preset with the variant's overrides."""
        d, name = self.cfg["dynamics"], variant["name"]
        with open(d["config"], encoding="utf-8") as f:
            config = yaml.safe_load(f)
        for section, values in variant.items():
            if section != "name":
                config.setdefault(section, {}).update(values)
        os.makedirs(self.path(name), exist_ok=True)
        config_file = self.path(name, "dynamics.yaml")
        write_atomically(config_file, yaml.safe_dump(config, sort_keys=True))
        run_dir = self.path(name, "dynamics")
        resume = ["--resume"] if os.path.exists(os.path.join(run_dir, "checkpoint.wmt")) else []
        self.tool("wm-train", "--config", config_file, "--tokens", self.path("tokens", "train"),
                  "--val-tokens", self.path("tokens", "seen"), "--out", run_dir, "--steps",
                  d["steps"], "--seed", self.cfg["seed"], "--threads", d["threads"], *resume)

    def evaluate(self, split):
        e, names = self.cfg["eval"], [v["name"] for v in self.cfg["variants"]]
        reports = self.path("reports", split)
        if all(os.path.exists(os.path.join(reports, n, "manifest.json")) for n in names):
            return
        self.tool("wm-eval", "--checkpoint", *[self.path(n, "dynamics") for n in names],
                  "--name", *names, "--tokenizer", self.path("tokenizer"), "--data",
                  self.path("shards", split), "--tokens", self.path("tokens", split), "--out",
                  reports, "--horizon", e["horizon"], "--rollout", "both", "--seed",
                  self.cfg["seed"], "--resamples", e["resamples"], "--masks", "files",
                  "--seg-config", "configs/segmentation/tabletop.yaml", "--videos", 1)

    def summary_rows(self):
        """(variant, split, rollout) -> metric -> (mean, ci_low, ci_high), and episode counts."""
        table, episodes = {}, {}
        for split in SPLITS:
            for v in self.cfg["variants"]:
                report = self.path("reports", split, v["name"])
                with open(os.path.join(report, "summary.csv"), encoding="utf-8") as f:
                    for row in csv.DictReader(f):
                        key = (v["name"], split, row["rollout"])
                        table.setdefault(key, {})[row["metric"]] = (
                            row["mean"], row["ci_low"], row["ci_high"])
                        if row["metric"] == "psnr":
                            episodes[key] = row["n"]
        return table, episodes

    def write_csv(self, table, episodes):
        header = ["variant", "split", "rollout", "n_episodes"]
        for m in METRICS:
            header += [m, m + "_ci_low", m + "_ci_high"]
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(header)
        for v in self.cfg["variants"]:
            for split in SPLITS:
                for rollout in ROLLOUTS:
                    key = (v["name"], split, rollout)
                    if key not in table:
                        continue
                    row = [*key, episodes.get(key, "")]
                    for m in METRICS:
                        row += list(table[key].get(m, ("", "", "")))
                    w.writerow(row)
        write_atomically(self.path("ablation.csv"), buf.getvalue())

    def findings(self, table):
        """The paper's directions, each checked per split (and per variant or rollout)."""
        def get(key, m):
            mean, lo, hi = table.get(key, {}).get(m, ("", "", ""))
            num = lambda s: float(s) if s not in ("", None) else math.nan
            return num(mean), num(lo), num(hi)

        def verdict(better, worse, m):
            (a, alo, ahi), (b, blo, bhi) = get(better, m), get(worse, m)
            if math.isnan(a) or math.isnan(b):
                return f"undefined ({m} has no value)"
            holds = "holds" if a < b else "does not hold"
            if math.isnan(alo) or math.isnan(blo):
                sep = "no interval"
            else:
                sep = "intervals separate" if ahi < blo or bhi < alo else "intervals overlap"
            return f"{holds} ({a:.4g} vs {b:.4g}; {sep})"

        lines = []
        names = [v["name"] for v in self.cfg["variants"]]
        for split in SPLITS:
            for n in names:
                for m in ["fvd_style", "value_gap"]:
                    lines.append(f"| retracing lowers {m} | {n} | {split} | "
                                 f"{verdict((n, split, 'retrace'), (n, split, 'plain'), m)} |")
            if "policy" in names and "no_policy" in names:
                for rollout in ["plain", "retrace"]:
                    lines.append(
                        f"| policy conditioning lowers value_gap | {rollout} | {split} | "
                        f"{verdict(('policy', split, rollout), ('no_policy', split, rollout), 'value_gap')} |")
        return lines

    def write_markdown(self, table, episodes):
        shown = ["fvd_style", "psnr", "ssim", "lpips_style", "mse_arm", "value_gap", "spearman"]
        out = ["| variant | split | rollout | n | " + " | ".join(shown) + " |",
               "|" + "---|" * (4 + len(shown))]
        for (variant, split, rollout), metrics in sorted(table.items()):
            if rollout not in ("plain", "retrace"):
                continue
            cells = []
            for m in shown:
                mean, lo, hi = metrics.get(m, ("", "", ""))
                cells.append("" if mean == "" else f"{float(mean):.4g}" +
                             (f" [{float(lo):.3g}, {float(hi):.3g}]" if lo != "" else ""))
            out.append(f"| {variant} | {split} | {rollout} | "
                       f"{episodes.get((variant, split, rollout), '')} | " + " | ".join(cells) + " |")
        out += ["", "| direction (whale-x Table 2) | variant / rollout | split | here |",
                "|---|---|---|---|", *self.findings(table)]
        write_atomically(self.path("ablation.md"), "\n".join(out) + "\n")

    def plot(self):
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, axes = plt.subplots(1, len(SPLITS), figsize=(11, 4), sharey=True)
        for ax, split in zip(axes, SPLITS):
            for v in self.cfg["variants"]:
                steps = {}
                with open(self.path("reports", split, v["name"], "per_step.csv"),
                          encoding="utf-8") as f:
                    for row in csv.DictReader(f):
                        if row["metric"] == "psnr" and row["mean"]:
                            steps.setdefault(row["rollout"], []).append(
                                (int(row["step"]), float(row["mean"])))
                for rollout in ["plain", "retrace"]:
                    xs, ys = zip(*sorted(steps.get(rollout, [(0, math.nan)])))
                    ax.plot(xs, ys, label=f"{v['name']} / {rollout}")
            ax.set_title(f"{split} policies")
            ax.set_xlabel("rollout step")
        axes[0].set_ylabel("PSNR (dB)")
        axes[0].legend()
        fig.tight_layout()
        tmp = self.path("ablation_horizon.tmp.png")
        fig.savefig(tmp, dpi=100, metadata={"Software": None})
        os.replace(tmp, self.path("ablation_horizon.png"))

    def manifest(self, started):
        entries = {}
        for v in self.cfg["variants"]:
            with open(self.path(v["name"], "dynamics", "checkpoint.json"), encoding="utf-8") as f:
                ckpt = json.load(f)
            entries[v["name"]] = {
                "checkpoint_sha256": sha256(self.path(v["name"], "dynamics", "checkpoint.wmt")),
                "config_hash": ckpt.get("config_hash"),
                "data": ckpt.get("data")}
        data = {split: sha256(self.path("shards", split, "index.json"))
                for split in ["train", *SPLITS]}
        manifest = {"config": self.cfg, "config_sha256": sha256(self.config_path),
                    "tokenizer_sha256": sha256(self.path("tokenizer", "checkpoint.wmt")),
                    "shard_index_sha256": data, "variants": entries,
                    "ablation_csv_sha256": sha256(self.path("ablation.csv")),
                    "wall_seconds_this_invocation": round(time.time() - started, 1)}
        write_atomically(self.path("manifest.json"), json.dumps(manifest, indent=2) + "\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default="build/bin")
    ap.add_argument("--config", default="configs/ablation/tiny.yaml")
    ap.add_argument("--out", default="data/ablation")
    args = ap.parse_args()
    started = time.time()
    a = Ablation(args)
    a.data()
    a.tokenizer()
    for variant in a.cfg["variants"]:
        a.dynamics(variant)
    for split in SPLITS:
        a.evaluate(split)
    table, episodes = a.summary_rows()
    a.write_csv(table, episodes)
    a.write_markdown(table, episodes)
    a.plot()
    a.manifest(started)
    print(open(a.path("ablation.md"), encoding="utf-8").read())
    print(f"ablation finished in {time.time() - started:.0f} s: {a.path('ablation.csv')}")


if __name__ == "__main__":
    main()
