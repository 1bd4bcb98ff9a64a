"""The paper's observations as checks at reduced scale, each a figure built from the MCAP logs of the runs.

* O1 (:func:`plot_o1`): on-policy (MT-PPO, MT-GRPO) vs off-policy (MT-SAC, MT-PQN): success against wall-clock
  and against frames (paper Figure ``fig:efficiency``).
* O3 (:func:`plot_o3`): actor vs critic task-gradient conflict: the mean pairwise cosine similarity of per-task
  gradients with its min-max band, from the ``train/grad_cos_{actor,critic}_{mean,min,max}`` diagnostics the
  trainer logs with ``grad.diagnostics_every`` (paper Figure ``fig:cosine_sim``).
* O4 (:func:`plot_o4`): curriculum vs no curriculum: final Parkour progress on hard and hard-CL per variant
  (paper Table 2, columns 2 and 3).

Every function returns a small summary (the numbers behind the check) and writes one PNG.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from .results import COSINE_KEYS, SUCCESS_KEY, RunResult, align_curves
from .stats import Estimate, curve_intervals, interval_estimates

__all__ = ["plot_curves", "plot_o1", "plot_o3", "plot_o4", "cosine_summary"]


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _band(ax, runs: Sequence[RunResult], key: str, label: str, *, x: str = "frames", scale: float = 100.0,
          x_scale: float = 1.0, reps: int = 2000, color=None) -> bool:
    grid, values = align_curves(list(runs), key, x=x)
    if values.size == 0:
        return False
    mean, lo, hi = curve_intervals(values, reps=reps)
    line, = ax.plot(grid / x_scale, mean * scale, label=f"{label} (n={len(values)})", linewidth=1.4, color=color)
    ax.fill_between(grid / x_scale, lo * scale, hi * scale, alpha=0.25, color=line.get_color(), linewidth=0)
    return True


def plot_curves(groups: Mapping[str, Sequence[RunResult]], path: Path, *, title: str, ylabel: str,
                key: str = SUCCESS_KEY, reps: int = 2000) -> Path | None:
    """Learning curves (``key`` x 100 vs frames) of each group: pointwise mean over seeds with its 95 % bootstrap
    band. ``None`` when no group has data."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(8, 4.8))
    cmap = plt.get_cmap("tab10" if len(groups) <= 10 else "tab20")
    drawn = 0
    for i, (label, runs) in enumerate(groups.items()):
        drawn += _band(ax, runs, key, label, reps=reps, color=cmap(i % cmap.N))
    if not drawn:
        plt.close(fig)
        return None
    ax.set(xlabel="frames", ylabel=ylabel, title=title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize="x-small", loc="center left", bbox_to_anchor=(1.01, 0.5))
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_o1(groups: Mapping[str, Sequence[RunResult]], path: Path, *, title: str,
            reps: int = 2000) -> dict[str, dict[str, float]]:
    """O1: success vs wall-clock (minutes of training) and vs frames for each algorithm with runs.

    Returns per algorithm ``{"frames", "minutes", "success", "frames_per_s"}`` (means over seeds at the end of the
    runs); an empty dict (and no PNG) when no algorithm has runs."""
    plt = _plt()
    summary: dict[str, dict[str, float]] = {}
    fig, (ax_t, ax_f) = plt.subplots(1, 2, figsize=(11, 4.2))
    for label, runs in groups.items():
        runs = [r for r in runs if r.has(SUCCESS_KEY)]
        if not runs:
            continue
        drawn = _band(ax_t, runs, SUCCESS_KEY, label, x="seconds", x_scale=60.0, reps=reps)
        _band(ax_f, runs, SUCCESS_KEY, label, reps=reps, color=ax_t.get_lines()[-1].get_color() if drawn else None)
        minutes = [r.wallclock[1][-1] / 60.0 for r in runs if len(r.wallclock[1])]
        frames = [r.frames for r in runs]
        summary[label] = {
            "frames": float(np.mean(frames)),
            "minutes": float(np.mean(minutes)) if minutes else math.nan,
            "success": float(np.mean([r.final(SUCCESS_KEY) for r in runs]) * 100.0),
            "frames_per_s": float(np.mean(frames) / (np.mean(minutes) * 60.0)) if minutes and np.mean(minutes) else
            math.nan,
        }
    if not summary:
        plt.close(fig)
        return summary
    ax_t.set(xlabel="training wall-clock (minutes)", ylabel="success rate (%)", title=f"{title}: vs wall-clock")
    ax_f.set(xlabel="frames", ylabel="success rate (%)", title=f"{title}: vs frames")
    for ax in (ax_t, ax_f):
        ax.grid(alpha=0.3)
        ax.legend(fontsize="small")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return summary


