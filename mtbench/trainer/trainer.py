"""On-policy multi-task training loop (MT-PPO / MT-GRPO, or any TorchRL loss) over a native-autoreset env."""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any, Sequence, TypeVar

import torch
from omegaconf import DictConfig, OmegaConf
from tensordict import TensorDictBase
from torch import nn
from torchrl.envs import EnvBase, TransformedEnv
from torchrl.objectives import LossModule

from ..transforms import PerTaskObservationNorm
from .checkpoint import CHECKPOINT_VERSION, CheckpointError, load_checkpoint, rng_state, save_checkpoint, set_rng_state
from .config import effective_minibatch_size
from .env_factory import make_env_from_cfg  # noqa: F401  (kept importable here: mtbench.evaluation uses it)
from .hooks import TrainerHook
from .metrics import EpisodeStatsWindow
from .rollout import Rollout, base_env
from .stop import StopRequest
from .update import MinibatchUpdate


def _transformed_levels(env: EnvBase) -> list[TransformedEnv]:
    """The ``TransformedEnv`` wrappers of ``env``, outermost first (their transforms hold state, e.g. the
    observation statistics; ``TransformedEnv.state_dict`` holds only its own transform's)."""
    levels = []
    while isinstance(env, TransformedEnv):
        levels.append(env)
        env = env.base_env
    return levels


def observation_norm(env: EnvBase) -> PerTaskObservationNorm | None:
    """The env's ``PerTaskObservationNorm`` transform, if any."""
    for level in _transformed_levels(env):
        for transform in [level.transform, *getattr(level.transform, "transforms", [])]:
            if isinstance(transform, PerTaskObservationNorm):
                return transform
    return None


def tasks_with_worlds(env: EnvBase, num_tasks: int) -> torch.Tensor | None:
    """Per task, whether ``env`` has worlds of it (from its ``task_id`` tensor; ``None`` if it has none). Parkour's
    flat pre-training fills only the ``flat`` slot of its 21 tasks."""
    task_id = getattr(env, "task_id", None)
    if not isinstance(task_id, torch.Tensor):
        return None
    return torch.bincount(task_id.reshape(-1).cpu(), minlength=num_tasks)[:num_tasks] > 0


# keys whose mismatch between a checkpoint and the current config makes a resume meaningless
RESUME_KEYS = ("env.name", "env.num_envs", "loss.name", "loss.horizon", "arch.name", "grad.name")
H = TypeVar("H", bound=TrainerHook)


