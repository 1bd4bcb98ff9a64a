"""Summarize an mtbench MCAP run and plot its learning curves.

Usage::

    python -m mtbench.logs RUN.mcap [--out DIR] [--last N]

``RUN.mcap`` may also be a directory holding the segment files of one run. Prints a table of every scalar
(last value, mean of the last N points, max, number of points), then a per-task table built from the
scalars ``success/<task>`` and ``return/<task>`` plus the mean over tasks, and writes PNG learning curves:
``success_mean.png`` (``success/mean`` vs frames), ``success_per_task.png``, one ``loss_<group>.png`` per
loss group and, for a Parkour curriculum run (``terrain_level/<task>`` scalars), ``terrain_level.png`` (mean
terrain level per task and over tasks). The x axis is the scalar ``frames`` logged at the same step when present
(interpolated over steps for scalars logged at other steps), else the step; ``--frames-offset N`` adds N to it
(e.g. the frames of a flat pre-training stage that came before the run). No torch import.
"""

from __future__ import annotations

import argparse
import math
import re
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from mtbench.logging.reader import find_segments, read_scalars

__all__ = ["loss_groups", "main", "plot_run", "scalar_summary", "task_table"]

Series = list[tuple[int, float]]
# words users type as a subcommand (the CLI has none: the run path comes first)
_NOT_SUBCOMMANDS = ("summary", "plot", "plots")


def _finite(values: Sequence[float]) -> list[float]:
    return [v for v in values if math.isfinite(v)]


def _mean(values: Sequence[float]) -> float:
    finite = _finite(values)
    return sum(finite) / len(finite) if finite else math.nan


def _fmt(value: float | int | str) -> str:
    if isinstance(value, str):
        return value
    if isinstance(value, int) or (math.isfinite(value) and value.is_integer() and abs(value) < 1e15):
        return str(int(value))
    return f"{value:.6g}"


def _table(header: Sequence[str], rows: Sequence[Sequence[float | int | str]]) -> str:
    cells = [list(header)] + [[_fmt(c) for c in row] for row in rows]
    widths = [max(len(row[i]) for row in cells) for i in range(len(header))]
    lines = []
    for n, row in enumerate(cells):
        first = row[0].ljust(widths[0])
        rest = [c.rjust(w) for c, w in zip(row[1:], widths[1:], strict=True)]
        lines.append("  ".join([first, *rest]))
        if n == 0:
            lines.append("  ".join("-" * w for w in widths))
    return "\n".join(lines)


def scalar_summary(scalars: dict[str, Series], last: int) -> list[tuple[str, float, float, float, int]]:
    """Rows ``(name, last value, mean of the last ``last`` points, max, points)``; mean/max skip non-finite."""
    rows = []
    for name, points in sorted(scalars.items()):
        values = [v for _, v in points]
        finite = _finite(values)
        rows.append((name, values[-1], _mean(values[-last:]), max(finite) if finite else math.nan, len(values)))
    return rows


def _task_names(scalars: dict[str, Series]) -> list[str]:
    tasks = set()
    for name in scalars:
        for prefix in ("success/", "return/"):
            if name.startswith(prefix) and name != f"{prefix}mean" and len(name) > len(prefix):
                tasks.add(name[len(prefix) :])
    return sorted(tasks)


def task_table(scalars: dict[str, Series], last: int) -> list[tuple[str, float, float, float, float]]:
    """Rows ``(task, success last, success mean last N, return last, return mean last N)`` sorted by task,
    followed by a ``mean`` row (mean over tasks of each column, non-finite entries skipped). Empty if no task."""
    rows: list[tuple[str, float, float, float, float]] = []
    for task in _task_names(scalars):
        row: list[float] = []
        for prefix in ("success/", "return/"):
            values = [v for _, v in scalars.get(f"{prefix}{task}", [])]
            row += [values[-1], _mean(values[-last:])] if values else [math.nan, math.nan]
        rows.append((task, *row))  # type: ignore[arg-type]
    if rows:
        columns = list(zip(*[r[1:] for r in rows], strict=True))
        rows.append(("mean", *[_mean(col) for col in columns]))  # type: ignore[arg-type]
    return rows


def loss_groups(scalars: dict[str, Series]) -> dict[str, list[str]]:
    """Loss scalars grouped by the component after ``loss/`` (``loss/critic/q1`` -> ``critic``) or ``loss_``
    (``loss_actor`` -> ``actor``)."""
    groups: dict[str, list[str]] = {}
    for name in sorted(scalars):
        if name.startswith("loss/") and len(name) > 5:
            group = name[5:].split("/", 1)[0]
        elif name.startswith("loss_") and len(name) > 5:
            group = name[5:]
        else:
            continue
        groups.setdefault(group, []).append(name)
    return groups


def _x_axis(scalars: dict[str, Series], frames_offset: float = 0.0
            ) -> tuple[str, Callable[[Sequence[int]], np.ndarray]]:
    """``(label, steps -> x)``: ``frames_offset`` + frames when a ``frames`` scalar exists, else the identity on
    steps."""
    frames = scalars.get("frames")
    if not frames:
        return "step", lambda steps: np.asarray(steps, dtype=np.float64)
    exact = {s: v + frames_offset for s, v in frames}
    fs = np.asarray(sorted(exact), dtype=np.float64)
    fv = np.asarray([exact[s] for s in sorted(exact)], dtype=np.float64)

    def to_frames(steps: Sequence[int]) -> np.ndarray:
        return np.asarray(
            [exact[s] if s in exact else float(np.interp(s, fs, fv)) for s in steps], dtype=np.float64
        )

    return ("frames" if not frames_offset else f"frames (including {frames_offset:,.0f} before this run)"), to_frames


