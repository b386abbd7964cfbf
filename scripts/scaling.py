#!/usr/bin/python3
"""`make scaling`: the dynamics model's final validation loss and rollout error against its size
and its training data (Whale-X Sec. 4.3, Fig. 5, issue 22) at CPU scale. One tokenizer, trained
once on the largest training set and frozen (every run sees the same tokens); the dynamics preset
at several widths and depths, each on several nested training sets (every smaller set is a
prefix of the larger, the same generator seed), all with the same steps and seed, validated and
evaluated on one validation set. The loss is fitted against parameters and episodes with
`wm-metrics scaling` and extrapolated. Drives the real executables; every stage is skipped when
its output exists and the trainers resume, so a killed run continues. docs/scaling.md.

  scripts/scaling.py --bin build/bin --config configs/scaling/tiny.yaml --out data/scaling
"""
import concurrent.futures
import csv
import io
import json
import math
import os
import resource
import struct
import sys
import time

import yaml

from pipeline_steps import ConfigError, ConfigKeys, Pipeline, load_yaml_config, run_output, \
    sha256, start, write_atomically
import scaling_plot

EVAL_METRICS = ["psnr", "mse", "mse_arm"]  # scaling.csv's evaluation columns (plain rollout)
FIT_METRICS = ["val_token_ce", "mse"]  # fitted: both fall as the model gets better
FILES = ["scaling.csv", "scaling_summary.json", "scaling.png", "scaling.md"]


def load_config(path):
    """The config, every key checked; a bad one is one line naming the file and the key."""
    cfg = load_yaml_config(path)
    keys = ConfigKeys(path, cfg)
    get, positive = keys.get, ConfigKeys.POSITIVE
    keys.seed_and_frames()
    get("data.look", str, lambda v: v in ("varied", "plain"), "varied or plain")
    get("data.seed", int, *ConfigKeys.NON_NEGATIVE)
    ascending = lambda v: len(v) >= 2 and all(isinstance(n, int) and not isinstance(n, bool) and
                                              n >= 1 for n in v) and v == sorted(set(v))
    get("data.train_episodes", list, ascending, "a list of >= 2 ascending integers >= 1")
    get("data.val_episodes", int, lambda v: v >= 2, "an integer >= 2 (intervals)")
    get("dynamics.sizes", list, lambda v: len(v) >= 2, "a list of >= 2 sizes")
    for i, size in enumerate(cfg["dynamics"]["sizes"]):
        if not isinstance(size, dict) or set(size) != {"d_model", "num_layers"}:
            raise ConfigError(f"{path}: key 'dynamics.sizes[{i}]': expected "
                              f"{{d_model, num_layers}}, got {size!r}")
        for k in ["d_model", "num_layers"]:
            if not isinstance(size[k], int) or isinstance(size[k], bool) or size[k] < 1:
                raise ConfigError(f"{path}: key 'dynamics.sizes[{i}].{k}': expected an integer "
                                  f">= 1, got {size[k]!r}")
    names = [size_name(s) for s in cfg["dynamics"]["sizes"]]
    if len(set(names)) != len(names):
        raise ConfigError(f"{path}: key 'dynamics.sizes': a size is listed twice")
    for key in ["tokenizer.steps", "dynamics.steps", "dynamics.val_batches", "dynamics.threads",
                "dynamics.jobs", "eval.horizon", "eval.resamples"]:
        get(key, int, *positive)
    get("fit.form", str, lambda v: v in ("loglinear", "power"), "loglinear or power")
    for key in ["fit.extrapolate_parameters", "fit.extrapolate_episodes"]:
        get(key, list, lambda v: all(isinstance(x, (int, float)) and x > 0 for x in v),
            "a list of numbers > 0")
    for key in ["tokenizer.config", "dynamics.config"]:
        keys.existing_file(key)
    return cfg


def size_name(size):
    return f"d{size['d_model']}_l{size['num_layers']}"


def data_name(episodes):
    return f"n{episodes}"


