"""Build a training run from the Hydra config: env, transforms, networks, loss, value estimator, gradient method,
optimizer, rollout and hooks. The pieces are separate functions so that other loops (e.g. off-policy) reuse them."""

from __future__ import annotations

from typing import Any, Mapping

import torch
from omegaconf import DictConfig, OmegaConf
from torch import nn
from torchrl.envs import ClipTransform, EnvBase, Transform, TransformedEnv

from ..modules.q_network import DecomposedQNetwork
from ..objectives import MTGRPOLoss, MTPPOLoss, MTPQNLoss, make_gradient_method
from ..objectives.ppo import MTClipPPOBase
from ..transforms import PerTaskObservationNorm
from ..utils import distributed
from .actor_critic import GaussianPolicyHead, make_actor, make_critic
from .checkpoint import CheckpointError, load_checkpoint, seed_everything
from .config import (
    as_config,
    check_config,
    effective_minibatch_size,
    resolve_device,
    resolve_run_paths,
    total_iterations,
    warn_if_cpu_run_too_big,
)
from .env_factory import make_env_from_cfg, network_sizes
from .hooks import AdaptiveLR, Checkpointer, MetricsLogger, NonFiniteGuard, ProgressHook, TrainerHook
from .loop import TrainingLoop
from .pqn import build_pqn_loss, build_radam, discrete_action_env, make_pqn_policy, pqn_hold_keys, pqn_hooks
from .pretraining import load_pretrained
from .ranks import join_run, rank_env_config, rank_file, rank_seed, share_run_paths
from .rollout import base_env
from .sac_builder import build_sac_trainer
from .trainer import Trainer


def build_env(cfg: DictConfig, device: torch.device) -> EnvBase:
    """``mtbench.envs.make_env(env.name, num_envs=env.num_envs, device=..., seed=seed, **env.overrides)``; warns
    first when the run is far too big for the CPU. Under torchrun: this rank's share of the worlds, from its own
    seed (:mod:`~mtbench.trainer.ranks`)."""
    env_cfg = rank_env_config(cfg.env)
    warn_if_cpu_run_too_big(device, int(env_cfg["num_envs"]), int(cfg.loss.horizon))
    return make_env_from_cfg(env_cfg, device, rank_seed(int(cfg.seed)))


ACTION_CLIP = 1.0  # rl_games clip_actions: the sampled action is clamped to [-ACTION_CLIP, ACTION_CLIP]


def add_action_clip(env: EnvBase, loss_cfg: Mapping[str, Any]) -> EnvBase:
    """rl_games' ``clip_actions`` (``loss.clip_actions: true``): the env receives the sampled action clamped to
    ``[-1, 1]`` (TorchRL's ``ClipTransform`` on the action, applied on the way into the env), while the rollout keeps
    the raw sample, whose log-probability the loss uses (rl_games stores the unclamped action too). ``env``
    unchanged when ``clip_actions`` is false (default). MTBench's Go1 configs clamp (docs/parkour.md, "Action
    clipping"): with Parkour's action scale 1 the joint targets stay within 1 rad of the default pose, where the
    env's own clip alone allows 5 rad."""
    if not loss_cfg.get("clip_actions", False):
        return env
    bound = torch.tensor(ACTION_CLIP, device=env.device)
    return append_transform(env, ClipTransform(in_keys_inv=["action"], out_keys_inv=["action"], low=-bound,
                                               high=bound))


def add_observation_norm(env: EnvBase, loss_cfg: Mapping[str, Any]) -> EnvBase:
    """``TransformedEnv(env, PerTaskObservationNorm)`` when ``loss.normalize_input`` (default), else ``env``."""
    if not loss_cfg.get("normalize_input", True):
        return env
    base = base_env(env)
    norm = PerTaskObservationNorm(base.num_tasks, state_dim=getattr(base, "state_dim", None), device=env.device)
    return append_transform(env, norm)


def append_transform(env: EnvBase, transform: Transform) -> EnvBase:
    """``env`` with ``transform`` last: appended to a ``TransformedEnv``'s transforms (one level of transforms, as
    TorchRL lays them out; e.g. PQN's discrete actions, then the action clip, then the observation statistics), or a
    new ``TransformedEnv``."""
    if isinstance(env, TransformedEnv):
        env.append_transform(transform)
        return env
    return TransformedEnv(env, transform)


