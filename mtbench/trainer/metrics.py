"""Per-task episode statistics over a sliding window of iterations (MTBench's success metric)."""

from __future__ import annotations

from collections import deque
from typing import Any, Mapping, Sequence

import torch
from tensordict import TensorDictBase

STAT_KEYS = ("episodes", "success", "return", "length")


class EpisodeStatsWindow:
    """Sums of per-task episode statistics over the last ``window`` iterations.

    Each :meth:`push` takes the output of ``env.pop_episode_stats()`` (per-task ``[K]`` sums over the
    episodes that finished during one iteration). The success rate of a task is
    ``successes / finished episodes`` pooled over the window (an episode is a success if it succeeded at
    any step, as in MTBench / the paper, "averaged over the last 5 epochs"); tasks with no finished episode
    in the window report NaN and are left out of ``success/mean``.
    """

    def __init__(self, task_names: Sequence[str], window: int = 5) -> None:
        if window < 1:
            raise ValueError(f"window must be >= 1, got {window}")
        self.task_names = list(task_names)
        self.window = int(window)
        self._items: deque[torch.Tensor] = deque(maxlen=self.window)
        self.total_episodes = torch.zeros(len(self.task_names), dtype=torch.float64)

    def push(self, stats: TensorDictBase | Mapping[str, torch.Tensor]) -> None:
        """Add one iteration's per-task sums (moved to the CPU: one host sync per iteration)."""
        missing = [k for k in STAT_KEYS if k not in stats.keys()]
        if missing:
            raise KeyError(f"episode stats lack {missing}; env.pop_episode_stats() must return {list(STAT_KEYS)}")
        row = torch.stack([stats[k].detach().to("cpu", torch.float64).reshape(-1) for k in STAT_KEYS])
        if row.shape[-1] != len(self.task_names):
            raise ValueError(f"episode stats have {row.shape[-1]} tasks, expected {len(self.task_names)}")
        self._items.append(row)
        self.total_episodes += row[0]

    def _sums(self) -> torch.Tensor:
        if not self._items:
            return torch.zeros(len(STAT_KEYS), len(self.task_names), dtype=torch.float64)
        return torch.stack(list(self._items)).sum(0)

    def per_task(self) -> dict[str, torch.Tensor]:
        """``success_rate``, ``return``, ``length`` (means per finished episode) and ``episodes`` ([K] each)."""
        episodes, success, ret, length = self._sums()
        denom = torch.where(episodes > 0, episodes, torch.full_like(episodes, float("nan")))
        return {"episodes": episodes, "success_rate": success / denom, "return": ret / denom, "length": length / denom}

    def mean_success(self) -> float:
        """Average over tasks (with finished episodes in the window) of the per-task success rate."""
        rate = self.per_task()["success_rate"]
        valid = ~torch.isnan(rate)
        return float(rate[valid].mean()) if bool(valid.any()) else float("nan")

    def summary(self) -> dict[str, float]:
        """Flat metrics: ``success/<task>``, ``return/<task>``, ``length/<task>``, ``success/mean``,
        ``return/mean`` (tasks without finished episodes are omitted)."""
        stats = self.per_task()
        out: dict[str, float] = {}
        for i, name in enumerate(self.task_names):
            if stats["episodes"][i] > 0:
                out[f"success/{name}"] = float(stats["success_rate"][i])
                out[f"return/{name}"] = float(stats["return"][i])
                out[f"length/{name}"] = float(stats["length"][i])
        out["success/mean"] = self.mean_success()
        ret = stats["return"]
        valid = ~torch.isnan(ret)
        out["return/mean"] = float(ret[valid].mean()) if bool(valid.any()) else float("nan")
        return out

    def table(self) -> str:
        """Per-task table (success over the window, mean return, mean length, episodes) as text."""
        stats = self.per_task()
        width = max([len("task"), *(len(n) for n in self.task_names)])
        lines = [f"{'task':<{width}}  {'success':>8}  {'return':>10}  {'length':>7}  {'episodes':>9}"]
        lines.append("-" * len(lines[0]))
        for i, name in enumerate(self.task_names):
            eps = int(stats["episodes"][i])
            if eps == 0:
                lines.append(f"{name:<{width}}  {'n/a':>8}  {'n/a':>10}  {'n/a':>7}  {eps:>9d}")
                continue
            lines.append(
                f"{name:<{width}}  {100 * float(stats['success_rate'][i]):>7.1f}%  {float(stats['return'][i]):>10.2f}"
                f"  {float(stats['length'][i]):>7.1f}  {eps:>9d}"
            )
        lines.append("-" * len(lines[0]))
        mean = self.mean_success()
        mean_txt = "n/a" if mean != mean else f"{100 * mean:.1f}%"
        lines.append(f"{'mean':<{width}}  {mean_txt:>8}")
        return "\n".join(lines)

    def state_dict(self) -> dict[str, Any]:
        return {"window": self.window, "items": [t.clone() for t in self._items], "total_episodes": self.total_episodes}

    def load_state_dict(self, state: Mapping[str, Any]) -> None:
        self._items = deque([torch.as_tensor(t, dtype=torch.float64) for t in state["items"]], maxlen=self.window)
        self.total_episodes = torch.as_tensor(state["total_episodes"], dtype=torch.float64).clone()
