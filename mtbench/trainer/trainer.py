"""On-policy multi-task trainer (MT-PPO / MT-GRPO) over a native-autoreset mtbench env."""

from __future__ import annotations

import math
import os
import signal
import threading
import time
import warnings
from pathlib import Path
from typing import Any, Mapping

import torch
from omegaconf import DictConfig, OmegaConf
from tensordict import TensorDictBase
from torchrl.collectors import Collector
from torchrl.envs import EnvBase, TransformedEnv

from ..objectives import compute_gradients, make_gradient_method
from ..objectives.gradients import total_loss
from ..objectives.grpo import MTGRPOLoss
from ..objectives.ppo import MTClipPPOBase, MTPPOLoss
from ..transforms import PerTaskObservationNorm
from ..utils import GraphedStage
from .actor_critic import GaussianPolicyHead, make_actor, make_critic
from .checkpoint import CHECKPOINT_VERSION, load_checkpoint, rng_state, save_checkpoint, seed_everything, set_rng_state
from .metrics import EpisodeStatsWindow
from .progress import ProgressDisplay

LOSSES = ("ppo", "grpo")
LR_SCHEDULES = ("fixed", "adaptive")
# keys whose mismatch between a checkpoint and the current config makes a resume meaningless
_RESUME_KEYS = ("env.name", "env.num_envs", "loss.name", "loss.horizon", "arch.name", "grad.name")


def resolve_device(device: str | torch.device | None) -> torch.device:
    """``"auto"``/``None`` -> ``cuda`` if available else ``cpu``; anything else is passed to ``torch.device``."""
    if device is None or str(device) == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    dev = torch.device(device)
    if dev.type == "cuda" and not torch.cuda.is_available():
        raise ValueError(f"device={device!r} requested but CUDA is not available (use device=auto or cpu)")
    return dev


def make_env_from_cfg(env_cfg: Mapping[str, Any], device: torch.device, seed: int) -> EnvBase:
    """``mtbench.envs.make_env(env_cfg.name, num_envs=env_cfg.num_envs, device=..., seed=..., **overrides)``."""
    try:
        from ..envs import make_env
    except ImportError as err:  # the physics env is optional for tests that pass their own env
        raise ImportError(f"mtbench.envs.make_env is not available ({err}); pass env= to Trainer") from err
    raw = env_cfg.get("overrides")
    if raw is None:
        overrides: dict[str, Any] = {}
    elif OmegaConf.is_config(raw):
        overrides = dict(OmegaConf.to_container(raw, resolve=True))  # type: ignore[arg-type]
    else:
        overrides = dict(raw)
    name = env_cfg["name"]
    if isinstance(name, (list, tuple)) or OmegaConf.is_list(name):
        name = list(name)
    return make_env(name, num_envs=int(env_cfg["num_envs"]), device=device, seed=seed, **overrides)


def _base_env(env: EnvBase) -> EnvBase:
    while isinstance(env, TransformedEnv):
        env = env.base_env
    return env


def _ensure_native_autoreset(env: EnvBase) -> None:
    """TorchRL reads ``_torchrl_native_autoreset`` from the *instance* ``__dict__``; a class attribute alone
    silently falls back to TorchRL-driven resets (a second reset of finished rows + a host sync per step)."""
    base = _base_env(env)
    if getattr(type(base), "_torchrl_native_autoreset", False) and not base.__dict__.get("_torchrl_native_autoreset"):
        base.__dict__["_torchrl_native_autoreset"] = True
    if isinstance(env, TransformedEnv) and base.__dict__.get("_torchrl_native_autoreset"):
        env.__dict__["_torchrl_native_autoreset"] = True


def _cfg(cfg: Mapping[str, Any] | DictConfig) -> DictConfig:
    return cfg if isinstance(cfg, DictConfig) else OmegaConf.create(dict(cfg))