def parameter_counts(safetensors_path):
    """(dynamics, total) parameter counts from an exported checkpoint's safetensors header: the
    model's own tensors, so the count is the model's, not a formula's."""
    with open(safetensors_path, "rb") as f:
        header = json.loads(f.read(struct.unpack("<Q", f.read(8))[0]))
    counts = {}
    for name, tensor in header.items():
        if name != "__metadata__":
            part = name.split(".")[0]
            counts[part] = counts.get(part, 0) + math.prod(tensor["shape"])
    return counts.get("dynamics", 0), sum(counts.values())


def final_validation(metrics_csv):
    """(step, val_token_ce, val_token_acc) of the last validation row of a run's metrics.csv."""
    last = None
    with open(metrics_csv, encoding="utf-8") as f:
        for row in csv.DictReader(f):
            if row["val_token_ce"]:
                last = row
    if last is None:
        sys.exit(f"scaling: {metrics_csv} has no validation row")
    return int(last["step"]), float(last["val_token_ce"]), float(last["val_token_acc"])


def training_curve(metrics_csv):
    """[(step, token_ce)] of every logged training row (the validation rows repeat a step)."""
    seen, curve = set(), []
    with open(metrics_csv, encoding="utf-8") as f:
        for row in csv.DictReader(f):
            if row["step"] not in seen:
                seen.add(row["step"])
                curve.append((int(row["step"]), float(row["token_ce"])))
    return curve