def build_networks(cfg: DictConfig, env: EnvBase, device: torch.device) -> tuple[nn.Module, nn.Module | None]:
    """The Gaussian actor and (for PPO) the critic of the ``arch`` preset, sized from the env's specs; for PQN the
    epsilon-greedy policy of the decomposed Q network (no critic)."""
    if cfg.loss.name == "pqn":
        return make_pqn_policy(cfg, env, device), None
    n, arch = network_sizes(env), cfg.get("arch")
    actor = make_actor(arch, obs_dim=n.obs_dim, action_dim=n.action_dim, num_tasks=n.num_tasks,
                       task_descriptions=n.task_descriptions, log_std_init=float(cfg.loss.get("log_std_init", 0.0)),
                       device=device)
    critic = None
    if cfg.loss.name == "ppo":
        critic = make_critic(arch, obs_dim=n.obs_dim, num_tasks=n.num_tasks, task_descriptions=n.task_descriptions,
                             device=device)
    return actor, critic


def compile_networks(actor: nn.Module, critic: nn.Module | None, mode: str | None) -> None:
    """``torch.compile`` the actor and critic networks in place (``nn.Module.compile``): used by the rollout and
    by every loss evaluation. The TensorDict plumbing of the loss and the optimizer step stay eager (compiling
    them whole graph-breaks on TensorDict internals / fused Adam)."""
    nets = [m.net for m in actor.modules() if isinstance(m, (GaussianPolicyHead, DecomposedQNetwork))]
    if critic is not None:
        nets.append(critic.module)
    for net in nets:
        net.compile(mode=mode)


def build_loss(loss_cfg: Mapping[str, Any], actor: nn.Module, critic: nn.Module | None, num_tasks: int,
               device: torch.device) -> MTClipPPOBase | MTPQNLoss:
    """``MTPPOLoss`` (``loss=ppo``, value estimator ``PerTaskGAE``), ``MTGRPOLoss`` (``loss=grpo``,
    ``PerTaskMCAdvantage``) or ``MTPQNLoss`` (``loss=pqn``, ``PengQLambda``; ``actor`` is the Q policy) with the
    config's hyperparameters."""
    lc = loss_cfg
    if lc["name"] == "pqn":
        return build_pqn_loss(lc, actor, num_tasks, device)
    common = dict(num_tasks=num_tasks, clip_epsilon=float(lc["clip_epsilon"]), entropy_coeff=float(lc["entropy_coeff"]),
                  bounds_coeff=float(lc["bounds_coeff"]), soft_bound=float(lc["soft_bound"]), gamma=float(lc["gamma"]))
    if lc["name"] == "grpo":
        return MTGRPOLoss(actor, **common).to(device)
    return MTPPOLoss(
        actor,
        critic,
        critic_coef=float(lc["critic_coef"]),
        clip_value=None if lc.get("clip_value") is None else float(lc["clip_value"]),
        lmbda=float(lc["lmbda"]),
        normalize_value=bool(lc["normalize_value"]),
        value_norm_clip=None if lc.get("value_norm_clip") is None else float(lc["value_norm_clip"]),
        per_task_advantage_norm=bool(lc["per_task_advantage_norm"]),
        **common,
    ).to(device)


def build_gradient_method(grad_cfg: Mapping[str, Any] | None, loss: nn.Module, num_tasks: int) -> nn.Module:
    """``make_gradient_method(grad.name, loss, num_tasks, **grad)``: the loss itself for ``grad=none`` (or a
    diagnostics wrapper when ``diagnostics_every > 0``), else the PCGrad / CAGrad / FAMO wrapper."""
    if grad_cfg is None:
        return loss
    kwargs = OmegaConf.to_container(grad_cfg, resolve=True) if OmegaConf.is_config(grad_cfg) else dict(grad_cfg)
    name = str(kwargs.pop("name", "none"))
    return make_gradient_method(name, loss, num_tasks, **kwargs)


def graph_safe_update(update_module: nn.Module, loss: nn.Module) -> bool:
    """Whether the minibatch update of ``update_module`` may be replayed from a CUDA graph: the plain loss, or a
    gradient method whose ``cuda_graph_safe`` says so (PCGrad, CAGrad, FAMO, GradientDiagnostics)."""
    return update_module is loss or bool(getattr(update_module, "cuda_graph_safe", False))


def resolve_graph_update(value: Any, device: torch.device, graph_safe: bool) -> bool:
    """``cudagraph_update``: ``auto`` = on for CUDA when the update is graph-safe (:func:`graph_safe_update`: the
    plain loss and every gradient method, their diagnostics scheduled between replays), for every loss (PPO, GRPO,
    PQN; SAC once its replay buffer is full): each compared with its eager update on an H200 by
    ``benchmarks/update_check.py [--loss pqn|sac]``; ``true`` = on (an error where that is not possible);
    ``false`` = off."""
    if value is None or str(value) == "auto":  # off under torchrun: the gradient all-reduce is not captured
        return device.type == "cuda" and graph_safe and not distributed.is_active()
    if not isinstance(value, bool):
        raise ValueError(f"cudagraph_update must be auto, true or false; got {value!r}")
    if value and not graph_safe:
        raise ValueError("cudagraph_update=true needs a graph-safe update module (the plain loss, or a gradient "
                         "method whose cuda_graph_safe is True); use auto or false")
    if value and device.type != "cuda":
        raise ValueError(f"cudagraph_update=true needs a CUDA device (device={device}); use auto or false")
    return value


