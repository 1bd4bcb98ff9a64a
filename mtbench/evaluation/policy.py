"""Rebuild what a checkpoint needs for evaluation: the env (fresh worlds), the actor and the frozen normaliser."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any, Mapping

import torch
from omegaconf import DictConfig, OmegaConf
from tensordict import TensorDict, TensorDictBase
from tensordict.nn import InteractionType, set_interaction_type
from torch import nn

from ..envs.make import is_parkour
from ..trainer.actor_critic import GaussianPolicyHead, make_actor
from ..trainer.builder import ACTION_CLIP
from ..trainer.checkpoint import load_checkpoint
from ..trainer.trainer import make_env_from_cfg
from ..transforms import PerTaskObservationNorm
from .args import EvalArgumentError
from .task_slots import TaskSlots

ACTOR_PREFIX = "actor_network_params."


def read_checkpoint(path: Any) -> dict[str, Any]:
    """``load_checkpoint(path)`` with one clear error for anything that is not a training checkpoint."""
    if Path(path).is_dir():
        raise EvalArgumentError(f"checkpoint={str(path)!r} is a directory; give a checkpoint file") from None
    try:
        state = load_checkpoint(path, map_location="cpu")
    except FileNotFoundError:
        raise EvalArgumentError(f"checkpoint={str(path)!r}: no such file") from None
    except Exception as err:  # unpickling errors, truncated files, other versions, ...
        raise EvalArgumentError(
            f"checkpoint={str(path)!r} cannot be read as a checkpoint written by Trainer.save "
            f"({type(err).__name__}: {err})"
        ) from None
    missing = [k for k in ("config", "loss") if k not in state]
    if missing:
        raise EvalArgumentError(f"checkpoint={str(path)!r} lacks {missing}: not a checkpoint written by Trainer.save")
    return state


def checkpoint_num_tasks(state: Mapping[str, Any]) -> int | None:
    """Number of tasks of the checkpointed run, from the env state or the per-task statistics it holds."""
    extra = (state.get("env") or {}).get("_extra_state")
    if isinstance(extra, Mapping) and extra.get("task_names"):
        return len(extra["task_names"])
    if isinstance(extra, Mapping) and extra.get("columns"):  # Parkour: worlds are split over the terrain columns
        return len(extra["columns"])
    for part, key in (("obs_norm", "stats.count"), ("loss", "value_norm.count")):
        tensor = (state.get(part) or {}).get(key)
        if isinstance(tensor, torch.Tensor) and tensor.ndim == 1:
            return int(tensor.numel())
    return None


def eval_env_config(config: Mapping[str, Any], num_envs: int) -> DictConfig:
    """The run's ``env`` config with ``num_envs`` worlds and no staggered start (every world starts its first
    episode at step 0: ``random_start_progress=False``). A Parkour run whose config predates
    ``robot_contact_timeconst`` (2026-11-28) trained on MuJoCo's soft contacts and is evaluated on them."""
    env_cfg = OmegaConf.create(copy.deepcopy(OmegaConf.to_container(OmegaConf.create(dict(config)), resolve=True)))
    env_cfg.num_envs = int(num_envs)
    if env_cfg.get("overrides") is None:
        env_cfg.overrides = {}
    env_cfg.overrides.random_start_progress = False
    if is_parkour(env_cfg.name) and "robot_contact_timeconst" not in env_cfg.overrides:
        env_cfg.overrides.robot_contact_timeconst = None
    return env_cfg


def make_eval_env(config: Mapping[str, Any], num_envs: int, device: torch.device, seed: int) -> Any:
    """``make_env_from_cfg`` on the run's env config with fresh worlds (``seed``) and no staggered start."""
    env = make_env_from_cfg(eval_env_config(config, num_envs), device, seed)
    # TorchRL reads the native-autoreset flag from the instance __dict__ (see mtbench.trainer)
    if getattr(type(env), "_torchrl_native_autoreset", False):
        env.__dict__["_torchrl_native_autoreset"] = True
    return env


def normalized_input(td: TensorDictBase, obs_norm: PerTaskObservationNorm | None,
                     task_slots: TaskSlots | None = None) -> TensorDict:
    """A new tensordict with ``td``'s ``observation`` (normalised by the frozen ``obs_norm``, if any) and
    ``task_id``: the input of an evaluated network; with ``task_slots`` (an env of some of the run's Meta-World
    tasks) the task ids and one-hots of the policy's slots. ``td`` is not modified."""
    obs, task_id = td.get("observation"), td.get("task_id")
    if task_slots is not None:
        obs, task_id = task_slots.policy_input(obs, task_id)
    if obs_norm is not None:
        obs = obs_norm.normalize(obs, task_id)  # frozen: no statistics update
    return TensorDict({"observation": obs, "task_id": task_id}, batch_size=td.batch_size, device=td.device)