class Scaling(Pipeline):
    def __init__(self, args):
        super().__init__(args, "scaling", load_config)
        self.sizes = [size_name(s) for s in self.cfg["dynamics"]["sizes"]]
        self.episodes = self.cfg["data"]["train_episodes"]

    def cells(self):
        """(size, episodes) of every run, the costliest first so parallel jobs end together."""
        cost = {size_name(s): s["d_model"] ** 2 * s["num_layers"]
                for s in self.cfg["dynamics"]["sizes"]}
        return sorted(((s, n) for s in self.sizes for n in self.episodes),
                      key=lambda c: (-cost[c[0]], -c[1]))

    def run_dir(self, size, episodes):
        return self.path("runs", size, data_name(episodes))

    def data(self):
        """One generation per data size, same seed: episode k is the same in all of them
        (docs/tabletop.md), so each training set is a prefix of the next and the validation set
        is the same; the largest generation's val split is the one used."""
        d = self.cfg["data"]
        for n in self.episodes:
            raw = os.path.join("raw", data_name(n))
            self.generate(raw, d["size"], d["policies"], n, d["val_episodes"], d["seed"],
                          d["look"])
            self.ingest(raw, "train", f"train_{data_name(n)}")
        self.ingest(os.path.join("raw", data_name(self.episodes[-1])), "val", "val")

    def tokenizer(self):
        """Trained once, on the largest training set, then frozen: every split is encoded with
        it (Whale-X froze the tokenizer in its scaling study)."""
        t, largest = self.cfg["tokenizer"], f"train_{data_name(self.episodes[-1])}"
        self.train_tokenizer(t["config"], t["steps"], self.cfg["seed"], largest, "val")
        for split in [*(f"train_{data_name(n)}" for n in self.episodes), "val"]:
            self.encode(split)

    def dynamics_configs(self):
        """configs/<size>.yaml: the base preset with the size's width and depth and the sweep's
        validation batches; nothing else changes between sizes."""
        d = self.cfg["dynamics"]
        with open(d["config"], encoding="utf-8") as f:
            base = yaml.safe_load(f)
        os.makedirs(self.path("configs"), exist_ok=True)
        for size in d["sizes"]:
            config = yaml.safe_load(yaml.safe_dump(base))
            config["model"].update(size)
            config["train"]["val_batches"] = d["val_batches"]
            write_atomically(self.path("configs", size_name(size) + ".yaml"),
                             yaml.safe_dump(config, sort_keys=True))

    def train_cell(self, cell):
        size, n = cell
        d = self.cfg["dynamics"]
        self.train_dynamics(self.run_dir(size, n), self.path("configs", size + ".yaml"),
                            f"train_{data_name(n)}", "val", d["steps"], self.cfg["seed"],
                            d["threads"], log=self.path("runs", f"{size}_{data_name(n)}.log"))

    def train_all(self):
        self.dynamics_configs()
        os.makedirs(self.path("runs"), exist_ok=True)
        with concurrent.futures.ThreadPoolExecutor(self.cfg["dynamics"]["jobs"]) as pool:
            for future in [pool.submit(self.train_cell, c) for c in self.cells()]:
                future.result()  # a failed run stops the script (its SystemExit re-raised)

    def evaluate_all(self):
        e, cells = self.cfg["eval"], sorted(self.cells())
        self.evaluate("reports", [f"{s}_{data_name(n)}" for s, n in cells],
                      [self.run_dir(s, n) for s, n in cells], "val", e["horizon"],
                      self.cfg["seed"], e["resamples"], 0, self.cfg["dynamics"]["threads"])

    def report_means(self, name):
        """rollout -> metric -> (mean, ci_low, ci_high, n) of one report's summary.csv."""
        out = {}
        with open(self.path("reports", name, "summary.csv"), encoding="utf-8") as f:
            for r in csv.DictReader(f):
                out.setdefault(r["rollout"], {})[r["metric"]] = (
                    r["mean"], r["ci_low"], r["ci_high"], r["n"])
        return out

    def count_parameters(self, size, n):
        exported = self.path("runs", f"{size}_{data_name(n)}.safetensors")
        self.tool("wm-checkpoint", "export", "--checkpoint", self.run_dir(size, n), "--out",
                  exported)
        counts = parameter_counts(exported)
        os.remove(exported)
        return counts

    def rows(self):
        """scaling.csv's rows, size-major, as dicts of strings and numbers."""
        rows, steps = [], self.cfg["dynamics"]["steps"]
        for spec in self.cfg["dynamics"]["sizes"]:
            size = size_name(spec)
            for n in self.episodes:
                run_dir = self.run_dir(size, n)
                step, ce, acc = final_validation(os.path.join(run_dir, "metrics.csv"))
                if step != steps:
                    sys.exit(f"scaling: {run_dir} ended at step {step}, not {steps}")
                dyn, total = self.count_parameters(size, n)
                means = self.report_means(f"{size}_{data_name(n)}")["plain"]
                row = {"size": size, "d_model": spec["d_model"], "num_layers": spec["num_layers"],
                       "dynamics_parameters": dyn, "total_parameters": total,
                       "train_episodes": n, "train_steps": steps, "val_token_ce": ce,
                       "val_token_acc": acc, "n_episodes": int(means["psnr"][3])}
                for m in EVAL_METRICS:
                    for suffix, value in zip(["", "_ci_low", "_ci_high"], means[m][:3]):
                        row[m + suffix] = float(value) if value else None
                row["checkpoint_sha256"] = sha256(os.path.join(run_dir, "checkpoint.wmt"))
                rows.append(row)
        return rows

    def fit(self, name, points, extrapolate):
        """wm-metrics scaling on `points` [(x, y, label)] -> its JSON, kept in fits/<name>.json."""
        os.makedirs(self.path("fits"), exist_ok=True)
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(["x", "y", "label"])
        w.writerows(points)
        points_csv = self.path("fits", name + ".points.csv")
        write_atomically(points_csv, buf.getvalue())
        out = run_output([os.path.join(self.bin, "wm-metrics"), "scaling", "--points", points_csv,
                          "--form", self.cfg["fit"]["form"], "--extrapolate",
                          ",".join(repr(float(x)) for x in extrapolate), "--format", "json"],
                         self.log, self.who)
        write_atomically(self.path("fits", name + ".json"), out)
        return json.loads(out)

    def fits(self, rows):
        """Every metric against dynamics parameters at each data size, and against training
        episodes at each model size."""
        f, fits = self.cfg["fit"], []
        for metric in FIT_METRICS:
            for n in self.episodes:
                cut = [r for r in rows if r["train_episodes"] == n]
                fits.append(self.fit_entry(f"{metric}_vs_parameters_{data_name(n)}", metric,
                                           "dynamics_parameters", {"train_episodes": n}, cut,
                                           f["extrapolate_parameters"]))
            for size in self.sizes:
                cut = [r for r in rows if r["size"] == size]
                fits.append(self.fit_entry(f"{metric}_vs_episodes_{size}", metric,
                                           "train_episodes", {"size": size}, cut,
                                           f["extrapolate_episodes"]))
        return fits

    def fit_entry(self, name, metric, against, held, rows, extrapolate):
        rows = sorted(rows, key=lambda r: r[against])
        xs, ys = [r[against] for r in rows], [r[metric] for r in rows]
        fit = self.fit(name, [(x, y, f"{r['size']}_{data_name(r['train_episodes'])}")
                              for x, y, r in zip(xs, ys, rows)], extrapolate)
        p = fit["parameters"]
        return {"name": name, "metric": metric, "against": against, "held": held, "x": xs,
                "y": ys, "change": (ys[-1] - ys[0]) / ys[0],
                "falls_monotonically": all(b < a for a, b in zip(ys, ys[1:])),
                # + 0.0: no negative zero in the JSON
                "a": p["a"]["value"], "b": p["b"]["value"] + 0.0,
                "b_std_error": p["b"]["std_error"],
                "c": p["c"]["value"] if p.get("c") else None, "r2": fit["r2"],
                "converged": fit["converged"],
                "extrapolation": [{k: e[k] for k in ("x", "y", "std_error")}
                                  for e in fit["extrapolation"]],
                "file": f"fits/{name}.json"}

    def write_csv(self, rows):
        buf = io.StringIO()
        w = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
        w.writeheader()
        for r in rows:
            w.writerow({k: "" if v is None else v for k, v in r.items()})
        write_atomically(self.path("scaling.csv"), buf.getvalue())

    def summary(self, rows, fits):
        """scaling_summary.json: the sweep, copy_last for scale, every fit, and the two headline
        changes: the largest model against the smallest on the most data, and the most data
        against the least for the largest model."""
        copy_last = self.report_means(f"{self.sizes[0]}_{data_name(self.episodes[0])}")
        by_name = {f["name"]: f for f in fits}
        largest_n, largest_size = data_name(self.episodes[-1]), self.sizes[-1]
        summary = {
            "format": "wmkit-scaling-summary", "format_version": 1,
            "seed": self.cfg["seed"], "train_steps": self.cfg["dynamics"]["steps"],
            "form": self.cfg["fit"]["form"],
            "sizes": [{k: r[k] for k in ("size", "d_model", "num_layers", "dynamics_parameters",
                                         "total_parameters")}
                      for r in rows if r["train_episodes"] == self.episodes[0]],
            "train_episodes": self.episodes,
            "val_episodes": rows[0]["n_episodes"],
            "copy_last": {m: float(copy_last["copy_last"][m][0]) for m in EVAL_METRICS},
            "headline": {},
            "fits": fits}
        for metric in FIT_METRICS:
            for key, fit in [("vs_parameters", by_name[f"{metric}_vs_parameters_{largest_n}"]),
                             ("vs_episodes", by_name[f"{metric}_vs_episodes_{largest_size}"])]:
                summary["headline"][f"{metric}_{key}"] = {
                    k: fit[k] for k in ("name", "held", "change", "falls_monotonically", "b",
                                        "b_std_error")}
        write_atomically(self.path("scaling_summary.json"), json.dumps(summary, indent=2) + "\n")
        return summary

    def curves(self):
        """{size: [(step, token_ce)]} of the runs on the most data, for the plot."""
        return {s: training_curve(os.path.join(self.run_dir(s, self.episodes[-1]), "metrics.csv"))
                for s in self.sizes}

    def manifest(self, started):
        runs = {}
        for size, n in sorted(self.cells()):
            with open(os.path.join(self.run_dir(size, n), "checkpoint.json"),
                      encoding="utf-8") as f:
                ckpt = json.load(f)
            runs[f"{size}_{data_name(n)}"] = {
                "checkpoint_sha256": sha256(os.path.join(self.run_dir(size, n), "checkpoint.wmt")),
                "config_hash": ckpt.get("config_hash"), "step": ckpt.get("step"),
                "data": ckpt.get("data")}
        with open(self.path("tokenizer", "checkpoint.json"), encoding="utf-8") as f:
            git_commit = json.load(f).get("git_commit")
        splits = [*(f"train_{data_name(n)}" for n in self.episodes), "val"]
        children = resource.getrusage(resource.RUSAGE_CHILDREN)
        manifest = {
            "format": "wmkit-scaling-manifest", "format_version": 1,
            "config": self.cfg, "config_sha256": sha256(self.config_path),
            "git_commit": git_commit,
            "tokenizer_sha256": sha256(self.path("tokenizer", "checkpoint.wmt")),
            "shard_index_sha256": {s: sha256(self.path("shards", s, "index.json"))
                                   for s in splits},
            "dynamics_configs": {s: sha256(self.path("configs", s + ".yaml"))
                                 for s in self.sizes},
            "runs": runs,
            "reports": {name: sha256(self.path("reports", name, "manifest.json"))
                        for name in runs},
            "files": {f: sha256(self.path(f)) for f in FILES},
            "stage_seconds_this_invocation": self.stage_seconds,
            "wall_seconds_this_invocation": round(time.time() - started, 1),
            "cpu_seconds_this_invocation": round(children.ru_utime + children.ru_stime, 1)}
        write_atomically(self.path("manifest.json"), json.dumps(manifest, indent=2) + "\n")