class Trainer:
    """MT-PPO / MT-GRPO training loop.

    One iteration = collect ``num_envs x horizon`` frames with a TorchRL :class:`~torchrl.collectors.Collector`
    (native autoreset, no per-step host sync) -> ``loss.compute_advantage`` -> ``epochs`` passes over shuffled
    minibatches, each through ``mtbench.objectives.compute_gradients`` (plain loss or gradient-manipulation
    wrapper), global grad-norm clip, Adam step. A minibatch whose loss or gradient norm is non-finite is skipped
    on the device (fused Adam ``found_inf``: parameters and optimizer state untouched) and counted.

    Args:
        cfg: the composed Hydra config (see ``conf/config.yaml``) or an equivalent mapping.
        env: an env to train on (built from ``cfg.env`` with ``mtbench.envs.make_env`` when omitted); must follow
            the mtbench contract (``observation``, ``task_id``, ``num_tasks``, ``task_names``, ``pop_episode_stats``).
        logger: optional torchrl ``Logger`` (``mtbench.logging.MCAPLogger``): metrics are logged every iteration.
    """

    def __init__(self, cfg: Mapping[str, Any] | DictConfig, env: EnvBase | None = None, logger: Any = None) -> None:
        self.cfg = cfg = _cfg(cfg)
        self.device = resolve_device(cfg.get("device", "auto"))
        self.seed = int(cfg.get("seed", 0))
        seed_everything(self.seed)
        lc = cfg.loss
        if lc.name not in LOSSES:
            raise ValueError(f"unknown loss {lc.name!r}; valid choices: {list(LOSSES)}")
        if lc.get("lr_schedule", "fixed") not in LR_SCHEDULES:
            raise ValueError(f"unknown loss.lr_schedule {lc.lr_schedule!r}; valid choices: {list(LR_SCHEDULES)}")

        # ---------------------------------------------------------------- env (+ per-task input normalisation)
        base = env if env is not None else make_env_from_cfg(cfg.env, self.device, self.seed)
        self.base_env = _base_env(base)
        for attr in ("num_tasks", "task_names", "pop_episode_stats"):
            if not hasattr(self.base_env, attr):
                raise TypeError(f"env {type(self.base_env).__name__} lacks '{attr}' (mtbench env contract)")
        self.num_tasks = int(self.base_env.num_tasks)
        self.task_names = list(self.base_env.task_names)
        # one sentence per task (CARE's context); envs without descriptions give CARE learned task embeddings
        descriptions = getattr(self.base_env, "task_descriptions", None)
        self.task_descriptions = list(descriptions) if descriptions is not None else None
        self.obs_norm: PerTaskObservationNorm | None = None
        if lc.get("normalize_input", True):
            self.obs_norm = PerTaskObservationNorm(
                self.num_tasks, state_dim=getattr(self.base_env, "state_dim", None), device=base.device
            )
            self.env = TransformedEnv(base, self.obs_norm)
        else:
            self.env = base
        _ensure_native_autoreset(self.env)
        obs_dim = int(self.env.observation_spec["observation"].shape[-1])
        action_dim = int(self.env.action_spec.shape[-1])
        self.num_envs = int(self.env.batch_size.numel())

        # ---------------------------------------------------------------- networks and loss
        arch = cfg.get("arch")
        self.actor = make_actor(
            arch, obs_dim=obs_dim, action_dim=action_dim, num_tasks=self.num_tasks,
            task_descriptions=self.task_descriptions,
            log_std_init=float(lc.get("log_std_init", 0.0)), device=self.device,
        )
        common = dict(
            num_tasks=self.num_tasks,
            clip_epsilon=float(lc.clip_epsilon),
            entropy_coeff=float(lc.entropy_coeff),
            bounds_coeff=float(lc.bounds_coeff),
            soft_bound=float(lc.soft_bound),
            gamma=float(lc.gamma),
        )
        if lc.name == "ppo":
            self.critic = make_critic(
                arch, obs_dim=obs_dim, num_tasks=self.num_tasks, task_descriptions=self.task_descriptions,
                device=self.device,
            )
            self.loss: MTClipPPOBase = MTPPOLoss(
                self.actor,
                self.critic,
                critic_coef=float(lc.critic_coef),
                clip_value=None if lc.get("clip_value") is None else float(lc.clip_value),
                lmbda=float(lc.lmbda),
                normalize_value=bool(lc.normalize_value),
                value_norm_clip=None if lc.get("value_norm_clip") is None else float(lc.value_norm_clip),
                per_task_advantage_norm=bool(lc.per_task_advantage_norm),
                **common,
            ).to(self.device)
        else:
            self.critic = None
            self.loss = MTGRPOLoss(self.actor, **common).to(self.device)
        self.update_module = self._make_update_module(cfg.get("grad"))
        self.graph_update = self._resolve_graph_update(cfg.get("cudagraph_update", "auto"))

        # ---------------------------------------------------------------- optimisation
        self.params = [p for p in self.loss.parameters() if p.requires_grad]
        self.lr = torch.tensor(float(lc.lr), device=self.device)
        self.optimizer = torch.optim.Adam(
            self.params, lr=self.lr, eps=float(lc.adam_eps), fused=True, capturable=self.graph_update
        )
        self.max_grad_norm = None if lc.get("max_grad_norm") is None else float(lc.max_grad_norm)
        self.adaptive_lr = lc.get("lr_schedule", "fixed") == "adaptive"
        self.kl_threshold = float(lc.get("kl_threshold", 0.008))
        self.min_lr, self.max_lr = float(lc.get("min_lr", 1e-6)), float(lc.get("max_lr", 1e-2))
        self.epochs = int(lc.epochs)
        self.horizon = int(lc.horizon)
        self.frames_per_batch = self.num_envs * self.horizon
        mb = int(lc.minibatch_size)
        if mb >= self.frames_per_batch:
            mb = self.frames_per_batch
        elif self.frames_per_batch % mb:
            raise ValueError(
                f"loss.minibatch_size={mb} must divide the batch num_envs*horizon = {self.num_envs}*{self.horizon} "
                f"= {self.frames_per_batch}"
            )
        self.minibatch_size = mb
        self.num_minibatches = self.frames_per_batch // mb
        if cfg.get("total_frames") is not None:
            self.total_iterations = max(1, math.ceil(int(cfg.total_frames) / self.frames_per_batch))
        else:
            self.total_iterations = int(cfg.max_iterations)
        if cfg.get("compile", False):
            self._compile_networks(cfg.get("compile_mode") or None)

        # ---------------------------------------------------------------- collection
        cudagraph_policy = {"warmup": 10} if cfg.get("cudagraphs", False) else None
        if cudagraph_policy is not None and self.device.type != "cuda":
            raise ValueError("cudagraphs=true needs a CUDA device")
        self.collector = Collector(
            self.env,
            self.actor,
            frames_per_batch=self.frames_per_batch,
            total_frames=-1,
            device=self.device,
            no_cuda_sync=True,
            trust_policy=True,
            track_traj_ids=False,
            return_same_td=True,
            cudagraph_policy=cudagraph_policy,
            auto_register_policy_transforms=False,
        )
        self._iterator = iter(self.collector)
        # the minibatch update replayed from a CUDA graph (cudagraph_update): a static minibatch is filled by
        # index_select, the graph runs loss -> backward -> clip -> Adam and writes the metrics into one vector.
        # Either way an update's scalar metrics are summed on the device as one vector (keys: _metric_keys).
        self._static_minibatch: TensorDictBase | None = None
        self._metric_keys: list[str] | None = None
        self._metric_buf: torch.Tensor | None = None
        self._update_stage = GraphedStage(
            self._static_update_step,
            self.device,
            warmup=3,
            stream=torch.cuda.Stream(self.device) if self.graph_update else None,
            enabled=self.graph_update,
            name="minibatch update",
        )

        # ---------------------------------------------------------------- bookkeeping
        self.iteration = 0
        self.frames = 0
        self.updates = 0
        self.skipped_updates = 0
        self.unhealthy_resets = 0.0  # env worlds reset after a NaN / runaway state / buffer overflow
        self.nonfinite_actions = 0.0  # env steps whose action had a NaN/inf component
        self.nonfinite_streak = 0
        self.max_nonfinite_streak = int(cfg.get("max_nonfinite_iterations", 10))
        self.window = EpisodeStatsWindow(self.task_names, int(cfg.get("success_window", 5)))
        self.logger = logger
        self.history: list[dict[str, float]] = []
        ck = cfg.get("checkpoint") or {}
        self.checkpoint_every = int(ck.get("every", 0) or 0)
        self.checkpoint_keep = int(ck.get("keep_last", 0) or 0)
        self.checkpoint_final = bool(ck.get("save_final", True))
        self.checkpoint_dir = Path(ck.get("dir") or _default_output_dir() / "checkpoints")
        self._hparams_logged = False
        if cfg.get("resume"):
            self.load(cfg.resume)

    # ------------------------------------------------------------------ construction helpers
    def _make_update_module(self, grad_cfg: Mapping[str, Any] | None) -> torch.nn.Module:
        """``make_gradient_method(grad.name, loss, num_tasks, **grad)``: the loss itself for ``grad=none`` (or a
        diagnostics wrapper when ``diagnostics_every > 0``), else the PCGrad / CAGrad / FAMO wrapper."""
        if grad_cfg is None:
            return self.loss
        kwargs = OmegaConf.to_container(grad_cfg, resolve=True) if OmegaConf.is_config(grad_cfg) else dict(grad_cfg)
        name = str(kwargs.pop("name", "none"))
        return make_gradient_method(name, self.loss, self.num_tasks, **kwargs)

    def _resolve_graph_update(self, value: Any) -> bool:
        """``cudagraph_update``: ``auto`` = on for CUDA with the plain loss (``grad=none``), ``true`` / ``false``."""
        if value is None or str(value) == "auto":
            return self.device.type == "cuda" and self.update_module is self.loss
        if not isinstance(value, bool):
            raise ValueError(f"cudagraph_update must be auto, true or false; got {value!r}")
        if value and self.device.type != "cuda":
            raise ValueError(f"cudagraph_update=true needs a CUDA device (device={self.device}); use auto or false")
        return value

    def _compile_networks(self, mode: str | None) -> None:
        """``torch.compile`` the actor and critic networks in place (``nn.Module.compile``).

        Used by the collection policy and by every loss evaluation. The TensorDict plumbing of the loss and the
        optimizer step stay eager: compiling them whole graph-breaks on TensorDict internals / fused Adam.
        """
        nets = [m.net for m in self.actor.modules() if isinstance(m, GaussianPolicyHead)]
        if self.critic is not None:
            nets.append(self.critic.module)
        for net in nets:
            net.compile(mode=mode)

    # ------------------------------------------------------------------ one optimisation step
    def _update_step(self, minibatch: TensorDictBase) -> TensorDictBase:
        """zero_grad -> compute_gradients -> clip -> Adam step (skipped on non-finite loss/grad, no host sync)."""
        self.optimizer.zero_grad(set_to_none=True)
        metrics = compute_gradients(self.update_module, minibatch)
        if self.max_grad_norm is not None:
            grad_norm = torch.nn.utils.clip_grad_norm_(self.params, self.max_grad_norm)
        else:
            grads = [p.grad for p in self.params if p.grad is not None]
            grad_norm = torch.linalg.vector_norm(torch.stack([torch.linalg.vector_norm(g) for g in grads]))
        finite = torch.isfinite(grad_norm)
        has_loss = any(isinstance(k, str) and k.startswith("loss_") for k in metrics.keys())
        if has_loss:
            finite = finite & torch.isfinite(total_loss(metrics))
        bad = (~finite).to(torch.float32)
        self.optimizer.found_inf = bad
        self.optimizer.step()
        if self.adaptive_lr and "kl" in metrics.keys():
            # rl_games AdaptiveScheduler ("legacy": after every minibatch), on the device
            kl = metrics["kl"].to(self.lr.dtype)
            lr = self.optimizer.param_groups[0]["lr"]
            new_lr = torch.where(
                kl > 2.0 * self.kl_threshold,
                (lr / 1.5).clamp_min(self.min_lr),
                torch.where(kl < 0.5 * self.kl_threshold, (lr * 1.5).clamp_max(self.max_lr), lr),
            )
            lr.copy_(torch.where(finite & torch.isfinite(kl), new_lr, lr))
        out = metrics.select(*[k for k in metrics.keys() if isinstance(k, str)]).clone(False)
        out.set("grad_norm", grad_norm.detach())
        out.set("skipped", bad)
        return out

    # ------------------------------------------------------------------ iteration
    def collect(self) -> tuple[TensorDictBase, TensorDictBase]:
        """One ``[num_envs, horizon]`` rollout and the per-task episode statistics finished during it."""
        data = next(self._iterator)
        return data, self.base_env.pop_episode_stats()

    def update(self, data: TensorDictBase) -> dict[str, torch.Tensor]:
        """Advantages + ``epochs`` x ``num_minibatches`` optimisation steps on a collected rollout.

        Returns per-update means of the scalar metrics (device tensors, no host sync) and ``skipped`` (count).
        """
        batch = self.loss.compute_advantage(data)
        batch = batch.select(*self.loss.batch_keys).reshape(-1)
        if self.graph_update and self._static_minibatch is None:
            self._static_minibatch = batch[: self.minibatch_size].clone()
        total: torch.Tensor | None = None
        for _ in range(self.epochs):
            perm = torch.randperm(self.frames_per_batch, device=batch.device)
            for i in range(self.num_minibatches):
                idx = perm[i * self.minibatch_size : (i + 1) * self.minibatch_size]
                if self.graph_update:
                    for key, value in self._static_minibatch.items():
                        torch.index_select(batch.get(key), 0, idx, out=value)
                    self._update_stage()
                    metrics = self._metric_buf
                else:
                    metrics = self._metric_vector(self._update_step(batch[idx]))
                total = metrics.clone() if total is None else total.add_(metrics)
        n = self.epochs * self.num_minibatches
        means = {k: total[j] / n for j, k in enumerate(self._metric_keys)}
        means["skipped"] = total[self._metric_keys.index("skipped")]  # a count, not a mean
        return means

    def _metric_vector(self, metrics: TensorDictBase) -> torch.Tensor:
        """The scalar metrics of one update as one vector (key order fixed by the first call)."""
        if self._metric_keys is None:
            self._metric_keys = [k for k, v in metrics.items() if isinstance(v, torch.Tensor) and v.numel() == 1]
        return torch.stack([metrics[k].detach().reshape(()).float() for k in self._metric_keys])

    def _static_update_step(self) -> None:
        """One update on the static minibatch, its metric vector written to ``_metric_buf`` (the graphed step)."""
        metrics = self._metric_vector(self._update_step(self._static_minibatch))
        if self._metric_buf is None:  # the first calls are eager (graph warm-up)
            self._metric_buf = torch.zeros_like(metrics)
        self._metric_buf.copy_(metrics)

    def train_iteration(self) -> dict[str, float]:
        """Collect one batch, update, and return this iteration's scalar metrics."""
        t0 = time.perf_counter()
        data, stats = self.collect()
        unhealthy = stats.get("unhealthy", None)  # optional: envs other than mtbench's may not report it
        nonfinite = stats.get("nonfinite_actions", None)
        self.window.push(stats)  # device -> host copy: also ends the collection timing on GPU
        t1 = time.perf_counter()
        means = self.update(data)
        # the only host sync of the update: all metrics at once
        names = list(means)
        values = torch.stack([means[k] for k in names]).tolist() if names else []
        t2 = time.perf_counter()
        self.iteration += 1
        self.frames += self.frames_per_batch
        metrics = dict(zip(names, values))
        skipped = int(round(metrics.pop("skipped", 0.0)))
        self.skipped_updates += skipped
        self.updates += self.epochs * self.num_minibatches - skipped
        if skipped == self.epochs * self.num_minibatches:
            self.nonfinite_streak += 1
        else:
            self.nonfinite_streak = 0
        out: dict[str, float] = {
            "iteration": float(self.iteration),
            "frames": float(self.frames),
            "fps": self.frames_per_batch / max(t2 - t0, 1e-9),
            "fps_collect": self.frames_per_batch / max(t1 - t0, 1e-9),
            "time/collect_s": t1 - t0,
            "time/update_s": t2 - t1,
            "train/lr": float(self.optimizer.param_groups[0]["lr"]),
            "train/skipped_updates": float(skipped),
            "train/skipped_updates_total": float(self.skipped_updates),
        }
        for key, value in metrics.items():
            out[f"loss/{key[5:]}" if key.startswith("loss_") else f"train/{key}"] = value
        out.update(self.window.summary())
        if unhealthy is not None:  # worlds the env reset after a NaN / runaway state / buffer overflow
            self.unhealthy_resets += float(unhealthy.sum())
            out["env/unhealthy_resets_total"] = self.unhealthy_resets
        if nonfinite is not None:  # policy actions with a NaN/inf component (replaced by 0 by the env)
            self.nonfinite_actions += float(nonfinite.sum())
            out["env/nonfinite_actions_total"] = self.nonfinite_actions
        if skipped:
            warnings.warn(
                f"iteration {self.iteration}: {skipped}/{self.epochs * self.num_minibatches} minibatch updates "
                "skipped (non-finite loss or gradient)",
                RuntimeWarning,
                stacklevel=2,
            )
        if self.nonfinite_streak >= self.max_nonfinite_streak:
            raise RuntimeError(
                f"every update of the last {self.nonfinite_streak} iterations was non-finite (NaN/Inf loss or "
                "gradient); stopping. Check the env (physics blow-up) and the normalisers."
            )
        return out

    # ------------------------------------------------------------------ main loop
    def train(self, progress: str | None = None) -> list[dict[str, float]]:
        """Run until ``total_iterations``; returns the per-iteration metrics of this call."""
        logging_cfg = self.cfg.get("logging") or {}
        display = ProgressDisplay(
            self.total_iterations,
            mode=progress or logging_cfg.get("progress", "auto"),
            every=int(logging_cfg.get("print_every", 1) or 1),
            initial=self.iteration,
        )
        if self.logger is not None and not self._hparams_logged:
            hparams = OmegaConf.to_container(self.cfg, resolve=True)
            hparams["env_info"] = self.env_info()  # e.g. the reward version the env actually runs
            self.logger.log_hparams(OmegaConf.create(hparams))
            self._hparams_logged = True
        history: list[dict[str, float]] = []
        stop = _StopRequest()
        try:
            while self.iteration < self.total_iterations and not stop.requested:
                metrics = self.train_iteration()
                history.append(metrics)
                self.history.append(metrics)
                if self.logger is not None:
                    self.logger.log_metrics(metrics, step=self.frames)
                extra = ""
                if "loss/objective" in metrics:
                    extra = f"kl={metrics.get('train/kl', float('nan')):.4f}"
                display.update(self.iteration, self.frames, metrics["fps"], metrics["success/mean"], extra)
                if self.checkpoint_every and self.iteration % self.checkpoint_every == 0:
                    self.save(self.checkpoint_dir / f"ckpt_{self.iteration:06d}.pt")
        finally:
            display.close()
            stop.restore()
        if stop.requested:
            # SIGINT/SIGTERM: the iteration in flight was finished; keep everything up to it
            path = self.save(self.checkpoint_dir / f"ckpt_{self.iteration:06d}.pt")
            print(f"stopped by signal {stop.signum} after iteration {self.iteration}; checkpoint: {path}", flush=True)
            return history
        if self.checkpoint_final and history:
            self.save(self.checkpoint_dir / "final.pt")
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
        """Everything needed to continue the run bit-for-bit (on the same device type)."""
        carrier = getattr(self.collector, "_carrier", None)
        state: dict[str, Any] = {
            "version": CHECKPOINT_VERSION,
            "config": OmegaConf.to_container(self.cfg, resolve=True),
            "env_info": self.env_info(),
            "counters": {
                "iteration": self.iteration,
                "frames": self.frames,
                "updates": self.updates,
                "skipped_updates": self.skipped_updates,
                "unhealthy_resets": self.unhealthy_resets,
                "nonfinite_actions": self.nonfinite_actions,
                "nonfinite_streak": self.nonfinite_streak,
            },
            "loss": self.loss.state_dict(),
            "update_module": None if self.update_module is self.loss else self.update_module.state_dict(),
            "optimizer": self.optimizer.state_dict(),
            "obs_norm": None if self.obs_norm is None else self.obs_norm.state_dict(),
            "env": self.base_env.state_dict(),
            "carrier": None if carrier is None else carrier.detach().to("cpu").clone(),
            "window": self.window.state_dict(),
            "rng": rng_state(),
            "logger": getattr(self.logger, "_checkpoint_state", lambda: None)() if self.logger is not None else None,
        }
        return state

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Atomically write a checkpoint to ``path`` and point ``last.pt`` next to it at it."""
        path = save_checkpoint(path, self.state_dict())
        last = path.parent / "last.pt"
        if path.name != last.name:
            tmp = path.parent / f".last.{os.getpid()}.tmp"
            try:
                if tmp.exists():
                    tmp.unlink()
                os.link(path, tmp)
                os.replace(tmp, last)
            except OSError:
                save_checkpoint(last, self.state_dict())
        if self.checkpoint_keep > 0:
            old = sorted(path.parent.glob("ckpt_*.pt"))[: -self.checkpoint_keep]
            for p in old:
                p.unlink(missing_ok=True)
        return path

    def load(self, path: str | os.PathLike[str]) -> None:
        """Restore a checkpoint written by :meth:`save` (counters, model, optimiser, normalisers, gradient
        method, env state, collector carry, metric window, RNG states)."""
        state = load_checkpoint(path, map_location="cpu")
        saved = OmegaConf.create(state["config"])
        diffs = []
        for key in _RESUME_KEYS:
            a, b = OmegaConf.select(saved, key), OmegaConf.select(self.cfg, key)
            if a != b:
                diffs.append(f"{key}: checkpoint={a!r} current={b!r}")
        for key, value in self.env_info().items():
            saved_value = (state.get("env_info") or {}).get(key, value)
            if saved_value != value:
                diffs.append(f"env {key}: checkpoint={saved_value!r} current={value!r}")
        if diffs:
            raise ValueError(f"cannot resume from {path}: configuration differs ({'; '.join(diffs)})")
        c = state["counters"]
        self.iteration, self.frames = int(c["iteration"]), int(c["frames"])
        self.updates, self.skipped_updates = int(c["updates"]), int(c["skipped_updates"])
        self.unhealthy_resets = float(c.get("unhealthy_resets", 0.0))
        self.nonfinite_actions = float(c.get("nonfinite_actions", 0.0))
        self.nonfinite_streak = int(c.get("nonfinite_streak", 0))
        self.loss.load_state_dict(state["loss"])
        if state.get("update_module") is not None and self.update_module is not self.loss:
            self.update_module.load_state_dict(state["update_module"])
        self.optimizer.load_state_dict(state["optimizer"])
        for group in self.optimizer.param_groups:  # a property of this run, not of the checkpoint
            group["capturable"] = self.graph_update
        self._update_stage.reset()  # the loaded optimizer state lives in new tensors: capture again
        lr = self.optimizer.param_groups[0]["lr"]
        if isinstance(lr, torch.Tensor):
            self.lr.copy_(lr.to(self.lr.device))
        self.optimizer.param_groups[0]["lr"] = self.lr
        if self.obs_norm is not None and state.get("obs_norm") is not None:
            self.obs_norm.load_state_dict(state["obs_norm"])
        env_restored = False
        if state.get("env"):
            try:
                self.base_env.load_state_dict(state["env"])
                env_restored = True
            except (RuntimeError, KeyError) as err:
                warnings.warn(f"could not restore the env state ({err}); the env continues from a fresh reset")
        carrier = state.get("carrier")
        # the carried observations only match the env if its state was restored too
        if env_restored and carrier is not None and getattr(self.collector, "_carrier", None) is not None:
            self.collector._carrier.update(carrier.to(self.collector._carrier.device))
        self.window.load_state_dict(state["window"])
        self._resume_logger_state = state.get("logger")
        if self.logger is not None:
            self.set_logger(self.logger)
        set_rng_state(state["rng"])
        self._hparams_logged = True

    def set_logger(self, logger: Any) -> None:
        """Attach a torchrl ``Logger`` (restores its counters when this run was resumed from a checkpoint)."""
        self.logger = logger
        state = getattr(self, "_resume_logger_state", None)
        if logger is not None and state is not None and hasattr(logger, "_load_checkpoint_state"):
            logger._load_checkpoint_state(state)

    def close(self) -> None:
        """Shut the collector down (closes the env)."""
        self.collector.shutdown()


def _default_output_dir() -> Path:
    try:
        from hydra.core.hydra_config import HydraConfig

        if HydraConfig.initialized():
            return Path(HydraConfig.get().runtime.output_dir)
    except ImportError:  # pragma: no cover
        pass
    return Path.cwd()


__all__ = ["LOSSES", "LR_SCHEDULES", "Trainer", "make_env_from_cfg", "resolve_device"]


class _StopRequest:
    """SIGINT/SIGTERM handler for the training loop: the first signal asks the loop to stop after the current
    iteration (which is then checkpointed); a second SIGINT interrupts immediately."""

    def __init__(self) -> None:
        self.requested = False
        self.signum: int | None = None
        self._previous: dict[int, Any] = {}
        if threading.current_thread() is not threading.main_thread():
            return
        for sig in (signal.SIGINT, signal.SIGTERM):
            self._previous[sig] = signal.signal(sig, self._handle)

    def _handle(self, signum: int, frame: Any) -> None:
        if self.requested and signum == signal.SIGINT:
            raise KeyboardInterrupt
        self.requested, self.signum = True, signum

    def restore(self) -> None:
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)
        self._previous.clear()
