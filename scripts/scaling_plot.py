"""scaling.png of `make scaling` (scripts/scaling.py) in the manner of Whale-X Fig. 5: training
loss curves per model size; final validation loss against dynamics parameters, one line per data
size; against training episodes, one line per model size; and the rollout MSE against parameters.
Each line carries its wm-metrics scaling fit, dashed out to the extrapolated sizes
(docs/scaling.md)."""
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after the backend is chosen)
import numpy as np  # noqa: E402

PNG_METADATA = {"Software": None}  # no matplotlib version in the file: same bytes across runs


def curve(fit, xs):
    """The fitted law at xs: a·x^-b, plus c for the power form."""
    return fit["a"] * np.power(xs, -fit["b"]) + (fit["c"] or 0.0)


def millions(n):
    return f"{n / 1e6:.2g}M"


def fitted_lines(ax, rows, fits, metric, against, held_key, label):
    """One line of points per held value, its fit drawn solid over the data, dashed beyond."""
    colours = plt.cm.viridis(np.linspace(0.0, 0.85, len(fits)))
    for colour, fit in zip(colours, fits):
        held = fit["held"][held_key]
        xs = np.array(fit["x"], dtype=float)
        ax.plot(xs, fit["y"], "o", color=colour, label=label(held, rows))
        inside = np.geomspace(xs.min(), xs.max(), 50)
        ax.plot(inside, curve(fit, inside), "-", color=colour, linewidth=1)
        far = [e["x"] for e in fit["extrapolation"]]
        if far:
            beyond = np.geomspace(xs.max(), max(far), 50)
            ax.plot(beyond, curve(fit, beyond), "--", color=colour, linewidth=1)
            ax.plot(far, [e["y"] for e in fit["extrapolation"]], "x", color=colour)
    ax.set_xscale("log")
    ax.set_ylabel(metric)
    ax.set_xlabel(against.replace("_", " "))
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)


def plot(path, rows, summary, curves):
    """`curves`: {size: [(step, token_ce)]} of the runs on the most data."""
    fits = {(f["metric"], f["against"]): [] for f in summary["fits"]}
    for f in summary["fits"]:
        fits[(f["metric"], f["against"])].append(f)
    params = {r["size"]: r["dynamics_parameters"] for r in rows}
    by_episodes = lambda n, _: f"{n} episodes"
    by_size = lambda s, _: f"{s} ({millions(params[s])})"

    fig, axes = plt.subplots(1, 4, figsize=(20, 4.6))
    colours = plt.cm.viridis(np.linspace(0.0, 0.85, len(curves)))
    for colour, (size, points) in zip(colours, curves.items()):
        steps, ce = np.array(points, dtype=float).T
        window = min(5, len(ce))
        smooth = np.convolve(ce, np.ones(window) / window, mode="valid")
        axes[0].plot(steps[window - 1:], smooth, color=colour, label=by_size(size, rows))
    axes[0].set_title(f"training token CE, {summary['train_episodes'][-1]} episodes")
    axes[0].set_xlabel("step")
    axes[0].set_ylabel(f"token CE (mean of {min(5, len(ce))} logged steps)")
    axes[0].grid(True, alpha=0.3)
    axes[0].legend(fontsize=7)

    fitted_lines(axes[1], rows, fits[("val_token_ce", "dynamics_parameters")], "val token CE",
                 "dynamics_parameters", "train_episodes", by_episodes)
    axes[1].set_title("final validation loss vs parameters")
    fitted_lines(axes[2], rows, fits[("val_token_ce", "train_episodes")], "val token CE",
                 "train_episodes", "size", by_size)
    axes[2].set_title("final validation loss vs data")
    fitted_lines(axes[3], rows, fits[("mse", "dynamics_parameters")], "rollout MSE",
                 "dynamics_parameters", "train_episodes", by_episodes)
    axes[3].axhline(summary["copy_last"]["mse"], color="grey", linestyle=":", label="copy_last")
    axes[3].legend(fontsize=7)
    axes[3].set_title("rollout MSE vs parameters (val, plain)")
    fig.suptitle(f"make scaling: {summary['form']} fits (solid), extrapolated (dashed, x); "
                 f"{summary['train_steps']} steps per run", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=90, metadata=PNG_METADATA)
    plt.close(fig)
