"""Per-task episode statistics over a sliding window of iterations (MTBench's success metric; Parkour's progress and
terrain levels)."""

from __future__ import annotations

import math
from collections import deque
from typing import Any, Mapping, Sequence

import torch
from tensordict import TensorDictBase

STAT_KEYS = ("episodes", "success", "return", "length")
# optional per-task statistics of curriculum envs (Parkour-hard-cl): summed levels of the finished episodes and the
# highest level of a finished episode (-1: none)
LEVEL_KEYS = ("terrain_level", "max_terrain_level")
# optional per-task counts of how the finished episodes ended, one reason each (Parkour: end_goals, end_time,
# end_height, end_roll, end_pitch, end_physics); any stats key with this prefix is one
END_PREFIX = "end_"


def percent(value: float) -> str:
    """A share in [0, 1] as ``"12.3%"`` (``"n/a"`` for NaN)."""
    return "n/a" if value != value else f"{100 * value:.1f}%"


class EpisodeStatsWindow:
    """Sums of per-task episode statistics over the last ``window`` iterations.

    Each :meth:`push` takes the output of ``env.pop_episode_stats()`` (per-task ``[K]`` sums over the
    episodes that finished during one iteration). The success rate of a task is
    ``successes / finished episodes`` pooled over the window (an episode is a success if it succeeded at
    any step, as in MTBench / the paper, "averaged over the last 5 epochs"); tasks with no finished episode
    in the window report NaN and are left out of ``success/mean``. Envs whose per-episode quantity is not a 0/1
    success name it in ``metric`` (Parkour: ``"progress"``, the fraction of waypoints reached); the logged keys stay
    ``success/<task>`` so that every tool reads one schema.

    When the stats hold ``terrain_level`` / ``max_terrain_level`` (the Parkour curriculum), the window also reports
    the mean terrain level of the finished episodes per task and the highest one (``terrain_level/<task>``,
    ``terrain_level_max/<task>``). When they hold ``end_<reason>`` counts (how each finished episode ended, e.g.
    Parkour's falls into a pit or roll-overs), it reports each reason's share of the finished episodes
    (``end_<reason>/<task>``, ``end_<reason>/mean``) and :meth:`table` adds a table of them.

    Args:
        task_names: the env's tasks (``env.task_names``).
        window: iterations pooled.
        metric: what ``success`` measures, shown in tables (``env.success_metric``; default ``"success"``).
        active: per task, whether the env has worlds of it (tasks without worlds are left out of the table; all by
            default). Parkour's flat pre-training has 21 task slots but only ``flat`` worlds.
        levels: report terrain levels when the stats hold them (``None``/``True``) or never (``False``: an env
            whose levels are fixed rows, not a curriculum).
    """

    def __init__(self, task_names: Sequence[str], window: int = 5, *, metric: str = "success",
                 active: Sequence[bool] | torch.Tensor | None = None, levels: bool | None = None) -> None:
        if window < 1:
            raise ValueError(f"window must be >= 1, got {window}")
        self.task_names = list(task_names)
        self.window = int(window)
        self.metric = str(metric)
        self.track_levels = levels is not False
        k = len(self.task_names)
        flags = torch.ones(k, dtype=torch.bool) if active is None else torch.as_tensor(active)
        self.active = flags.to("cpu", torch.bool)
        if self.active.shape != (k,):
            raise ValueError(f"active must hold one flag per task ({k}), got shape {tuple(self.active.shape)}")
        self._items: deque[torch.Tensor] = deque(maxlen=self.window)
        self._levels: deque[torch.Tensor] = deque(maxlen=self.window)
        self.end_keys: list[str] = []  # the env's end_<reason> keys, from the first push that has any
        self._ends: deque[torch.Tensor] = deque(maxlen=self.window)
        self.total_episodes = torch.zeros(k, dtype=torch.float64)

    def push(self, stats: TensorDictBase | Mapping[str, torch.Tensor]) -> None:
        """Add one iteration's per-task sums (moved to the CPU: one host sync per iteration)."""
        keys = list(stats.keys())
        missing = [k for k in STAT_KEYS if k not in keys]
        if missing:
            raise KeyError(f"episode stats lack {missing}; env.pop_episode_stats() must return {list(STAT_KEYS)}")
        row = torch.stack([stats[k].detach().to("cpu", torch.float64).reshape(-1) for k in STAT_KEYS])
        if row.shape[-1] != len(self.task_names):
            raise ValueError(f"episode stats have {row.shape[-1]} tasks, expected {len(self.task_names)}")
        self._items.append(row)
        self.total_episodes += row[0]
        if self.track_levels and LEVEL_KEYS[0] in keys:
            level_sum = stats[LEVEL_KEYS[0]].detach().to("cpu", torch.float64).reshape(-1)
            level_max = (stats[LEVEL_KEYS[1]].detach().to("cpu", torch.float64).reshape(-1) if LEVEL_KEYS[1] in keys
                         else torch.full_like(level_sum, -1.0))
            self._levels.append(torch.stack([level_sum, level_max]))
        if not self.end_keys:
            self.end_keys = [k for k in keys if isinstance(k, str) and k.startswith(END_PREFIX)]
        if self.end_keys:
            self._ends.append(torch.stack([
                stats[k].detach().to("cpu", torch.float64).reshape(-1) if k in keys else torch.zeros_like(row[0])
                for k in self.end_keys]))

    @property
    def has_levels(self) -> bool:
        """Whether the env reports terrain levels (a curriculum)."""
        return len(self._levels) > 0

    def _sums(self) -> torch.Tensor:
        if not self._items:
            return torch.zeros(len(STAT_KEYS), len(self.task_names), dtype=torch.float64)
        return torch.stack(list(self._items)).sum(0)

    def per_task(self) -> dict[str, torch.Tensor]:
        """``success_rate``, ``return``, ``length`` (means per finished episode) and ``episodes`` ([K] each); with a
        curriculum also ``terrain_level`` (mean level of the finished episodes) and ``max_terrain_level`` (highest;
        NaN without finished episodes); with end reasons each ``end_<reason>`` as a share of the finished
        episodes."""
        episodes, success, ret, length = self._sums()
        denom = torch.where(episodes > 0, episodes, torch.full_like(episodes, float("nan")))
        out = {"episodes": episodes, "success_rate": success / denom, "return": ret / denom, "length": length / denom}
        if self._levels:
            levels = torch.stack(list(self._levels))
            out["terrain_level"] = levels[:, 0].sum(0) / denom
            top = levels[:, 1].amax(0)
            out["max_terrain_level"] = torch.where(top >= 0, top, torch.full_like(top, float("nan")))
        if self._ends:
            ends = torch.stack(list(self._ends)).sum(0)
            for key, count in zip(self.end_keys, ends):
                out[key] = count / denom
        return out

    def mean_success(self) -> float:
        """Average over tasks (with finished episodes in the window) of the per-task success rate."""
        return float(torch.nanmean(self.per_task()["success_rate"]))

    def summary(self) -> dict[str, float]:
        """Flat metrics: ``success/<task>``, ``return/<task>``, ``length/<task>``, ``success/mean``,
        ``return/mean`` (tasks without finished episodes are omitted); with a curriculum also
        ``terrain_level/<task>``, ``terrain_level_max/<task>`` and ``terrain_level/mean``; with end reasons
        ``end_<reason>/<task>`` and ``end_<reason>/mean``. A mean is over the tasks with finished episodes (NaN
        without any)."""
        stats = self.per_task()
        out: dict[str, float] = {}
        for i, name in enumerate(self.task_names):
            if stats["episodes"][i] > 0:
                out[f"success/{name}"] = float(stats["success_rate"][i])
                out[f"return/{name}"] = float(stats["return"][i])
                out[f"length/{name}"] = float(stats["length"][i])
                if "terrain_level" in stats:
                    out[f"terrain_level/{name}"] = float(stats["terrain_level"][i])
                    out[f"terrain_level_max/{name}"] = float(stats["max_terrain_level"][i])
                for key in self.end_keys if self._ends else ():
                    out[f"{key}/{name}"] = float(stats[key][i])
        out["success/mean"] = self.mean_success()
        for key in self.end_keys if self._ends else ():
            out[f"{key}/mean"] = float(torch.nanmean(stats[key]))
        out["return/mean"] = float(torch.nanmean(stats["return"]))
        if "terrain_level" in stats:
            out["terrain_level/mean"] = float(torch.nanmean(stats["terrain_level"]))
        return out

    def table(self) -> str:
        """Per-task table (the metric over the window, mean return, mean length, episodes; mean and highest terrain
        level with a curriculum) as text; tasks without worlds are left out."""
        stats = self.per_task()
        levels = "terrain_level" in stats
        shown = [i for i in range(len(self.task_names)) if bool(self.active[i])]
        width = max([len("task"), *(len(self.task_names[i]) for i in shown)])
        col = max(8, len(self.metric))
        header = f"{'task':<{width}}  {self.metric:>{col}}  {'return':>10}  {'length':>7}  {'episodes':>9}"
        if levels:
            header += f"  {'level':>6}  {'max level':>9}"
        lines = [header, "-" * len(header)]
        for i in shown:
            name, eps = self.task_names[i], int(stats["episodes"][i])
            if eps == 0:
                line = f"{name:<{width}}  {'n/a':>{col}}  {'n/a':>10}  {'n/a':>7}  {eps:>9d}"
                if levels:
                    line += f"  {'n/a':>6}  {'n/a':>9}"
                lines.append(line)
                continue
            line = (f"{name:<{width}}  {100 * float(stats['success_rate'][i]):>{col - 1}.1f}%  "
                    f"{float(stats['return'][i]):>10.2f}  {float(stats['length'][i]):>7.1f}  {eps:>9d}")
            if levels:
                top = float(stats["max_terrain_level"][i])
                line += f"  {float(stats['terrain_level'][i]):>6.2f}  {'n/a' if math.isnan(top) else f'{top:.0f}':>9}"
            lines.append(line)
        lines.append("-" * len(header))
        mean = self.mean_success()
        mean_txt = "n/a" if mean != mean else f"{100 * mean:.1f}%"
        lines.append(f"{'mean':<{width}}  {mean_txt:>{col}}")
        hidden = len(self.task_names) - len(shown)
        if hidden:
            lines.append(f"({hidden} task slot{'s' if hidden > 1 else ''} without worlds in this env not shown)")
        if self._ends:
            lines += ["", self._end_table(stats, shown, width)]
        return "\n".join(lines)

    def _end_table(self, stats: Mapping[str, torch.Tensor], shown: Sequence[int], width: int) -> str:
        """How the finished episodes of each task ended: each reason's share (the rows sum to 100%)."""
        reasons = [k[len(END_PREFIX):] for k in self.end_keys]
        cols = [max(7, len(r)) for r in reasons]
        header = f"{'ended by':<{width}}  " + "  ".join(f"{r:>{c}}" for r, c in zip(reasons, cols))
        lines = [header, "-" * len(header)]
        for i in shown:
            cells = [percent(float(stats[k][i])) for k in self.end_keys]
            lines.append(f"{self.task_names[i]:<{width}}  " + "  ".join(f"{x:>{c}}" for x, c in zip(cells, cols)))
        return "\n".join(lines)

    def state_dict(self) -> dict[str, Any]:
        return {"window": self.window, "items": [t.clone() for t in self._items],
                "levels": [t.clone() for t in self._levels], "end_keys": list(self.end_keys),
                "ends": [t.clone() for t in self._ends], "total_episodes": self.total_episodes}

    def load_state_dict(self, state: Mapping[str, Any]) -> None:
        self._items = deque([torch.as_tensor(t, dtype=torch.float64) for t in state["items"]], maxlen=self.window)
        self._levels = deque([torch.as_tensor(t, dtype=torch.float64) for t in state.get("levels", [])],
                             maxlen=self.window)
        self.end_keys = list(state.get("end_keys", []))  # absent in checkpoints before 2026-11-28
        self._ends = deque([torch.as_tensor(t, dtype=torch.float64) for t in state.get("ends", [])],
                           maxlen=self.window)
        self.total_episodes = torch.as_tensor(state["total_episodes"], dtype=torch.float64).clone()