def markdown(rows, summary):
    """The README's table: one row per run, then the headline changes and exponents."""
    out = ["| size | dynamics params | episodes | val token CE | val token acc | psnr | mse "
           "| mse_arm |", "|---|---|---|---|---|---|---|---|"]
    ci = lambda r, m: f"{r[m]:.4g} [{r[m + '_ci_low']:.4g}, {r[m + '_ci_high']:.4g}]"
    for r in rows:
        out.append(f"| {r['size']} | {r['dynamics_parameters']} | {r['train_episodes']} | "
                   f"{r['val_token_ce']:.4f} | {r['val_token_acc']:.4f} | {ci(r, 'psnr')} | "
                   f"{ci(r, 'mse')} | {ci(r, 'mse_arm')} |")
    c = summary["copy_last"]
    out += ["", f"copy_last: psnr {c['psnr']:.4g}, mse {c['mse']:.4g}, "
                f"mse_arm {c['mse_arm']:.4g}", "",
            "| fit | change first -> last | falls monotonically | b ± s.e. | r2 | extrapolated |",
            "|---|---|---|---|---|---|"]
    for f in summary["fits"]:
        se = "" if f["b_std_error"] is None else f" ± {f['b_std_error']:.3g}"
        r2 = "" if f["r2"] is None else f"{f['r2']:.3f}"
        extra = ", ".join(f"{e['x']:.3g}: {e['y']:.4g}" + (
            "" if e["std_error"] is None else f" ± {e['std_error']:.2g}")
            for e in f["extrapolation"])
        out.append(f"| {f['name']} | {100 * f['change']:+.2f}% | {f['falls_monotonically']} | "
                   f"{f['b']:.3g}{se} | {r2} | {extra} |")
    return "\n".join(out) + "\n"


def main():
    s, started = start(__doc__, Scaling, "scaling")
    s.timed("data", s.data)
    s.timed("tokenizer", s.tokenizer)
    s.timed("dynamics", s.train_all)
    s.timed("evaluate", s.evaluate_all)
    rows = s.rows()
    s.write_csv(rows)
    summary = s.summary(rows, s.fits(rows))
    scaling_plot.plot(s.path("scaling.png"), rows, summary, s.curves())
    table = markdown(rows, summary)
    write_atomically(s.path("scaling.md"), table)
    s.manifest(started)
    print(table)
    print(f"scaling finished in {time.time() - started:.0f} s: {s.path('scaling.csv')}")


if __name__ == "__main__":
    main()
