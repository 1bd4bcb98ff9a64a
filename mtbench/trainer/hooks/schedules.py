"""Schedules of MT-PQN: the epsilon-greedy exploration rate per env step and the linearly annealed learning rate."""

from __future__ import annotations

from typing import Any

import torch
from torchrl.modules import EGreedyModule

from .base import TrainerHook

#: what :class:`EpsilonSchedule`'s rate is a function of: the frames collected, or MTBench's step counter
EPSILON_CLOCKS = ("frames", "mtbench")


def linear_epsilon(frames: int | float, start: float, end: float, anneal_frames: float) -> float:
    """``max(end, start + (end - start) * frames / anneal_frames)`` (CleanRL / MTBench ``linear_schedule``)."""
    if anneal_frames <= 0:
        return float(end)
    return max(float(end), float(start) + (float(end) - float(start)) * float(frames) / float(anneal_frames))


class EpsilonSchedule(TrainerHook):
    """Anneal the ``eps`` of the policy's ``EGreedyModule`` linearly from ``start`` to ``end`` over
    ``fraction`` of the run's frames, then hold ``end`` (MTBench PQN: 1 -> 0.005 over 0.5% of training).

    The rate of each env step is set before the step from the schedule's ``clock`` (by default the frames collected
    before it, ``trainer.frames + num_envs * steps done in the rollout``), in place on the module's ``eps`` buffer
    (no host sync; a CUDA-graphed policy sees it). The schedule is a function of the trainer's counters, so a
    resumed run (between iterations or in the middle of a rollout) continues it exactly; the hook's state holds its
    parameters and the current rate.
    Logs ``train/epsilon`` (the rate of the iteration's last env step).

    ``clock`` says what the rate is a function of:

    * ``"frames"`` (default, the paper's description): the frames collected before the step, ``num_envs * (horizon
      * iteration + step)``; the rate reaches ``end`` after ``fraction`` of the run's frames;
    * ``"mtbench"`` (MTBench's ``pqn_agent.py``, which produced the paper's curves): ``t = (epoch - 1) * num_envs +
      num_envs * (step + 1)`` = ``num_envs * (iteration + step + 1)``, i.e. one env step counted per iteration (not
      ``horizon``) plus the steps of the current rollout, against the same ``fraction * iterations * num_envs *
      horizon``: the rate restarts slightly higher at every iteration and reaches ``end`` after ``fraction *
      iterations * horizon`` iterations, ``horizon`` times later (16 x: after 8% of the paper's 50,000 iterations,
      524 M frames, instead of 0.5%, 33 M frames).

    Args:
        start, end: initial and final rate (``0 <= end <= start <= 1``).
        fraction: fraction of the run's frames over which the rate is annealed (in ``(0, 1]``).
        clock: ``"frames"`` or ``"mtbench"`` (:data:`EPSILON_CLOCKS`).
    """

    name = "epsilon_schedule"

    def __init__(self, start: float = 1.0, end: float = 0.005, fraction: float = 0.005, clock: str = "frames") -> None:
        if clock not in EPSILON_CLOCKS:
            raise ValueError(f"unknown epsilon clock {clock!r}; valid choices: {list(EPSILON_CLOCKS)}")
        if not 0.0 <= end <= start <= 1.0:
            raise ValueError(f"epsilon must satisfy 0 <= end_epsilon <= start_epsilon <= 1; got start={start}, "
                             f"end={end}")
        if not 0.0 < fraction <= 1.0:
            raise ValueError(f"exploration_fraction must be in (0, 1]; got {fraction}")
        self.start, self.end, self.fraction = float(start), float(end), float(fraction)
        self.clock = clock
        self.epsilon = self.start

    @staticmethod
    def modules(trainer: Any) -> list[EGreedyModule]:
        """The ``EGreedyModule`` s of ``trainer.policy`` (at least one, else ``TypeError``)."""
        found = [m for m in trainer.policy.modules() if isinstance(m, EGreedyModule)]
        if not found:
            raise TypeError(f"EpsilonSchedule needs an EGreedyModule in the policy; {type(trainer.policy).__name__} "
                            "has none")
        return found

    def anneal_frames(self, trainer: Any) -> float:
        return self.fraction * trainer.total_iterations * trainer.frames_per_batch

    def clock_frames(self, trainer: Any, steps_done: int) -> int:
        """The schedule's position before env step ``steps_done`` of the current rollout (see ``clock``)."""
        if self.clock == "mtbench":
            return trainer.total_envs * (trainer.iteration + steps_done + 1)
        return trainer.frames + trainer.total_envs * steps_done

    def _set(self, trainer: Any, steps_done: int) -> None:
        frames = self.clock_frames(trainer, steps_done)
        self.epsilon = linear_epsilon(frames, self.start, self.end, self.anneal_frames(trainer))
        for module in self.modules(trainer):
            module.eps.fill_(self.epsilon)

    def on_train_start(self, trainer: Any) -> None:
        self.modules(trainer)  # fail before the first rollout

    def on_iteration_start(self, trainer: Any) -> None:
        self._set(trainer, trainer.rollout.steps_done)

    def on_rollout_step(self, trainer: Any, step: int, horizon: int) -> None:
        if step < horizon:
            self._set(trainer, step)

    def on_iteration_end(self, trainer: Any, metrics: dict[str, float]) -> None:
        metrics["train/epsilon"] = self.epsilon

    def state_dict(self) -> dict[str, Any]:
        return {"start": self.start, "end": self.end, "fraction": self.fraction, "clock": self.clock,
                "epsilon": self.epsilon}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.start, self.end = float(state["start"]), float(state["end"])
        self.fraction, self.epsilon = float(state["fraction"]), float(state["epsilon"])
        self.clock = str(state.get("clock", "frames"))  # checkpoints from before the option: the frames clock


class LinearLRDecay(TrainerHook):
    """Learning rate ``lr * (1 - i / total_iterations)`` during iteration ``i = 0, 1, ...`` (MTBench PQN
    ``anneal_lr``: ``frac = 1 - (epoch - 1) / max_epochs``; the last iteration runs at ``lr / total_iterations``).

    Set at the start of every iteration, in place when the optimizer's learning rate is a tensor (no host sync,
    graph-safe); the rate lives in the optimizer (hence in its ``state_dict``), the hook's state holds ``lr``.

    Args:
        lr: the initial learning rate.
    """

    name = "lr_decay"

    def __init__(self, lr: float) -> None:
        if not lr > 0:
            raise ValueError(f"lr must be > 0; got {lr}")
        self.lr = float(lr)

    def on_iteration_start(self, trainer: Any) -> None:
        value = self.lr * (1.0 - trainer.iteration / trainer.total_iterations)
        for group in trainer.optimizer.param_groups:
            if isinstance(group["lr"], torch.Tensor):
                group["lr"].fill_(value)
            else:
                group["lr"] = value

    def state_dict(self) -> dict[str, Any]:
        return {"lr": self.lr}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.lr = float(state["lr"])


__all__ = ["EPSILON_CLOCKS", "EpsilonSchedule", "LinearLRDecay", "linear_epsilon"]
