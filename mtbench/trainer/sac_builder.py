"""Build an MT-SAC run (``loss=sac``) from the Hydra config: the shared builder pieces (env, hooks, gradient
method) plus the raw-observation copy for the replay buffer, the tanh-Gaussian actor and twin Q networks, the
``MTSACLoss``, fused Adam with one learning rate per network, the soft target update and the off-policy loop."""

from __future__ import annotations

from typing import Any, Mapping

import torch
from omegaconf import DictConfig
from torch import nn
from torchrl.envs import Compose, EnvBase, RenameTransform, TransformedEnv
from torchrl.objectives import SoftUpdate

from ..objectives import MTSACLoss
from ..transforms import PerTaskObservationNorm
from ..utils import distributed
from .env_factory import network_sizes
from .off_policy import RAW_OBSERVATION_KEY, OffPolicyTrainer
from .rollout import base_env
from .soft_actor_critic import make_qvalue, make_sac_actor

#: MT-SAC's parameter groups: learning-rate key of ``loss`` and the loss attribute holding the parameters
SAC_PARAM_GROUPS = {"actor": "actor_lr", "critic": "critic_lr", "alpha": "alpha_lr"}


def add_observation_norm_keep_raw(env: EnvBase, loss_cfg: Mapping[str, Any]) -> EnvBase:
    """``TransformedEnv(env, Compose(RenameTransform(observation -> observation_raw, copy),
    PerTaskObservationNorm))`` when ``loss.normalize_input`` (default), else ``env``: the policy sees normalised
    observations (statistics updated during collection, as in the on-policy loop) and the replay buffer stores
    the raw ones, normalised with the current statistics when sampled."""
    if not loss_cfg.get("normalize_input", True):
        return env
    base = base_env(env)
    keep_raw = RenameTransform(["observation"], [RAW_OBSERVATION_KEY], create_copy=True)
    norm = PerTaskObservationNorm(base.num_tasks, state_dim=getattr(base, "state_dim", None), device=env.device)
    return TransformedEnv(env, Compose(keep_raw, norm))


def build_sac_networks(
    cfg: DictConfig, env: EnvBase, device: torch.device
) -> tuple[nn.Module, list[nn.Module]]:
    """The tanh-Gaussian actor (the arch preset's ``actor`` network) and ``loss.num_qvalue_nets`` independently
    initialised Q networks (its ``critic`` network on observation + action), sized from the env's specs."""
    n, arch = network_sizes(env), cfg.get("arch")
    actor = make_sac_actor(arch, obs_dim=n.obs_dim, action_dim=n.action_dim, num_tasks=n.num_tasks,
                           task_descriptions=n.task_descriptions, log_std_bounds=list(cfg.loss.log_std_bounds),
                           device=device)
    qvalues = [make_qvalue(arch, obs_dim=n.obs_dim, action_dim=n.action_dim, num_tasks=n.num_tasks,
                           task_descriptions=n.task_descriptions, device=device)
               for _ in range(int(cfg.loss.get("num_qvalue_nets", 2)))]
    return actor, qvalues


def build_sac_loss(
    loss_cfg: Mapping[str, Any], actor: nn.Module, qvalues: list[nn.Module], num_tasks: int, action_dim: int,
    device: torch.device,
) -> MTSACLoss:
    """``MTSACLoss`` with the config's hyperparameters: per-task temperatures (``disentangled_alpha``) starting at
    ``init_alpha``, learnable unless ``learnable_temperature`` is false, target entropy ``-target_entropy_coef *
    |A|``, temperature loss ``alpha_loss``, MSE Q loss, TD(0) targets with ``gamma``."""
    lc = loss_cfg
    return MTSACLoss(
        actor,
        qvalues,
        num_tasks=num_tasks,
        num_qvalue_nets=len(qvalues),
        loss_function="l2",
        alpha_init=float(lc["init_alpha"]),
        fixed_alpha=not bool(lc["learnable_temperature"]),
        target_entropy=-float(lc["target_entropy_coef"]) * action_dim,
        per_task_alpha=bool(lc["disentangled_alpha"]),
        alpha_loss=str(lc["alpha_loss"]),
        gamma=float(lc["gamma"]),
    ).to(device)


def sac_parameter_groups(loss: MTSACLoss) -> dict[str, list[nn.Parameter]]:
    """The trainable parameters of the actor, the Q networks and the temperatures (the temperatures are absent
    when they are fixed)."""
    groups = {
        "actor": [p for p in loss.actor_network_params.values(True, True) if isinstance(p, nn.Parameter)],
        "critic": [p for p in loss.qvalue_network_params.values(True, True) if isinstance(p, nn.Parameter)],
        "alpha": [loss.log_alpha] if isinstance(loss.log_alpha, nn.Parameter) else [],
    }
    return {name: params for name, params in groups.items() if params}


