"""What every training loop of mtbench shares (the on-policy :class:`~mtbench.trainer.Trainer` and the
off-policy :class:`~mtbench.trainer.OffPolicyTrainer`): the env contract, hooks, ``train()`` with stop requests
and error hooks, counters, the per-task success window and the checkpoint state."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Sequence, TypeVar

import torch
from omegaconf import DictConfig, OmegaConf
from tensordict import TensorDictBase
from tensordict.utils import NestedKey
from torch import nn
from torchrl.envs import EnvBase, TransformedEnv

from ..transforms import PerTaskObservationNorm
from ..utils import distributed
from .checkpoint import CHECKPOINT_VERSION, CheckpointError, load_checkpoint, rng_state, save_checkpoint, set_rng_state
from .hooks import TrainerHook
from .metrics import EpisodeStatsWindow
from .rollout import Rollout, base_env
from .stop import StopRequest

H = TypeVar("H", bound=TrainerHook)


def transformed_levels(env: EnvBase) -> list[TransformedEnv]:
    """The ``TransformedEnv`` wrappers of ``env``, outermost first (their transforms hold state, e.g. the
    observation statistics; ``TransformedEnv.state_dict`` holds only its own transform's)."""
    levels = []
    while isinstance(env, TransformedEnv):
        levels.append(env)
        env = env.base_env
    return levels


def observation_norm(env: EnvBase) -> PerTaskObservationNorm | None:
    """The env's ``PerTaskObservationNorm`` transform, if any."""
    for level in transformed_levels(env):
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


LEGACY_V2_REVISION = "v2-2026-11-25"
"""The ``reward_revision`` of a ``reward_version="v2"`` checkpoint written before revisions were recorded (the first
v2 definition; Meta-World's ``task.REWARD_REVISIONS`` lists them)."""


# The env health statistics summed over the run: (episode-stats key, counter attribute, logged metric).
# ``unhealthy``: worlds reset after a NaN or runaway state; ``nonfinite_actions``: policy actions with a NaN/inf
# component (replaced by 0 by the env); ``contact_overflow``: steps whose contacts overflowed (Parkour only).
ENV_HEALTH_TOTALS: tuple[tuple[str, str, str], ...] = (
    ("unhealthy", "unhealthy_resets", "env/unhealthy_resets_total"),
    ("nonfinite_actions", "nonfinite_actions", "env/nonfinite_actions_total"),
    ("contact_overflow", "contact_overflows", "env/contact_overflow_steps_total"),
)


class TrainingLoop:
    """Base of the training loops: subclasses implement :meth:`train_iteration` (one iteration, top to bottom,
    returning its metrics or ``None`` when a stop request interrupted it) and may extend the checkpoint state
    with :meth:`_extra_state` / :meth:`_load_extra_state`.

    It holds the env (mtbench contract: ``num_tasks``, ``task_names``, ``pop_episode_stats``), the
    :class:`~mtbench.trainer.rollout.Rollout`, the loss and the module that produces its gradients, the
    optimizer, the hooks, the counters (``iteration``, ``frames``, ``updates``), the success window and the
    config; :meth:`train` runs iterations until ``total_iterations`` or a SIGINT/SIGTERM (the hooks'
    ``on_train_end(stopped=True)`` checkpoint it), :meth:`state_dict` / :meth:`load_state_dict` restore a run
    bit for bit.
    """

    #: config keys whose mismatch between a checkpoint and the current config makes a resume meaningless (the Parkour
    #: robot's contact stiffness: a resume must not change the physics under a run; its collision pieces: the saved
    #: per-geom model fields would not fit)
    resume_keys: tuple[str, ...] = ("env.name", "env.num_envs", "loss.name", "loss.horizon", "arch.name", "grad.name",
                                    "loss.clip_actions", "env.overrides.robot_contact_timeconst",
                                    "env.overrides.robot_collision_pieces")
    #: the value of a resume key in a config that lacks it (a checkpoint written before the key existed: MuJoCo's
    #: soft contacts before 2026-11-28, whole collision shapes before 2026-11-29)
    resume_defaults: dict[str, Any] = {"loss.clip_actions": False, "env.overrides.robot_contact_timeconst": None,
                                       "env.overrides.robot_collision_pieces": 1}

    def __init__(
        self,
        env: EnvBase,
        policy: nn.Module,
        loss: nn.Module,
        optimizer: torch.optim.Optimizer,
        *,
        horizon: int,
        total_iterations: int,
        update_module: nn.Module | None = None,
        hooks: Sequence[TrainerHook] = (),
        success_window: int = 5,
        cudagraph_policy: bool = False,
        hold_keys: Sequence[NestedKey] = (),
        hold_period: int | None = None,
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
        self.rollout = Rollout(env, policy, horizon, cudagraph_policy=cudagraph_policy, hold_keys=hold_keys,
                               hold_period=hold_period)
        self.horizon = self.rollout.horizon
        self.num_envs = self.rollout.num_envs  # this process's worlds
        self.world_size = distributed.world_size()  # torchrun: processes training this run together
        self.total_envs = self.num_envs * self.world_size  # the run's worlds, all ranks
        self.frames_per_batch = self.total_envs * self.horizon  # the run's frames per iteration, all ranks
        if int(total_iterations) < 1:
            raise ValueError(f"max_iterations must be >= 1, got {total_iterations}")
        self.total_iterations = int(total_iterations)
        self.hooks: list[TrainerHook] = []
        self._pending_hook_states: dict[str, Any] = {}
        for hook in hooks:
            self.add_hook(hook)
        self.window = EpisodeStatsWindow(self.task_names, success_window,
                                         metric=str(getattr(self.base_env, "success_metric", "success")),
                                         active=tasks_with_worlds(self.base_env, self.num_tasks),
                                         levels=getattr(self.base_env, "curriculum", None))
        self.iteration = 0
        self.frames = 0
        self.updates = 0  # optimizer updates attempted (NonFiniteGuard counts the skipped ones)
        self.unhealthy_resets = 0.0  # env worlds reset after a NaN / runaway state / buffer overflow
        self.nonfinite_actions = 0.0  # env steps whose action had a NaN/inf component
        self.contact_overflows = 0.0  # env steps with a non-fatal contact overflow (Parkour: trunk on > 50 prisms)
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

    # ------------------------------------------------------------------ pieces of an iteration
    def collect(self, interruptible: bool = True) -> tuple[TensorDictBase | None, TensorDictBase | None]:
        """The rollout (``None`` if a stop request interrupted it) and the episode statistics finished in it.
        ``interruptible=False``: a stop request waits for the end of the rollout (checked between iterations)."""
        # torchrun: the ranks stop together, between iterations (:meth:`train`), never inside a rollout
        stop = self._stop if interruptible and not distributed.is_active() else None
        data = self.rollout.collect(
            on_step=lambda step, horizon: self._call("on_rollout_step", step, horizon),
            should_stop=None if stop is None else stop,
        )
        if data is None:
            return None, None
        return data, self.base_env.pop_episode_stats()

    def _record_episodes(self, stats: TensorDictBase) -> dict[str, float]:
        """Push the iteration's per-task episode statistics into the success window (a device -> host copy: on
        a GPU it also ends the collection timing) and return the run's env health totals
        (:data:`ENV_HEALTH_TOTALS`) that the env reports."""
        distributed.all_reduce_stats_(stats)  # torchrun: every rank's episodes
        reported = [(stats.get(key, None), attr, metric) for key, attr, metric in ENV_HEALTH_TOTALS]
        self.window.push(stats)
        totals: dict[str, float] = {}
        for value, attr, metric in reported:  # each optional: envs other than mtbench's may not report them
            if value is not None:
                setattr(self, attr, getattr(self, attr) + float(value.sum()))
                totals[metric] = getattr(self, attr)
        return totals

    @staticmethod
    def _named_update_metrics(means: dict[str, float]) -> dict[str, float]:
        """``loss_x`` -> ``loss/x``, every other update metric -> ``train/<name>``."""
        return {f"loss/{k[5:]}" if k.startswith("loss_") else f"train/{k}": v for k, v in means.items()}

    def train_iteration(self) -> dict[str, float] | None:
        """One iteration; returns its metrics (``None``: a stop request interrupted the rollout)."""
        raise NotImplementedError

    # ------------------------------------------------------------------ main loop
    def train(self) -> list[dict[str, float]]:
        """Run until ``total_iterations`` (or a stop request); returns the metrics of this call's iterations."""
        history: list[dict[str, float]] = []
        with StopRequest() as stop:
            self._stop = stop
            try:
                self._call("on_train_start")
                while self.iteration < self.total_iterations and not self._stop_requested(stop):
                    stop.rearm()
                    metrics = self.train_iteration()
                    if metrics is None:
                        break
                    history.append(metrics)
            except BaseException as error:
                self._call("on_error", error)
                raise
            finally:
                self._stop = None
            self._call("on_train_end", self._stop_requested(stop))
        return history

    def _stop_requested(self, stop: StopRequest) -> bool:
        """Whether a stop was requested (torchrun: on any rank; every rank gets the same answer)."""
        return distributed.any_rank(stop.requested, self.env.device)

    def success_table(self) -> str:
        """End-of-run per-task table (success over the last ``success_window`` iterations)."""
        return self.window.table()

    @staticmethod
    def _timing(t0: float, t1: float, t2: float, frames: int) -> dict[str, float]:
        return {
            "fps": frames / max(t2 - t0, 1e-9),
            "fps_collect": frames / max(t1 - t0, 1e-9),
            "time/collect_s": t1 - t0,
            "time/update_s": t2 - t1,
        }

    # ------------------------------------------------------------------ checkpointing
    def env_info(self) -> dict[str, Any]:
        """Properties of the env that define what a run measures (recorded in logs and checkpoints; a run only
        resumes from a checkpoint with the same values): the env class, its ``reward_version`` and the revision of
        that version's definition (``reward_revision``, Meta-World: ``task.REWARD_REVISIONS``)."""
        return {"env_class": type(self.base_env).__name__,
                "reward_version": getattr(self.base_env, "reward_version", None),
                "reward_revision": getattr(self.base_env, "reward_revision", None)}

    def _counters(self) -> dict[str, Any]:
        return {
            "iteration": self.iteration,
            "frames": self.frames,
            "updates": self.updates,
            "unhealthy_resets": self.unhealthy_resets,
            "nonfinite_actions": self.nonfinite_actions,
            "contact_overflows": self.contact_overflows,
        }

    def _extra_state(self) -> dict[str, Any]:
        """Loop-specific checkpoint entries (none here)."""
        return {}

    def _load_extra_state(self, state: dict[str, Any], source: str | os.PathLike[str]) -> None:
        """Restore :meth:`_extra_state`."""

    def state_dict(self) -> dict[str, Any]:
        """Everything needed to continue the run bit for bit (on the same device type): counters, the loss
        (parameters, estimator statistics, target networks), the gradient method, the optimizer (incl. its
        learning rates), the env (``base_env.state_dict()``: physics, episode clocks, its generator) and the
        state of its transforms (observation statistics), the rollout's carried state (and the steps of an
        interrupted rollout), the success window, the hooks, the Python/NumPy/torch/CUDA generators, and the
        loop's own entries (:meth:`_extra_state`)."""
        return {
            "version": CHECKPOINT_VERSION,
            "config": None if self.config is None else OmegaConf.to_container(self.config, resolve=True),
            "env_info": self.env_info(),
            "counters": self._counters(),
            "loss": self.loss.state_dict(),
            "update_module": None if self.update_module is self.loss else self.update_module.state_dict(),
            "optimizer": self.optimizer.state_dict(),
            "env": self.base_env.state_dict(),
            "transforms": [level.transform.state_dict() for level in transformed_levels(self.env)],
            # the observation statistics again under their own name, for tools that rebuild the policy
            # (mtbench.evaluation); the same tensors: saved once
            "obs_norm": None if (norm := observation_norm(self.env)) is None else norm.state_dict(),
            "rollout": self.rollout.state_dict(),
            "window": self.window.state_dict(),
            "hooks": {h.name: h.state_dict() for h in self.hooks},
            "rng": rng_state(),
            # torchrun: each rank's file holds its own env, rollout and generators; a run resumes with as many ranks
            "distributed": {"rank": distributed.rank(), "world_size": self.world_size},
            **self._extra_state(),
        }

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write :meth:`state_dict` to ``path`` (atomic, checksummed)."""
        return save_checkpoint(path, self.state_dict())

    def load(self, path: str | os.PathLike[str]) -> None:
        """Restore a checkpoint file written by :meth:`save`."""
        self.load_state_dict(load_checkpoint(path), source=path)

    def _after_optimizer_load(self) -> None:
        """Called once the optimizer state is loaded (its state lives in new tensors)."""

    def load_state_dict(self, state: dict[str, Any], source: str | os.PathLike[str] = "checkpoint") -> None:
        """Restore :meth:`state_dict`; refuses a checkpoint of another configuration (``resume_keys``) or env, and one
        that holds the networks only (e.g. docs/results/checkpoints: no optimizer, env or rollout state)."""
        missing = [key for key in ("counters", "loss", "optimizer", "env", "rollout") if key not in state]
        if missing:
            raise CheckpointError(source, f"holds no {', '.join(missing)} state (a networks-only checkpoint?), so a run "
                                          f"cannot continue from it exactly; start one from its weights with "
                                          f"pretrained={source}")
        diffs = []
        if self.config is not None and state.get("config") is not None:
            saved = OmegaConf.create(state["config"])
            for key in self.resume_keys:
                default = self.resume_defaults.get(key)
                a = OmegaConf.select(saved, key, default=default)
                b = OmegaConf.select(self.config, key, default=default)
                if a != b:
                    diffs.append(f"{key}: checkpoint={a!r} current={b!r}")
        saved_info = dict(state.get("env_info") or {})
        if "reward_revision" not in saved_info and saved_info.get("reward_version") == "v2":
            saved_info["reward_revision"] = LEGACY_V2_REVISION
        for key, value in self.env_info().items():
            saved_value = saved_info.get(key, value)
            if saved_value != value:
                diffs.append(f"env {key}: checkpoint={saved_value!r} current={value!r}")
        saved_ranks = dict(state.get("distributed") or {"rank": 0, "world_size": 1})
        if int(saved_ranks["world_size"]) != self.world_size or int(saved_ranks["rank"]) != distributed.rank():
            diffs.append(f"processes: checkpoint=rank {saved_ranks['rank']} of {saved_ranks['world_size']} "
                         f"current=rank {distributed.rank()} of {self.world_size} (a run resumes with the number of "
                         f"torchrun processes it was started with, each from its own file)")
        if diffs:
            raise ValueError(f"cannot resume from {source}: configuration differs ({'; '.join(diffs)})")
        c = state["counters"]
        self.iteration, self.frames, self.updates = int(c["iteration"]), int(c["frames"]), int(c["updates"])
        self.unhealthy_resets = float(c["unhealthy_resets"])
        self.nonfinite_actions = float(c["nonfinite_actions"])
        self.contact_overflows = float(c.get("contact_overflows", 0.0))  # not in checkpoints before 2026-11-28
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
        self._after_optimizer_load()
        levels = transformed_levels(self.env)
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
        self._load_extra_state(state, source)
        set_rng_state(state["rng"])


__all__ = ["TrainingLoop", "observation_norm", "tasks_with_worlds", "transformed_levels"]