def build_optimizer(
    loss: nn.Module, loss_cfg: Mapping[str, Any], device: torch.device, capturable: bool
) -> torch.optim.Optimizer:
    """Fused Adam (``loss.lr``, ``loss.adam_eps``) over the loss's trainable parameters, with a tensor learning
    rate (changed in place by the adaptive schedule; ``capturable`` for a CUDA-graphed update); RAdam for PQN
    (:func:`~mtbench.trainer.pqn.build_radam`: a tensor learning rate, ``capturable`` whenever the device is CUDA,
    so the same optimizer serves the eager and the CUDA-graphed update)."""
    if loss_cfg.get("name") == "pqn":
        return build_radam(loss, loss_cfg, device)
    params = [p for p in loss.parameters() if p.requires_grad]
    lr = torch.tensor(float(loss_cfg["lr"]), device=device)
    return torch.optim.Adam(params, lr=lr, eps=float(loss_cfg["adam_eps"]), fused=True, capturable=capturable)


def uses_epoch_kl_reference(loss_cfg: Mapping[str, Any]) -> bool:
    """Whether the run adapts its learning rate as rl_games' ``schedule_type: standard`` (``loss.lr_schedule:
    adaptive`` with ``loss.lr_schedule_type: standard``): then the loop also measures each minibatch's KL against
    the policy one epoch earlier (rl_games' ``update_mu_sigma``; ``Trainer(kl_reference=True)``)."""
    return (loss_cfg.get("name") in ("ppo", "grpo") and loss_cfg.get("lr_schedule", "fixed") == "adaptive"
            and loss_cfg.get("lr_schedule_type", "minibatch") == "standard")


def build_hooks(cfg: DictConfig, logger: Any = None) -> list[TrainerHook]:
    """The hooks of a run, in call order: non-finite guard, the PQN schedules (``loss=pqn``: epsilon, learning-rate
    decay), adaptive learning rate (``loss.lr_schedule=adaptive``), metrics logger (when ``logger`` is given),
    progress display, checkpoints."""
    lc, ck, lg = cfg.loss, cfg.checkpoint, cfg.logging
    hooks: list[TrainerHook] = [NonFiniteGuard(int(cfg.get("max_nonfinite_iterations", 10)))]
    if lc.get("name") == "pqn":
        hooks += pqn_hooks(lc)  # epsilon schedule, learning-rate decay
    if lc.get("lr_schedule", "fixed") == "adaptive":
        period = "epoch" if uses_epoch_kl_reference(lc) else "minibatch"
        hooks.append(AdaptiveLR(float(lc.get("kl_threshold", 0.008)), float(lc.get("min_lr", 1e-6)),
                                float(lc.get("max_lr", 1e-2)), period=period))
    if logger is not None:
        hooks.append(MetricsLogger(logger))
    if distributed.rank() == 0:  # torchrun: one process prints
        hooks.append(ProgressHook(str(lg.get("progress", "auto")), int(lg.get("print_every", 1) or 1)))
    hooks.append(Checkpointer(ck.dir, int(ck.get("every", 0) or 0), int(ck.get("keep_last", 0) or 0),
                              bool(ck.get("save_final", True))))
    return hooks


def load_resume_checkpoint(cfg: DictConfig) -> dict[str, Any] | None:
    """The checkpoint named by ``resume`` (verified), or ``None``; errors name the parameter."""
    if not cfg.get("resume"):
        return None
    try:
        return load_checkpoint(rank_file(str(cfg.resume), distributed.rank()))  # torchrun: this rank's own file
    except CheckpointError as err:
        raise ValueError(f"resume={cfg.resume}: {err.reason}") from err