def _safe_filename(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text).strip("_") or "unnamed"


def plot_run(scalars: dict[str, Series], out_dir: Path, *, title: str = "", frames_offset: float = 0.0) -> list[Path]:
    """Write the learning-curve PNGs into ``out_dir`` and return their paths (figures without data are skipped).
    ``frames_offset`` is added to the frames axis."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    xlabel, to_x = _x_axis(scalars, frames_offset)
    written: list[Path] = []

    def save(fig: plt.Figure, name: str) -> None:
        path = out_dir / name
        fig.tight_layout()
        fig.savefig(path, dpi=110)
        plt.close(fig)
        written.append(path)

    def curve(ax: plt.Axes, points: Series, label: str) -> None:
        steps = [s for s, _ in points]
        ax.plot(to_x(steps), [v for _, v in points], label=label, linewidth=1.2)

    tasks = [t for t in _task_names(scalars) if f"success/{t}" in scalars]
    mean_points = scalars.get("success/mean")
    mean_label = "success/mean"
    if not mean_points and tasks:  # derive the mean at the steps where every task has a value
        per_task = [dict(scalars[f"success/{t}"]) for t in tasks]
        common = sorted(set.intersection(*[set(d) for d in per_task]))
        mean_points = [(s, _mean([d[s] for d in per_task])) for s in common]
        mean_label = "mean of success/<task>"
    if mean_points:
        fig, ax = plt.subplots(figsize=(7, 4))
        curve(ax, mean_points, mean_label)
        ax.set(xlabel=xlabel, ylabel="success rate", title=f"{title} {mean_label}".strip())
        ax.grid(alpha=0.3)
        save(fig, "success_mean.png")

    def per_task_figure(prefix: str, ylabel: str, what: str, name: str, mean_line: bool) -> None:
        """One curve of ``<prefix>/<task>`` per task (with ``mean_line``, ``<prefix>/mean`` in black if logged)."""
        names = [t for t in _task_names(scalars) if f"{prefix}/{t}" in scalars]
        if not names:
            return
        fig, ax = plt.subplots(figsize=(9, 5))
        for task in names:
            curve(ax, scalars[f"{prefix}/{task}"], task)
        if mean_line and scalars.get(f"{prefix}/mean"):
            steps = [s for s, _ in scalars[f"{prefix}/mean"]]
            ax.plot(to_x(steps), [v for _, v in scalars[f"{prefix}/mean"]], color="black", linewidth=2.5,
                    label="mean")
        ax.set(xlabel=xlabel, ylabel=ylabel, title=f"{title} {what}".strip())
        ax.grid(alpha=0.3)
        ax.legend(fontsize="x-small", ncol=max(1, math.ceil(len(names) / 20)), loc="center left",
                  bbox_to_anchor=(1.01, 0.5))
        save(fig, name)

    per_task_figure("success", "success rate", "success per task", "success_per_task.png", mean_line=False)
    per_task_figure("terrain_level", "terrain level (row of the grid)", "mean terrain level of finished episodes",
                    "terrain_level.png", mean_line=True)

    for group, names in loss_groups(scalars).items():
        fig, ax = plt.subplots(figsize=(7, 4))
        for name in names:
            curve(ax, scalars[name], name)
        ax.set(xlabel=xlabel, ylabel="loss", title=f"{title} loss: {group}".strip())
        ax.grid(alpha=0.3)
        ax.legend(fontsize="small")
        save(fig, f"loss_{_safe_filename(group)}.png")
    return written


def main(argv: Sequence[str] | None = None) -> int:
    """CLI entry point (``python -m mtbench.logs``). Returns the exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] in _NOT_SUBCOMMANDS and not Path(argv[0]).exists():
        print(f"error: python -m mtbench.logs has no {argv[0]!r} subcommand; usage: python -m mtbench.logs RUN.mcap "
              "[--out DIR] [--last N] (prints the summary tables and writes the plots)", file=sys.stderr)
        return 2
    parser = argparse.ArgumentParser(prog="python -m mtbench.logs", description=__doc__.split("\n\n")[0])
    parser.add_argument("run", type=Path, help="a run's .mcap file (its segments are merged) or its directory")
    parser.add_argument("--out", type=Path, default=None,
                        help="directory for the PNGs (default: <run without .mcap>_plots, or <dir>/plots)")
    parser.add_argument("--last", type=int, default=10, help="number of last points averaged (default 10)")
    parser.add_argument("--frames-offset", type=float, default=0.0,
                        help="frames added to the plots' frames axis (e.g. a flat pre-training stage's; default 0)")
    args = parser.parse_args(argv)
    if args.last < 1:
        parser.error("--last must be >= 1")
    try:
        files = find_segments(args.run)
        scalars = read_scalars(args.run)
    except (FileNotFoundError, ValueError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2

    print(f"run: {args.run} ({len(files)} segment{'s' if len(files) != 1 else ''}: {', '.join(f.name for f in files)})")
    if not scalars:
        print("no scalars logged")
        return 0
    print(f"\nscalars (mean over the last {args.last} points; mean/max skip non-finite values)")
    print(_table(["name", "last", f"mean(last {args.last})", "max", "points"], scalar_summary(scalars, args.last)))

    tasks = task_table(scalars, args.last)
    if tasks:
        print(f"\nper task (success/<task>, return/<task>; mean over the last {args.last} points)")
        print(_table(["task", "success", f"success(last {args.last})", "return", f"return(last {args.last})"], tasks))

    out_dir = args.out
    if out_dir is None:
        out_dir = args.run / "plots" if args.run.is_dir() else args.run.with_name(f"{files[0].stem}_plots")
    title = files[0].stem
    print()
    for path in plot_run(scalars, out_dir, title=title, frames_offset=args.frames_offset):
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