class EvalPolicy(nn.Module):
    """The trained actor behind the frozen per-task observation normaliser.

    ``forward(td, deterministic)`` returns the action for ``td["observation"]`` / ``td["task_id"]``:
    sampled from the Gaussian policy (as in training and in the paper's evaluation) or its mean
    (``deterministic=True``), clamped to ``[action_low, action_high]``: the env's action bounds, or ``[-1, 1]`` for a
    run that clamped its actions in training (``loss.clip_actions``). The input tensordict is not modified.
    """

    def __init__(self, actor: nn.Module, obs_norm: PerTaskObservationNorm | None,
                 action_low: torch.Tensor | float = -1.0, action_high: torch.Tensor | float = 1.0,
                 task_slots: TaskSlots | None = None) -> None:
        super().__init__()
        self.actor = actor
        self.obs_norm = obs_norm
        self.task_slots = task_slots
        self.register_buffer("action_low", torch.as_tensor(action_low, dtype=torch.float32))
        self.register_buffer("action_high", torch.as_tensor(action_high, dtype=torch.float32))
        if obs_norm is not None:
            obs_norm.freeze()
        self.eval()

    @property
    def head(self) -> GaussianPolicyHead:
        """The Gaussian head (its ``log_std`` parameter sets the sampling noise)."""
        return next(m for m in self.actor.modules() if isinstance(m, GaussianPolicyHead))

    @torch.no_grad()
    def forward(self, td: TensorDictBase, deterministic: bool = False) -> torch.Tensor:
        inp = normalized_input(td, self.obs_norm, self.task_slots)
        kind = InteractionType.DETERMINISTIC if deterministic else InteractionType.RANDOM
        with set_interaction_type(kind):
            action = self.actor(inp).get("action")
        return torch.clamp(action, self.action_low, self.action_high)


def _non_persistent_buffers(module: nn.Module) -> list[str]:
    """Dotted names of the non-persistent buffers of ``module`` and its submodules."""
    return [f"{prefix}.{name}" if prefix else name for prefix, sub in module.named_modules()
            for name in getattr(sub, "_non_persistent_buffers_set", ())]


def policy_task_sizes(env: Any, task_slots: TaskSlots | None) -> tuple[int, int, list[str] | None]:
    """``(num_tasks, obs_dim, task_descriptions)`` of the policy that acts in ``env``: the env's own, or with
    ``task_slots`` those of the run's task set (its one-hot width and descriptions)."""
    num_tasks = int(env.num_tasks)
    obs_dim = int(env.observation_spec["observation"].shape[-1])
    descriptions = getattr(env, "task_descriptions", None)
    if task_slots is None:
        return num_tasks, obs_dim, list(descriptions) if descriptions is not None else None
    return task_slots.num_slots, obs_dim - num_tasks + task_slots.num_slots, task_slots.descriptions


def load_policy(state: Mapping[str, Any], env: Any, device: torch.device,
                task_slots: TaskSlots | None = None) -> nn.Module:
    """Actor (``make_actor`` with the run's arch) and observation normaliser of a checkpoint, for ``env``; for a
    ``loss=pqn`` checkpoint the Q network's greedy / epsilon-greedy policy (:mod:`~mtbench.evaluation.q_policy`).
    ``task_slots``: ``env`` has some of the run's Meta-World tasks (:mod:`~mtbench.evaluation.task_slots`)."""
    cfg = OmegaConf.create(state["config"])
    if (cfg.get("loss") or {}).get("name") == "pqn":
        from .q_policy import load_q_policy

        return load_q_policy(state, env, device, task_slots)
    num_tasks, obs_dim, descriptions = policy_task_sizes(env, task_slots)
    action_dim = int(env.action_spec.shape[-1])
    actor = make_actor(
        cfg.get("arch"), obs_dim=obs_dim, action_dim=action_dim, num_tasks=num_tasks,
        task_descriptions=descriptions, device=device,
    )
    weights = {k[len(ACTOR_PREFIX):]: v for k, v in state["loss"].items() if k.startswith(ACTOR_PREFIX)}
    # TorchRL's loss modules keep every buffer of their networks, also the non-persistent ones (e.g. MOORE's task
    # one-hots) that the actor's own state_dict leaves out
    for name in _non_persistent_buffers(actor):
        weights.pop(name, None)
    try:
        actor.load_state_dict(weights, strict=True)
    except RuntimeError as err:
        raise EvalArgumentError(
            f"the checkpoint's actor does not fit the rebuilt one (arch={cfg.get('arch', {}).get('name')!r}, "
            f"obs_dim={obs_dim}, action_dim={action_dim}): {err}"
        ) from None
    obs_norm = None
    norm_state = state.get("obs_norm")
    if (cfg.get("loss") or {}).get("normalize_input", True) and norm_state is not None:
        obs_norm = PerTaskObservationNorm(num_tasks, state_dim=int(norm_state["stats.mean"].shape[-1]), device=device)
        obs_norm.load_state_dict(norm_state)
    # the env's action bounds (a bounded spec): [-1, 1] for Meta-World, +-5 for Parkour; [-1, 1] otherwise and for a
    # run that clamped its actions to [-1, 1] in training (loss.clip_actions, as MTBench's Go1 configs)
    low, high = getattr(env.action_spec, "low", None), getattr(env.action_spec, "high", None)
    if (cfg.get("loss") or {}).get("clip_actions", False):
        low, high = -ACTION_CLIP, ACTION_CLIP
    elif isinstance(low, torch.Tensor) and isinstance(high, torch.Tensor):
        low, high = low.reshape(-1, action_dim)[0], high.reshape(-1, action_dim)[0]
    else:
        low, high = -1.0, 1.0
    return EvalPolicy(actor, obs_norm, low, high, task_slots).to(device)


__all__ = ["ACTOR_PREFIX", "EvalPolicy", "checkpoint_num_tasks", "eval_env_config", "load_policy",
           "make_eval_env", "read_checkpoint"]