def build_trainer(
    cfg: Mapping[str, Any] | DictConfig, env: EnvBase | None = None, logger: Any = None
) -> TrainingLoop:
    """The run of ``cfg`` (``conf/config.yaml`` schema), ready to ``train()``: a :class:`Trainer` (on-policy:
    ``loss=ppo|grpo|pqn``) or an :class:`~mtbench.trainer.off_policy.OffPolicyTrainer` (``loss=sac``, built by
    :func:`~mtbench.trainer.sac_builder.build_sac_trainer`).

    Validates the config (clear errors before anything is built), seeds, sets ``torch_threads`` and
    ``matmul_precision``, fills the run paths (``logging.exp_name``/``log_dir``, ``checkpoint.dir``; a resumed run
    keeps its own), builds the env
    (``env`` if given: any env with the mtbench contract) with per-task observation normalisation, the networks,
    the loss (and its value estimator), the gradient method, fused Adam and the hooks, and restores
    ``resume``'s checkpoint, or else copies the networks of ``pretrained`` (weights only).
    """
    cfg = as_config(cfg)
    check_config(cfg)
    device = join_run(cfg, resolve_device(cfg.get("device", "auto")))  # torchrun: this rank's device
    resumed = load_resume_checkpoint(cfg)
    resolve_run_paths(cfg, None if resumed is None else resumed.get("config"))
    share_run_paths(cfg)
    if cfg.get("cudagraphs", False) and device.type != "cuda":
        raise ValueError(f"cudagraphs=true needs a CUDA device (device={device})")
    if cfg.get("torch_threads"):
        torch.set_num_threads(int(cfg.torch_threads))
    torch.set_float32_matmul_precision(str(cfg.get("matmul_precision", "high")))
    seed_everything(int(cfg.seed))
    off_policy = cfg.loss.name == "sac"
    if env is None:
        if not off_policy:
            effective_minibatch_size(int(cfg.env.num_envs), int(cfg.loss.horizon), int(cfg.loss.minibatch_size))
        env = build_env(cfg, device)
    else:
        warn_if_cpu_run_too_big(device, int(env.batch_size.numel()), int(cfg.loss.horizon))
    # the run's frames per iteration (torchrun: every rank's)
    frames_per_batch = int(env.batch_size.numel()) * int(cfg.loss.horizon) * distributed.world_size()
    if off_policy:
        trainer: TrainingLoop = build_sac_trainer(
            cfg, env, device, hooks=build_hooks(cfg, logger),
            update_module_factory=lambda loss, k: build_gradient_method(cfg.get("grad"), loss, k),
            total_iterations=total_iterations(cfg, frames_per_batch),
        )
        if resumed is not None:
            trainer.load_state_dict(resumed, source=str(cfg.resume))
        return trainer
    if cfg.loss.name == "pqn":
        env = discrete_action_env(env, int(cfg.loss.bins_per_dim))
    env = add_observation_norm(add_action_clip(env, cfg.loss), cfg.loss)
    actor, critic = build_networks(cfg, env, device)
    num_tasks = int(base_env(env).num_tasks)
    loss = build_loss(cfg.loss, actor, critic, num_tasks, device)
    distributed.broadcast_module_(loss)  # torchrun: every rank starts from rank 0's networks
    update_module = build_gradient_method(cfg.get("grad"), loss, num_tasks)
    graph_update = resolve_graph_update(cfg.get("cudagraph_update", "auto"), device,
                                        graph_safe_update(update_module, loss))
    optimizer = build_optimizer(loss, cfg.loss, device, capturable=graph_update)
    if cfg.get("compile", False):
        if update_module is not loss:
            # gradient methods backpropagate several task losses through one graph (retain_graph=True), which a
            # compiled backward with donated buffers refuses ("compiled with non-empty donated buffers")
            torch._functorch.config.donated_buffer = False
        compile_networks(actor, critic, cfg.get("compile_mode") or None)
    max_grad_norm = cfg.loss.get("max_grad_norm")
    trainer = Trainer(
        env,
        actor,
        loss,
        optimizer,
        horizon=int(cfg.loss.horizon),
        epochs=int(cfg.loss.epochs),
        minibatch_size=int(cfg.loss.minibatch_size),
        total_iterations=total_iterations(cfg, frames_per_batch),
        update_module=update_module,
        max_grad_norm=None if max_grad_norm is None else float(max_grad_norm),
        hooks=build_hooks(cfg, logger),
        success_window=int(cfg.get("success_window", 5)),
        cudagraph_policy=bool(cfg.get("cudagraphs", False)),
        cudagraph_update=graph_update,
        hold_keys=pqn_hold_keys(cfg.loss, actor) if cfg.loss.name == "pqn" else (),
        hold_period=cfg.loss.get("hold_period") if cfg.loss.name == "pqn" else None,
        kl_reference=uses_epoch_kl_reference(cfg.loss),
        config=cfg,
    )
    if resumed is not None:
        trainer.load_state_dict(resumed, source=str(cfg.resume))
    elif cfg.get("pretrained"):
        load_pretrained(trainer, str(cfg.pretrained), log_std=cfg.get("pretrained_log_std"))
    return trainer


__all__ = [
    "ACTION_CLIP",
    "add_action_clip",
    "add_observation_norm",
    "append_transform",
    "build_env",
    "build_gradient_method",
    "build_hooks",
    "build_loss",
    "build_networks",
    "build_optimizer",
    "build_trainer",
    "compile_networks",
    "uses_epoch_kl_reference",
    "graph_safe_update",
    "load_resume_checkpoint",
    "resolve_graph_update",
]
