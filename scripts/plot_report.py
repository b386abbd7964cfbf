#!/usr/bin/python3
"""Plots of wm-eval report directories (docs/reports.md, "wm-report plot").

  plot_report.py --out DIR [--metrics psnr,ssim] [--rollout all] [--scaling-metric mse]
                 [--scaling-rollout plain] [--wm-metrics PATH] -- REPORT_DIR/<ckpt>...

Writes into DIR:
  step_<metric>.png   mean and 95% band vs horizon step per checkpoint x rollout (per_step.csv);
                      a baseline rollout (copy_last(_tokens), tokenizer_recon) whose curve is the same
                      for several checkpoints is drawn once
  values.png          real vs model value per policy, one panel per rollout (values.csv)
  scaling_<metric>_<rollout>.png, scaling_points.csv, scaling_fit.json
                      when two or more manifests carry "scale": the summary.csv mean of
                      --scaling-metric vs scale (log x), with the power law y = a x^-b + c that
                      `wm-metrics scaling --points scaling_points.csv --format json` fits
                      (needs --wm-metrics and 3 distinct scales; otherwise points only)

Usually run by `wm-report plot`, which finds this script and wm-metrics. Exit codes: 0 success,
1 bad input (the message names the file, line and column), 2 usage.
"""
import argparse
import csv
import json
import math
import os
import re
import subprocess
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after the backend is chosen)
import matplotlib.ticker  # noqa: E402
import numpy as np  # noqa: E402

ROLLOUT_ORDER = ["plain", "retrace", "copy_last", "copy_last_tokens", "tokenizer_recon"]
LINE_STYLES = {"plain": "-", "retrace": "--", "copy_last": ":", "copy_last_tokens": ":",
               "tokenizer_recon": "-."}
MARKERS = {"copy_last_tokens": "s"}  # dotted like copy_last, told apart by square markers
BASELINE_ROLLOUTS = {"copy_last", "copy_last_tokens", "tokenizer_recon"}
PNG_METADATA = {"Software": None}  # no matplotlib version in the file: same bytes across runs


class ReportError(Exception):
    """Bad input; the message names the file and, for a row, its line and column."""


def read_csv(path, columns):
    """Rows of `path` as (line, dict) with the `columns` required in the header."""
    if not os.path.isfile(path):
        raise ReportError(f"{path}: missing file (not a wm-eval report directory?)")
    with open(path, newline="", encoding="utf-8-sig") as f:
        reader = csv.reader(f)
        header = next(reader, None)
        if header is None:
            raise ReportError(f"{path}: empty file: expected a header row")
        header = [h.strip() for h in header]
        for c in columns:
            if c not in header:
                raise ReportError(f"{path}: line 1: missing column '{c}' "
                                  f"(the header has: {', '.join(header)})")
        rows = []
        for cells in reader:
            if not any(c.strip() for c in cells):
                continue
            if len(cells) != len(header):
                raise ReportError(f"{path}: line {reader.line_num}: {len(cells)} cells, but the "
                                  f"header has {len(header)} columns")
            rows.append((reader.line_num, dict(zip(header, (c.strip() for c in cells)))))
        return rows


def number(path, line, row, column, optional=True):
    """The cell as a float; NaN for an empty optional cell."""
    cell = row[column]
    if cell == "" and optional:
        return math.nan
    try:
        value = float(cell)
    except ValueError:
        value = None
    if value is None or not math.isfinite(value):
        raise ReportError(f"{path}: line {line}: column '{column}': '{cell}' is not a finite "
                          "number")
    return value


def rollout_rank(rollout):
    return (ROLLOUT_ORDER.index(rollout) if rollout in ROLLOUT_ORDER else len(ROLLOUT_ORDER),
            rollout)


def safe_name(text):
    return re.sub(r"[^A-Za-z0-9_.-]", "_", text)