def build_sac_optimizer(
    loss: MTSACLoss, loss_cfg: Mapping[str, Any], device: torch.device, capturable: bool = False
) -> torch.optim.Adam:
    """Fused Adam with one parameter group per network (``actor_lr``, ``critic_lr``, ``alpha_lr``; named, so the
    logs show ``train/lr_actor``, ...), tensor learning rates and ``loss.adam_eps`` (MTBench: three Adam
    optimizers with torch's defaults); ``capturable`` for a CUDA-graphed update."""
    groups = [{"params": params, "name": name, "lr": torch.tensor(float(loss_cfg[SAC_PARAM_GROUPS[name]]),
                                                                    device=device)}
              for name, params in sac_parameter_groups(loss).items()]
    return torch.optim.Adam(groups, eps=float(loss_cfg.get("adam_eps", 1e-8)), fused=True, capturable=capturable)


def check_sac_features(cfg: DictConfig) -> None:
    """The trainer options that loss=sac does not support yet, refused with one clear error each."""
    for key, what in (("compile", "torch.compile of the networks"), ("cudagraphs", "a CUDA-graphed policy")):
        if cfg.get(key, False):
            raise ValueError(f"{key}=true ({what}) is not supported with loss=sac; set {key}=false")


def build_sac_trainer(
    cfg: DictConfig,
    env: EnvBase,
    device: torch.device,
    *,
    hooks: list[Any],
    update_module_factory: Any,
    total_iterations: int,
) -> OffPolicyTrainer:
    """The off-policy loop of ``cfg`` on ``env`` (already built and seeded by
    :func:`~mtbench.trainer.builder.build_trainer`): observation normalisation with a raw copy, networks, loss,
    gradient method (``update_module_factory(loss, num_tasks)``), optimizer, ``SoftUpdate(tau=critic_tau)`` and
    the hooks. ``cudagraph_update`` (:func:`~mtbench.trainer.builder.resolve_graph_update`; ``auto``: on for CUDA)
    replays the updates from a CUDA graph once the replay buffer is full, with a ``capturable`` optimizer."""
    from .builder import graph_safe_update, resolve_graph_update  # builder imports this module

    check_sac_features(cfg)
    lc = cfg.loss
    env = add_observation_norm_keep_raw(env, lc)
    actor, qvalues = build_sac_networks(cfg, env, device)
    num_tasks = int(base_env(env).num_tasks)
    loss = build_sac_loss(lc, actor, qvalues, num_tasks, int(env.action_spec.shape[-1]), device)
    distributed.broadcast_module_(loss)  # torchrun: every rank starts from rank 0's networks (and target networks)
    ranks = distributed.world_size()  # torchrun: each rank replays its share of every batch from its own buffer
    target_update = SoftUpdate(loss, tau=float(lc["critic_tau"]))
    max_grad_norm = lc.get("max_grad_norm")
    update_module = update_module_factory(loss, num_tasks)
    graph_update = resolve_graph_update(cfg.get("cudagraph_update", "auto"), device,
                                        graph_safe_update(update_module, loss))
    return OffPolicyTrainer(
        env,
        actor,
        loss,
        build_sac_optimizer(loss, lc, device, capturable=graph_update),
        horizon=int(lc.horizon),
        gradient_steps=int(lc.gradient_steps_per_iteration),
        batch_size=int(lc.batch_size) // ranks,
        replay_buffer_size=int(lc.replay_buffer_size) // ranks,
        nstep=int(lc.nstep),
        gamma=float(lc.gamma),
        warmup_steps=int(lc.warmup_steps),
        total_iterations=total_iterations,
        target_update=target_update.step,
        update_module=update_module,
        max_grad_norm=None if max_grad_norm is None else float(max_grad_norm),
        clip_groups=sac_parameter_groups(loss),
        hooks=hooks,
        success_window=int(cfg.get("success_window", 5)),
        replay_in_checkpoint=bool(lc.get("replay_in_checkpoint", True)),
        config=cfg,
        cudagraph_update=graph_update,
        overlap_update=lc.get("overlap_update", False),
    )


__all__ = [
    "SAC_PARAM_GROUPS",
    "add_observation_norm_keep_raw",
    "build_sac_loss",
    "build_sac_networks",
    "build_sac_optimizer",
    "build_sac_trainer",
    "check_sac_features",
    "sac_parameter_groups",
]
