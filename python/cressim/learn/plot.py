"""PNG plots of training curves and benchmark throughput (matplotlib, Agg: no display)."""
from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.ticker import EngFormatter  # noqa: E402


def _finite(history: list[dict], key: str) -> tuple[list, list]:
    """(env steps, values) of the updates where `key` is a number: an update in which no episode
    ended has NaN, and a line through NaNs breaks into unconnected pieces."""
    rows = [(h["env_steps"], h[key]) for h in history if isinstance(h.get(key), (int, float)) and math.isfinite(h[key])]
    return [r[0] for r in rows], [r[1] for r in rows]


def plot_training(history: list[dict], path: Path, title: str) -> Path:
    fig, (ax_len, ax_ret) = plt.subplots(1, 2, figsize=(10, 4))
    ax_len.plot(*_finite(history, "mean_length"), marker=".")
    ax_len.set(xlabel="env steps", ylabel="mean episode length", title=title)
    ax_ret.plot(*_finite(history, "mean_return"), color="tab:orange", marker=".")
    ax_ret.set(xlabel="env steps", ylabel="mean episode reward (return)")
    if any(h.get("terminated", 0) > 0 for h in history):  # tasks that end on success: how often they do
        ax_term = ax_len.twinx()
        ax_term.plot(*_finite(history, "terminated"), color="tab:green")
        ax_term.set_ylabel("share of episodes that terminated (success)", color="tab:green")
        ax_term.set_ylim(0, 1)
    for ax in (ax_len, ax_ret):
        ax.xaxis.set_major_formatter(EngFormatter())  # 800k, 100M: plain integers overlap
        ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def plot_throughput(series: dict[str, dict[int, float]], path: Path, title: str) -> Path:
    """series: label -> {num_envs: env-steps/s}, drawn log-log."""
    fig, ax = plt.subplots(figsize=(7, 5))
    for label, points in series.items():
        if points:
            envs = sorted(points)
            style = "o-" if label.startswith("ours") else "s--"
            ax.plot(envs, [points[n] for n in envs], style, label=label)
    ax.set(xscale="log", yscale="log", xlabel="envs", ylabel="env-steps/s", title=title)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