def cosine_summary(runs: Sequence[RunResult]) -> dict[str, float] | None:
    """Time averages (over all logged iterations, then over seeds) of the actor and critic task-gradient cosine
    mean / min / max; ``None`` when the runs logged no diagnostics."""
    runs = [r for r in runs if all(r.has(k) for k in COSINE_KEYS)]
    if not runs:
        return None
    out = {}
    for key in COSINE_KEYS:
        out[key.split("grad_cos_")[1]] = float(np.mean([np.mean(r.series(key)[1]) for r in runs]))
    out["seeds"] = float(len(runs))
    return out


def plot_o3(groups: Mapping[str, Sequence[RunResult]], path: Path, *, title: str) -> dict[str, dict[str, float]]:
    """O3: per group with diagnostics, actor and critic cosine similarity (mean over seeds of the pairwise mean,
    band = mean over seeds of the pairwise min and max) vs frames. Returns :func:`cosine_summary` per group."""
    plt = _plt()
    summaries = {label: s for label, runs in groups.items() if (s := cosine_summary(runs)) is not None}
    if not summaries:
        return {}
    n = len(summaries)
    fig, axes = plt.subplots(1, n, figsize=(5.2 * n, 4), squeeze=False)
    for ax, label in zip(axes[0], summaries):
        runs = [r for r in groups[label] if all(r.has(k) for k in COSINE_KEYS)]
        for role, color in (("actor", "tab:blue"), ("critic", "tab:red")):
            grid, mean = align_curves(runs, f"train/grad_cos_{role}_mean", num_points=200)
            _, low = align_curves(runs, f"train/grad_cos_{role}_min", num_points=200)
            _, high = align_curves(runs, f"train/grad_cos_{role}_max", num_points=200)
            ax.plot(grid, mean.mean(axis=0), color=color, label=f"{role} mean")
            ax.fill_between(grid, low.mean(axis=0), high.mean(axis=0), color=color, alpha=0.2, linewidth=0,
                            label=f"{role} min-max")
        ax.axhline(0.0, color="k", linewidth=0.6)
        ax.set(xlabel="frames", ylabel="pairwise cosine of task gradients", title=f"{label} (n={len(runs)})")
        ax.grid(alpha=0.3)
        ax.legend(fontsize="x-small")
    fig.suptitle(title)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return summaries


def plot_o4(pairs: Mapping[str, tuple[Sequence[RunResult], Sequence[RunResult]]], path: Path, *, title: str,
            reps: int = 10_000) -> dict[str, dict[str, Estimate]]:
    """O4: final progress (%) on Parkour-hard vs Parkour-hard-CL per variant with 95 % bootstrap CIs.

    ``pairs``: variant label -> (hard runs, hard-CL runs). Returns ``{label: {"hard": Estimate, "hard_cl":
    Estimate}}`` for the variants with runs in both settings."""
    plt = _plt()
    results: dict[str, dict[str, Estimate]] = {}
    for label, (hard, hard_cl) in pairs.items():
        a = [r.final(SUCCESS_KEY) * 100 for r in hard if math.isfinite(r.final(SUCCESS_KEY))]
        b = [r.final(SUCCESS_KEY) * 100 for r in hard_cl if math.isfinite(r.final(SUCCESS_KEY))]
        if a and b:
            results[label] = {"hard": interval_estimates(np.asarray(a), reps=reps)["mean"],
                              "hard_cl": interval_estimates(np.asarray(b), reps=reps)["mean"]}
    if not results:
        return results
    fig, ax = plt.subplots(figsize=(max(5.0, 1.2 * len(results) + 2), 4))
    xs = np.arange(len(results))
    for offset, setting, color in ((-0.2, "hard", "tab:gray"), (0.2, "hard_cl", "tab:green")):
        est = [results[label][setting] for label in results]
        ax.bar(xs + offset, [e.value for e in est], width=0.38, color=color,
               label="Parkour-hard" if setting == "hard" else "Parkour-hard-CL (curriculum)",
               yerr=np.array([[e.value - e.lo for e in est], [e.hi - e.value for e in est]]), capsize=3)
    ax.set_xticks(xs, list(results), rotation=20, ha="right")
    ax.set(ylabel="final progress (%)", title=title)
    ax.grid(alpha=0.3, axis="y")
    ax.legend(fontsize="small")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return results