class Report:
    """What the plots need from one report directory."""

    def __init__(self, path):
        self.dir = path
        manifest_path = os.path.join(path, "manifest.json")
        if not os.path.isfile(manifest_path):
            raise ReportError(f"{manifest_path}: missing file (not a wm-eval report directory?)")
        try:
            with open(manifest_path, encoding="utf-8") as f:
                self.manifest = json.load(f)
        except json.JSONDecodeError as e:
            raise ReportError(f"{manifest_path}: not valid JSON: {e}") from e
        name = (self.manifest.get("checkpoint") or {}).get("name") if isinstance(
            self.manifest, dict) else None
        if not isinstance(name, str) or not name:
            raise ReportError(f"{manifest_path}: key 'checkpoint.name': missing")
        self.name = name
        scale = self.manifest.get("scale")
        if scale is not None and (isinstance(scale, bool) or not isinstance(scale, (int, float))
                                  or not scale > 0):
            raise ReportError(f"{manifest_path}: key 'scale': expected a number > 0")
        self.scale = scale
        self.per_step = {}  # (rollout, metric) -> [(step, mean, ci_low, ci_high)]
        p = os.path.join(path, "per_step.csv")
        for line, row in read_csv(p, ["rollout", "step", "metric", "mean", "ci_low", "ci_high"]):
            try:
                step = int(row["step"])
            except ValueError:
                step = 0
            if step < 1:
                raise ReportError(f"{p}: line {line}: column 'step': '{row['step']}' is not a "
                                  "step >= 1")
            self.per_step.setdefault((row["rollout"], row["metric"]), []).append(
                (step, *(number(p, line, row, c) for c in ("mean", "ci_low", "ci_high"))))
        for points in self.per_step.values():
            points.sort()
        self.values = []  # (rollout, policy_id, real_value, model_value)
        p = os.path.join(path, "values.csv")
        for line, row in read_csv(p, ["rollout", "policy_id", "real_value", "model_value"]):
            self.values.append((row["rollout"], row["policy_id"],
                                number(p, line, row, "real_value"),
                                number(p, line, row, "model_value")))
        self.summary = {}  # (rollout, metric) -> mean
        p = os.path.join(path, "summary.csv")
        for line, row in read_csv(p, ["rollout", "metric", "mean"]):
            self.summary[(row["rollout"], row["metric"])] = number(p, line, row, "mean")


def wanted(rollout, choice):
    return choice == "all" or rollout == choice


def save(fig, path, written):
    fig.savefig(path, dpi=100, metadata=PNG_METADATA)
    plt.close(fig)
    written.append(path)


def plot_steps(reports, args, written):
    metrics = sorted({m for r in reports for (_, m) in r.per_step})
    if args.metrics:
        for m in args.metrics:
            if m not in metrics:
                raise ReportError(f"metric '{m}' is in no per_step.csv (they have: "
                                  f"{', '.join(metrics)})")
        metrics = args.metrics
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for metric in metrics:
        fig, ax = plt.subplots(figsize=(7, 4.5))
        drawn_baselines = {}
        for i, r in enumerate(reports):
            for rollout in sorted({ro for (ro, m) in r.per_step if m == metric}, key=rollout_rank):
                if not wanted(rollout, args.rollout):
                    continue
                points = r.per_step[(rollout, metric)]
                if rollout in BASELINE_ROLLOUTS:
                    if drawn_baselines.get(rollout) == points:
                        continue  # the same curve for another checkpoint: drawn once
                    drawn_baselines[rollout] = points
                step, mean, lo, hi = (np.array(c, dtype=float) for c in zip(*points))
                color = "0.4" if rollout in BASELINE_ROLLOUTS else colors[i % len(colors)]
                label = rollout if rollout in BASELINE_ROLLOUTS else f"{r.name} / {rollout}"
                ax.plot(step, mean, LINE_STYLES.get(rollout, "-"), color=color,
                        marker=MARKERS.get(rollout, "o"), markersize=3, label=label)
                if np.isfinite(lo).any():
                    ax.fill_between(step, lo, hi, color=color, alpha=0.15, linewidth=0)
        ax.set_xlabel("horizon step")
        ax.xaxis.set_major_locator(matplotlib.ticker.MaxNLocator(integer=True))
        ax.set_ylabel(metric)
        ax.set_title(f"{metric} vs horizon step (mean, 95% bootstrap band)")
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8)
        save(fig, os.path.join(args.out, f"step_{safe_name(metric)}.png"), written)


def plot_values(reports, args, written):
    rollouts = sorted({v[0] for r in reports for v in r.values if wanted(v[0], args.rollout)},
                      key=rollout_rank)
    if not rollouts:
        return
    fig, axes = plt.subplots(1, len(rollouts), figsize=(5 * len(rollouts), 4.8), squeeze=False)
    for ax, rollout in zip(axes[0], rollouts):
        everything = []
        for r in reports:
            pts = [(p, real, model) for ro, p, real, model in r.values
                   if ro == rollout and math.isfinite(real) and math.isfinite(model)]
            if not pts:
                continue
            ax.scatter([p[1] for p in pts], [p[2] for p in pts], label=r.name, s=30)
            for policy, real, model in pts:
                ax.annotate(policy, (real, model), fontsize=7, xytext=(3, 3),
                            textcoords="offset points")
            everything += [v for p in pts for v in p[1:]]
        if everything:
            lo, hi = min(everything), max(everything)
            pad = 0.05 * (hi - lo) if hi > lo else 0.5
            ax.plot([lo - pad, hi + pad], [lo - pad, hi + pad], "k:", linewidth=1, label="y = x")
        ax.set_xlabel("real value (mean return)")
        ax.set_ylabel("model value")
        ax.set_title(f"policy values, {rollout}")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    save(fig, os.path.join(args.out, "values.png"), written)


