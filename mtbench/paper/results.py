"""Read the runs of a paper table back from their MCAP logs (torch-free).

A run's final score is the last finite ``success/mean`` it logged: the per-task success (Parkour: progress) pooled
over the trainer's success window at the end of the run, averaged over tasks, as the paper reports it. Its
wall-clock is the running sum of the logged ``time/collect_s`` and ``time/update_s`` (training time without
start-up), or frames / ``fps`` when those are missing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np

from mtbench.logging import find_segments, read_scalars

from .runner import read_marker

__all__ = ["RunResult", "align_curves", "load_runs", "SUCCESS_KEY", "RETURN_KEY", "COSINE_KEYS"]

SUCCESS_KEY = "success/mean"
RETURN_KEY = "return/mean"
COSINE_KEYS = tuple(f"train/grad_cos_{g}_{s}" for g in ("actor", "critic") for s in ("mean", "min", "max"))

Series = list[tuple[int, float]]


@dataclass
class RunResult:
    """The scalars of one (row, seed) run."""

    seed: int
    directory: Path
    scalars: dict[str, Series] = field(repr=False)
    finished: bool = False
    target_frames: int | None = None

    def series(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """``(frames, values)`` of scalar ``name`` (finite values only); frames from the ``frames`` scalar at the same
        step (the trainer logs with ``step = frames``), else the step."""
        points = self.scalars.get(name) or []
        frames_at = dict(self.scalars.get("frames") or [])
        xs = np.asarray([frames_at.get(s, s) for s, v in points if math.isfinite(v)], dtype=np.float64)
        ys = np.asarray([v for _, v in points if math.isfinite(v)], dtype=np.float64)
        return xs, ys

    def final(self, name: str = SUCCESS_KEY) -> float:
        """Last finite value of ``name`` (NaN when none)."""
        _, ys = self.series(name)
        return float(ys[-1]) if len(ys) else math.nan

    @property
    def frames(self) -> int:
        points = self.scalars.get("frames") or []
        return int(points[-1][1]) if points else 0

    @cached_property
    def wallclock(self) -> tuple[np.ndarray, np.ndarray]:
        """``(frames, seconds)``: cumulative training time at each logged iteration."""
        collect = dict(self.scalars.get("time/collect_s") or [])
        update = dict(self.scalars.get("time/update_s") or [])
        frames_at = dict(self.scalars.get("frames") or [])
        steps = sorted(set(collect) | set(update))
        if steps:
            dt = [collect.get(s, 0.0) + update.get(s, 0.0) for s in steps]
        else:  # frames / fps per iteration
            fps = self.scalars.get("fps") or []
            steps = [s for s, _ in fps]
            prev, dt = 0.0, []
            for s, v in fps:
                f = float(frames_at.get(s, s))
                dt.append((f - prev) / v if v and math.isfinite(v) else 0.0)
                prev = f
        xs = np.asarray([frames_at.get(s, s) for s in steps], dtype=np.float64)
        return xs, np.cumsum(np.asarray(dt, dtype=np.float64))

    def has(self, name: str) -> bool:
        return bool(self.scalars.get(name))


def load_runs(row_dir: Path) -> list[RunResult]:
    """Every run ``<row_dir>/s<seed>/`` with an MCAP log, sorted by seed."""
    runs = []
    if not Path(row_dir).is_dir():
        return runs
    for d in sorted(Path(row_dir).glob("s*")):
        if not d.is_dir() or not d.name[1:].isdigit() or not any(d.glob("*.mcap")):
            continue
        segments = find_segments(sorted(d.glob("*.mcap"), key=lambda p: (len(p.name), p.name))[0])
        scalars = read_scalars(segments[0])
        marker = read_marker(d)
        runs.append(RunResult(int(d.name[1:]), d, scalars, finished=marker is not None,
                              target_frames=None if marker is None else int(marker.get("frames", 0))))
    return sorted(runs, key=lambda r: r.seed)


def align_curves(runs: list[RunResult], name: str, *, x: str = "frames",
                 num_points: int = 100) -> tuple[np.ndarray, np.ndarray]:
    """Curves of ``name`` of several runs on one grid: ``(grid, values[num_runs, num_points])``, linearly
    interpolated, up to the shortest run's last point. ``x``: ``"frames"`` or ``"seconds"`` (wall-clock)."""
    curves = []
    for run in runs:
        fx, fy = run.series(name)
        if x == "seconds":
            wf, ws = run.wallclock
            fx = np.interp(fx, wf, ws) if len(wf) else fx * np.nan
        if len(fx):
            curves.append((fx, fy))
    if not curves:
        return np.zeros(0), np.zeros((0, 0))
    lo = max(c[0][0] for c in curves)
    hi = min(c[0][-1] for c in curves)
    if not hi > lo:
        grid = np.asarray([hi])
    else:
        grid = np.linspace(lo, hi, num_points)
    values = np.stack([np.interp(grid, cx, cy) for cx, cy in curves])
    return grid, values