class Trainer:
    """The on-policy loop, top to bottom (LeanRL / CleanRL style); everything else is a hook.

    One iteration:

    1. **rollout**: ``horizon`` x (``policy(td)``, ``env.step_and_maybe_reset(td)``) into a ``[N, T]``
       TensorDict (:class:`~mtbench.trainer.rollout.Rollout`); ``env.pop_episode_stats()`` feeds the per-task
       success window;
    2. **advantage**: ``with torch.no_grad(): loss.value_estimator(rollout)`` -- whatever estimator the loss
       has (mtbench's ``PerTaskGAE`` / ``PerTaskMCAdvantage``, or TorchRL's ``GAE``);
    3. **update**: ``epochs`` x shuffled minibatches of the flat rollout through
       :class:`~mtbench.trainer.update.MinibatchUpdate` (``loss(minibatch)``, or the gradient-method wrapper's
       ``backward``), one host read of the summed metrics.

    Hooks (:class:`~mtbench.trainer.hooks.TrainerHook`) are called at defined points: the adaptive learning
    rate, the non-finite guard, checkpoints, logging and progress are hooks. A SIGINT/SIGTERM stops the loop
    after the current env step (or update) and the hooks' ``on_train_end(stopped=True)`` checkpoint it.

    Args:
        env: batched env with the mtbench contract (``num_tasks``, ``task_names``, ``pop_episode_stats``, native
            autoreset), possibly a ``TransformedEnv`` (e.g. per-task observation normalisation).
        policy: the actor: writes ``action`` (and what the loss reads, e.g. ``action_log_prob``) into the td.
        loss: a TorchRL ``LossModule`` with a value estimator for ``[N, T]`` rollouts.
        optimizer: over the parameters to train.
        horizon: env steps per iteration; epochs: passes per iteration; minibatch_size: divides
            ``num_envs * horizon`` (a value >= the batch means one minibatch).
        total_iterations: length of the run.
        update_module: what produces the gradients (a gradient-manipulation wrapper of ``loss``); ``loss``
            itself by default.
        max_grad_norm: global grad-norm clip (``None``: none).
        hooks: called in the given order at each point.
        success_window: iterations pooled for the per-task success rate.
        cudagraph_policy: replay the policy from a CUDA graph during the rollout.
        cudagraph_update: replay each minibatch update from a CUDA graph.
        config: the run's config (recorded in checkpoints and logs; checked on resume).
    """

    def __init__(
        self,
        env: EnvBase,
        policy: nn.Module,
        loss: LossModule,
        optimizer: torch.optim.Optimizer,
        *,
        horizon: int,
        epochs: int,
        minibatch_size: int,
        total_iterations: int,
        update_module: nn.Module | None = None,
        max_grad_norm: float | None = None,
        hooks: Sequence[TrainerHook] = (),
        success_window: int = 5,
        cudagraph_policy: bool = False,
        cudagraph_update: bool = False,
        config: DictConfig | None = None,
    ) -> None:
        self.env = env
        self.base_env = base_env(env)
        for attr in ("num_tasks", "task_names", "pop_episode_stats"):
            if not hasattr(self.base_env, attr):
                raise TypeError(f"env {type(self.base_env).__name__} lacks '{attr}' (mtbench env contract)")
        self.num_tasks = int(self.base_env.num_tasks)
        self.task_names = list(self.base_env.task_names)
        self.policy = policy
        self.loss = loss
        self.update_module = update_module if update_module is not None else loss
        self.optimizer = optimizer
        self.config = config
        self.rollout = Rollout(env, policy, horizon, cudagraph_policy=cudagraph_policy)
        self.horizon = self.rollout.horizon
        self.num_envs = self.rollout.num_envs
        self.frames_per_batch = self.num_envs * self.horizon
        if int(epochs) < 1:
            raise ValueError(f"loss.epochs must be >= 1, got {epochs}")
        self.epochs = int(epochs)
        self.minibatch_size = effective_minibatch_size(self.num_envs, self.horizon, minibatch_size)
        self.num_minibatches = self.frames_per_batch // self.minibatch_size
        self.updates_per_iteration = self.epochs * self.num_minibatches
        if int(total_iterations) < 1:
            raise ValueError(f"max_iterations must be >= 1, got {total_iterations}")
        self.total_iterations = int(total_iterations)
        self.hooks: list[TrainerHook] = []
        self._pending_hook_states: dict[str, Any] = {}
        for hook in hooks:
            self.add_hook(hook)
        device = next(iter(self.optimizer.param_groups[0]["params"])).device
        self.updater = MinibatchUpdate(
            self.update_module, optimizer, max_grad_norm=max_grad_norm, call_hooks=self._call,
            graph=cudagraph_update, device=device,
        )
        self.window = EpisodeStatsWindow(self.task_names, success_window,
                                         metric=str(getattr(self.base_env, "success_metric", "success")),
                                         active=tasks_with_worlds(self.base_env, self.num_tasks),
                                         levels=getattr(self.base_env, "curriculum", None))
        self.iteration = 0
        self.frames = 0
        self.updates = 0  # minibatch updates attempted (NonFiniteGuard counts the skipped ones)
        self.unhealthy_resets = 0.0  # env worlds reset after a NaN / runaway state / buffer overflow
        self.nonfinite_actions = 0.0  # env steps whose action had a NaN/inf component
        self._stop: StopRequest | None = None

    # ------------------------------------------------------------------ hooks
    def add_hook(self, hook: TrainerHook, before: type[TrainerHook] | None = None) -> None:
        """Add a hook at the end, or before the first hook of type ``before`` (e.g. a logger before the
        ``Checkpointer``, so that checkpoints hold its state after the iteration's logging). Its state is restored
        if a loaded checkpoint holds one under ``hook.name``."""
        if any(h.name == hook.name for h in self.hooks):
            raise ValueError(f"a hook named {hook.name!r} is already registered")
        index = next((i for i, h in enumerate(self.hooks) if before is not None and isinstance(h, before)), None)
        self.hooks.insert(len(self.hooks) if index is None else index, hook)
        if hook.name in self._pending_hook_states:
            hook.load_state_dict(self._pending_hook_states.pop(hook.name))

    def get_hook(self, cls: type[H]) -> H | None:
        """The first registered hook of type ``cls``, or ``None``."""
        return next((h for h in self.hooks if isinstance(h, cls)), None)

    def _call(self, point: str, *args: Any) -> None:
        for hook in self.hooks:
            getattr(hook, point)(self, *args)

    # ------------------------------------------------------------------ one iteration
    def collect(self) -> tuple[TensorDictBase | None, TensorDictBase | None]:
        """1. The rollout (``None`` if a stop request interrupted it) and the episode statistics finished in it."""
        stop = self._stop
        data = self.rollout.collect(
            on_step=lambda step, horizon: self._call("on_rollout_step", step, horizon),
            should_stop=None if stop is None else stop,
        )
        if data is None:
            return None, None
        return data, self.base_env.pop_episode_stats()

    def advantage(self, data: TensorDictBase) -> TensorDictBase:
        """2. ``loss.value_estimator`` on a shallow copy of the rollout (advantages, value targets, ...)."""
        with torch.no_grad():
            return self.loss.value_estimator(data.clone(False))

    def update(self, batch: TensorDictBase) -> dict[str, torch.Tensor]:
        """3. ``epochs`` x minibatches on the flat rollout (its ``"next"`` entries dropped); per-update means of
        the scalar metrics (device tensors)."""
        flat = batch.exclude("next").reshape(-1)
        means, count = self.updater.epochs(flat, self.epochs, self.minibatch_size)
        self.updates += count
        return means

    def train_iteration(self) -> dict[str, float] | None:
        """One iteration; returns its metrics (``None``: a stop request interrupted the rollout)."""
        self._call("on_iteration_start")
        t0 = time.perf_counter()
        data, stats = self.collect()
        if data is None or stats is None:
            return None
        unhealthy = stats.get("unhealthy", None)  # optional: envs other than mtbench's may not report them
        nonfinite = stats.get("nonfinite_actions", None)
        self.window.push(stats)  # device -> host copy: also ends the collection timing on GPU
        t1 = time.perf_counter()
        means = self.update(self.advantage(data))
        names = list(means)
        values = torch.stack([means[k] for k in names]).tolist()  # the update's only host sync
        t2 = time.perf_counter()
        self.iteration += 1
        self.frames += self.frames_per_batch
        metrics: dict[str, float] = {
            "iteration": float(self.iteration),
            "frames": float(self.frames),
            "fps": self.frames_per_batch / max(t2 - t0, 1e-9),
            "fps_collect": self.frames_per_batch / max(t1 - t0, 1e-9),
            "time/collect_s": t1 - t0,
            "time/update_s": t2 - t1,
            "train/lr": float(self.optimizer.param_groups[0]["lr"]),
        }
        for key, value in zip(names, values):
            metrics[f"loss/{key[5:]}" if key.startswith("loss_") else f"train/{key}"] = value
        metrics.update(self.window.summary())
        if unhealthy is not None:  # worlds the env reset after a NaN / runaway state / buffer overflow
            self.unhealthy_resets += float(unhealthy.sum())
            metrics["env/unhealthy_resets_total"] = self.unhealthy_resets
        if nonfinite is not None:  # policy actions with a NaN/inf component (replaced by 0 by the env)
            self.nonfinite_actions += float(nonfinite.sum())
            metrics["env/nonfinite_actions_total"] = self.nonfinite_actions
        self._call("on_iteration_end", metrics)
        return metrics

    # ------------------------------------------------------------------ main loop
    def train(self) -> list[dict[str, float]]:
        """Run until ``total_iterations`` (or a stop request); returns the metrics of this call's iterations."""
        history: list[dict[str, float]] = []
        with StopRequest() as stop:
            self._stop = stop
            try:
                self._call("on_train_start")
                while self.iteration < self.total_iterations and not stop.requested:
                    metrics = self.train_iteration()
                    if metrics is None:
                        break
                    history.append(metrics)
            except BaseException as error:
                self._call("on_error", error)
                raise
            finally:
                self._stop = None
            self._call("on_train_end", stop.requested)
        return history

    def success_table(self) -> str:
        """End-of-run per-task table (success over the last ``success_window`` iterations)."""
        return self.window.table()

    # ------------------------------------------------------------------ checkpointing
    def env_info(self) -> dict[str, Any]:
        """Properties of the env that define what a run measures (recorded in logs and checkpoints; a run only
        resumes from a checkpoint with the same values): the env class and its ``reward_version``."""
        return {"env_class": type(self.base_env).__name__,
                "reward_version": getattr(self.base_env, "reward_version", None)}

    def state_dict(self) -> dict[str, Any]:
        """Everything needed to continue the run bit for bit (on the same device type): counters, the loss
        (parameters, value-estimator statistics), the gradient method, the optimizer (incl. its learning rate),
        the env (``base_env.state_dict()``: physics, episode clocks, its generator) and the state of its
        transforms (observation statistics), the rollout's carried state (and the steps of an interrupted
        rollout), the success window, the hooks, and the Python/NumPy/torch/CUDA generators."""
        return {
            "version": CHECKPOINT_VERSION,
            "config": None if self.config is None else OmegaConf.to_container(self.config, resolve=True),
            "env_info": self.env_info(),
            "counters": {
                "iteration": self.iteration,
                "frames": self.frames,
                "updates": self.updates,
                "unhealthy_resets": self.unhealthy_resets,
                "nonfinite_actions": self.nonfinite_actions,
            },
            "loss": self.loss.state_dict(),
            "update_module": None if self.update_module is self.loss else self.update_module.state_dict(),
            "optimizer": self.optimizer.state_dict(),
            "env": self.base_env.state_dict(),
            "transforms": [level.transform.state_dict() for level in _transformed_levels(self.env)],
            # the observation statistics again under their own name, for tools that rebuild the policy
            # (mtbench.evaluation); the same tensors: saved once
            "obs_norm": None if (norm := observation_norm(self.env)) is None else norm.state_dict(),
            "rollout": self.rollout.state_dict(),
            "window": self.window.state_dict(),
            "hooks": {h.name: h.state_dict() for h in self.hooks},
            "rng": rng_state(),
        }

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write :meth:`state_dict` to ``path`` (atomic, checksummed)."""
        return save_checkpoint(path, self.state_dict())

    def load(self, path: str | os.PathLike[str]) -> None:
        """Restore a checkpoint file written by :meth:`save`."""
        self.load_state_dict(load_checkpoint(path), source=path)

    def load_state_dict(self, state: dict[str, Any], source: str | os.PathLike[str] = "checkpoint") -> None:
        """Restore :meth:`state_dict`; refuses a checkpoint of another configuration (``RESUME_KEYS``) or env."""
        diffs = []
        if self.config is not None and state.get("config") is not None:
            saved = OmegaConf.create(state["config"])
            for key in RESUME_KEYS:
                a, b = OmegaConf.select(saved, key), OmegaConf.select(self.config, key)
                if a != b:
                    diffs.append(f"{key}: checkpoint={a!r} current={b!r}")
        for key, value in self.env_info().items():
            saved_value = (state.get("env_info") or {}).get(key, value)
            if saved_value != value:
                diffs.append(f"env {key}: checkpoint={saved_value!r} current={value!r}")
        if diffs:
            raise ValueError(f"cannot resume from {source}: configuration differs ({'; '.join(diffs)})")
        c = state["counters"]
        self.iteration, self.frames, self.updates = int(c["iteration"]), int(c["frames"]), int(c["updates"])
        self.unhealthy_resets = float(c["unhealthy_resets"])
        self.nonfinite_actions = float(c["nonfinite_actions"])
        self.loss.load_state_dict(state["loss"])
        if state.get("update_module") is not None and self.update_module is not self.loss:
            self.update_module.load_state_dict(state["update_module"])
        capturable = [group.get("capturable") for group in self.optimizer.param_groups]
        self.optimizer.load_state_dict(state["optimizer"])
        for group, flag in zip(self.optimizer.param_groups, capturable):
            if isinstance(group["lr"], torch.Tensor):  # a tensor lr lives with the parameters (graph-safe updates)
                group["lr"] = group["lr"].to(group["params"][0].device)
            if flag is not None:  # a property of this run, not of the checkpoint
                group["capturable"] = flag
        self.updater.reset_graph()  # the loaded optimizer state lives in new tensors: capture again
        levels = _transformed_levels(self.env)
        if len(levels) != len(state["transforms"]):
            raise CheckpointError(source, f"{len(state['transforms'])} levels of env transforms saved, this env has "
                                          f"{len(levels)}")
        try:
            self.base_env.load_state_dict(state["env"])
            for level, saved in zip(levels, state["transforms"]):
                level.transform.load_state_dict(saved)
        except (RuntimeError, KeyError) as err:
            raise CheckpointError(source, f"the env state does not fit this env ({err})") from err
        self.rollout.load_state_dict(state["rollout"])
        self.window.load_state_dict(state["window"])
        self._pending_hook_states = dict(state.get("hooks") or {})
        for hook in self.hooks:
            if hook.name in self._pending_hook_states:
                hook.load_state_dict(self._pending_hook_states.pop(hook.name))
        set_rng_state(state["rng"])


__all__ = ["RESUME_KEYS", "Trainer", "make_env_from_cfg", "observation_norm", "tasks_with_worlds"]