def fit_scaling(points_csv, wm_metrics):
    """The JSON of `wm-metrics scaling`, or (None, why not)."""
    if not wm_metrics:
        return None, "no wm-metrics given (--wm-metrics): fit skipped"
    p = subprocess.run([wm_metrics, "scaling", "--points", points_csv, "--format", "json"],
                       capture_output=True, text=True)
    if p.returncode != 0:
        lines = p.stderr.strip().splitlines()
        return None, "no fit: " + (lines[-1] if lines else f"wm-metrics exit {p.returncode}")
    return json.loads(p.stdout), None


def plot_scaling(reports, args, written):
    scaled = [r for r in reports if r.scale is not None]
    key = (args.scaling_rollout, args.scaling_metric)
    points = [(float(r.scale), r.summary[key], r.name) for r in scaled
              if math.isfinite(r.summary.get(key, math.nan))]
    if len(points) < 2:
        if scaled:
            print(f"plot_report.py: scaling plot skipped: {len(points)} report(s) have 'scale' "
                  f"and a {args.scaling_rollout} {args.scaling_metric} mean (need 2)",
                  file=sys.stderr)
        return
    points.sort()
    points_csv = os.path.join(args.out, "scaling_points.csv")
    with open(points_csv, "w", encoding="utf-8") as f:
        f.write("x,y,label\n")
        for x, y, label in points:
            f.write(f"{x:.9g},{y:.9g},{label}\n")
    written.append(points_csv)
    fit, why_not = fit_scaling(points_csv, args.wm_metrics)
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    xs = np.array([p[0] for p in points])
    ax.scatter(xs, [p[1] for p in points], zorder=3, label="checkpoints")
    for x, y, label in points:
        ax.annotate(label, (x, y), fontsize=7, xytext=(3, 3), textcoords="offset points")
    title = f"{args.scaling_metric} ({args.scaling_rollout}) vs scale"
    if fit is not None:
        fit_json = os.path.join(args.out, "scaling_fit.json")
        with open(fit_json, "w", encoding="utf-8") as f:
            json.dump(fit, f, indent=2, sort_keys=True)
            f.write("\n")
        written.append(fit_json)
        a, b = fit["parameters"]["a"]["value"], fit["parameters"]["b"]["value"]
        c = (fit["parameters"]["c"] or {}).get("value") or 0.0
        grid = np.geomspace(xs.min(), xs.max(), 200)
        curve = a * grid ** -b + c if fit["form"] == "power" else a * grid ** -b
        r2 = fit.get("r2")
        ax.plot(grid, curve, "C1-", label=f"y = {a:.3g} x^-{b:.3g} + {c:.3g}" +
                (f" (R² {r2:.3f})" if r2 is not None else ""))
    else:
        title += f"\n({why_not})"
        print(f"plot_report.py: {why_not}", file=sys.stderr)
    ax.set_xscale("log")
    ax.set_xlabel("scale (manifest.json 'scale': parameters or compute)")
    ax.set_ylabel(args.scaling_metric)
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    fig.tight_layout()
    name = f"scaling_{safe_name(args.scaling_metric)}_{safe_name(args.scaling_rollout)}.png"
    save(fig, os.path.join(args.out, name), written)


def main():
    parser = argparse.ArgumentParser(
        description=__doc__, epilog="Formats: docs/reports.md.",
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("reports", nargs="+", help="report directories REPORT_DIR/<checkpoint>")
    parser.add_argument("--out", required=True, help="directory for the PNGs")
    parser.add_argument("--metrics", type=lambda s: [m for m in s.split(",") if m],
                        help="comma-separated per-step metrics (default: all)")
    parser.add_argument("--rollout", default="all", help="rollout to draw, or all")
    parser.add_argument("--scaling-metric", default="mse",
                        help="summary.csv metric plotted against manifest 'scale' (default mse)")
    parser.add_argument("--scaling-rollout", default="plain",
                        help="rollout of the scaling plot (default plain)")
    parser.add_argument("--wm-metrics", default="", help="wm-metrics executable (scaling fit)")
    args = parser.parse_args()
    try:
        reports = [Report(d) for d in args.reports]
        os.makedirs(args.out, exist_ok=True)
        written = []
        plot_steps(reports, args, written)
        plot_values(reports, args, written)
        plot_scaling(reports, args, written)
    except (ReportError, OSError) as e:
        print(f"plot_report.py: error: {e}", file=sys.stderr)
        return 1
    for path in written:
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
