"""Run full episodes of every task of an mtbench env with a policy and read the per-task statistics."""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Callable

import torch
from tensordict import TensorDictBase

from ..trainer.metrics import END_PREFIX, STAT_KEYS

# optional per-task counters an env may report besides STAT_KEYS (summed and reported when present), and any
# ``end_<reason>`` count (how the counted episodes ended, one reason each: Parkour)
EXTRA_STAT_KEYS = ("unhealthy", "nonfinite_actions")


@dataclasses.dataclass
class EvalResult:
    """Per-task results of one evaluation (``mode`` ``"sampled"`` or ``"deterministic"``).

    ``success`` is the env's success statistic per finished episode: for Meta-World the fraction of episodes that
    succeeded at any step (the paper's metric); an env whose ``pop_episode_stats()["success"]`` sums another
    quantity (e.g. a progress in [0, 1]) names it in ``env.success_metric``, kept in ``metric``. ``extra`` holds the
    env's optional per-task counts (``unhealthy``, ``nonfinite_actions``, ``end_<reason>``: episodes that ended that
    way; :meth:`end_shares` gives them as shares of the episodes).
    """

    mode: str
    metric: str
    task_names: list[str]
    episodes: list[int]
    success: list[float]
    returns: list[float]
    lengths: list[float]
    extra: dict[str, list[float]] = dataclasses.field(default_factory=dict)

    def _mean(self, values: list[float]) -> float:
        valid = [v for v, n in zip(values, self.episodes) if n > 0]
        return sum(valid) / len(valid) if valid else math.nan

    @property
    def mean_success(self) -> float:
        """Mean over the tasks (with finished episodes) of the per-task success."""
        return self._mean(self.success)

    @property
    def mean_return(self) -> float:
        return self._mean(self.returns)

    @property
    def mean_length(self) -> float:
        return self._mean(self.lengths)

    def end_shares(self) -> dict[str, list[float]]:
        """Per end reason (the ``end_`` prefix removed), each task's share of its counted episodes that ended that
        way (NaN without episodes); empty for an env that reports no end reasons."""
        return {key[len(END_PREFIX):]: [c / n if n > 0 else math.nan for c, n in zip(counts, self.episodes)]
                for key, counts in self.extra.items() if key.startswith(END_PREFIX)}

    def as_dict(self) -> dict[str, Any]:
        per_task = {
            name: {"episodes": self.episodes[i], self.metric: self.success[i], "return": self.returns[i],
                   "length": self.lengths[i], **{k: v[i] for k, v in self.extra.items()}}
            for i, name in enumerate(self.task_names)
        }
        return {"mode": self.mode, "metric": self.metric, "per_task": per_task,
                "mean": {self.metric: self.mean_success, "return": self.mean_return, "length": self.mean_length,
                         "episodes": sum(self.episodes)}}


def worlds_per_task(env: Any) -> list[int]:
    """Worlds of each task block (``env.task_counts``, or counted from ``env.task_id``)."""
    counts = getattr(env, "task_counts", None)
    if counts is None:
        counts = torch.bincount(env.task_id.reshape(-1).cpu(), minlength=int(env.num_tasks)).tolist()
    return [int(c) for c in counts]


def fewest_worlds(env: Any) -> int:
    """The worlds of the smallest task block among the tasks that have worlds (Parkour's flat stage fills one of its
    21 task slots)."""
    return min(c for c in worlds_per_task(env) if c > 0)


def passes_needed(env: Any, episodes: int) -> int:
    """Passes of one episode per world so that every task (with worlds) finishes at least ``episodes`` episodes."""
    return max(1, math.ceil(episodes / fewest_worlds(env)))


def run_episodes(
    env: Any,
    policy: Callable[[TensorDictBase, bool], torch.Tensor],
    *,
    episodes: int,
    deterministic: bool,
    seed: int,
    on_step: Callable[[int, int, torch.Tensor], None] | None = None,
) -> EvalResult:
    """Evaluate ``policy`` for at least ``episodes`` full episodes per task.

    Every pass resets all worlds (the env must start them at step 0, i.e. ``random_start_progress=False``) and
    runs ``env.max_episode_steps`` steps: each world finishes one episode, and only that first episode is counted
    (an env with ``exclude_episodes``, as mtbench's are, leaves out the episodes that worlds start after an early
    end -- a fall, a physics failure -- which would otherwise weigh the short failed episodes several times;
    MTBench's player also counts the first episode of every env). With ``episodes`` worlds per task one pass suffices; otherwise
    passes repeat until every task has ``episodes`` episodes (tasks with more worlds finish more). The env's
    reset sampler and torch's generator are seeded with ``seed`` first, so two evaluations with the same seed
    see the same initial worlds. ``on_step(pass, t, finished)`` is called before the action of step ``t`` (e.g. to
    render the current state); ``finished`` (bool ``[num_worlds]``, on the device) marks the worlds whose first
    episode of the pass ended before step ``t``. A policy with a ``reset()`` method (a stateful one, e.g. an MT-PQN policy that holds its
    action for ``loss.horizon`` steps) is reset after every env reset. The statistics stay on the device until the
    end (one host copy).
    """
    if episodes < 1:
        raise ValueError(f"episodes must be >= 1, got {episodes}")
    for attr in ("num_tasks", "task_names", "pop_episode_stats", "max_episode_steps"):
        if not hasattr(env, attr):
            raise TypeError(f"env {type(env).__name__} lacks '{attr}' (mtbench env contract)")
    env.set_seed(int(seed))
    torch.manual_seed(int(seed))
    steps = int(env.max_episode_steps)
    totals: dict[str, torch.Tensor] = {}
    for p in range(passes_needed(env, episodes)):
        td = env.reset()
        env.pop_episode_stats()  # nothing from before this pass
        reset_policy = getattr(policy, "reset", None)
        if callable(reset_policy):  # a stateful policy (e.g. a PQN policy holding its action) starts afresh
            reset_policy()
        exclude = getattr(env, "exclude_episodes", None)
        # worlds whose first episode of this pass has ended (on the device)
        finished = torch.zeros(td.batch_size[0], dtype=torch.bool, device=td.device)
        for t in range(steps):
            if on_step is not None:
                on_step(p, t, finished)
            td.set("action", policy(td, deterministic))
            out, td = env.step_and_maybe_reset(td)
            finished = finished | out.get(("next", "done")).reshape(-1)
            if callable(exclude):
                exclude(finished)
        stats = env.pop_episode_stats()
        for key in stats.keys():
            if key in STAT_KEYS or key in EXTRA_STAT_KEYS or key.startswith(END_PREFIX):
                value = stats.get(key).detach().double()
                totals[key] = value if key not in totals else totals[key] + value
    host = {k: v.cpu() for k, v in totals.items()}  # the one host sync
    count = host["episodes"]
    denom = torch.where(count > 0, count, torch.full_like(count, math.nan))
    return EvalResult(
        mode="deterministic" if deterministic else "sampled",
        metric=str(getattr(env, "success_metric", "success")),
        task_names=list(env.task_names),
        episodes=[int(round(c)) for c in count.tolist()],
        success=(host["success"] / denom).tolist(),
        returns=(host["return"] / denom).tolist(),
        lengths=(host["length"] / denom).tolist(),
        extra={k: v.tolist() for k, v in host.items() if k in EXTRA_STAT_KEYS or k.startswith(END_PREFIX)},
    )


__all__ = ["EXTRA_STAT_KEYS", "EvalResult", "STAT_KEYS", "fewest_worlds", "passes_needed", "run_episodes",
           "worlds_per_task"]
