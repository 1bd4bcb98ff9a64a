"""On-policy multi-task training loop (MT-PPO / MT-GRPO, or any TorchRL loss) over a native-autoreset env."""

from __future__ import annotations

import time
from typing import Sequence

import torch
from omegaconf import DictConfig
from tensordict import TensorDictBase
from tensordict.utils import NestedKey
from torch import nn
from torchrl.envs import EnvBase
from torchrl.objectives import LossModule

from .config import effective_minibatch_size
from .env_factory import make_env_from_cfg  # noqa: F401  (kept importable here: mtbench.evaluation uses it)
from .hooks import TrainerHook
from .loop import TrainingLoop, observation_norm, tasks_with_worlds
from .update import MinibatchUpdate

# keys whose mismatch between a checkpoint and the current config makes a resume meaningless
RESUME_KEYS = TrainingLoop.resume_keys


class Trainer(TrainingLoop):
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
        hold_keys: root entries that keep their first-step value for the whole rollout (MT-PQN's
            ``loss.hold_observation``; :class:`~mtbench.trainer.rollout.Rollout`).
        hold_period: with ``hold_keys``, take the held entries afresh every ``hold_period`` steps (``None``: once
            per rollout; ``loss.hold_period``).
        kl_reference: after every minibatch update, write the policy's distribution on that minibatch before the
            step (the loss's ``loc``/``scale`` keys) into the batch (rl_games' ``update_mu_sigma``), so that from
            the second epoch on the loss's ``kl`` measures the change over one epoch, not the distance to the
            behaviour policy (``loss.lr_schedule_type=standard``; :class:`~mtbench.trainer.update.MinibatchUpdate`).
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
        hold_keys: Sequence[NestedKey] = (),
        hold_period: int | None = None,
        kl_reference: bool = False,
        config: DictConfig | None = None,
    ) -> None:
        super().__init__(
            env, policy, loss, optimizer, horizon=horizon, total_iterations=total_iterations,
            update_module=update_module, hooks=hooks, success_window=success_window,
            cudagraph_policy=cudagraph_policy, hold_keys=hold_keys, hold_period=hold_period, config=config,
        )
        if int(epochs) < 1:
            raise ValueError(f"loss.epochs must be >= 1, got {epochs}")
        self.epochs = int(epochs)
        run_minibatch = effective_minibatch_size(self.total_envs, self.horizon, minibatch_size)
        if run_minibatch % self.world_size:
            raise ValueError(f"loss.minibatch_size={minibatch_size} must be divisible by the number of torchrun "
                             f"processes ({self.world_size}): each takes an equal share of every minibatch")
        self.minibatch_size = run_minibatch // self.world_size  # this process's share (all of it in one process)
        self.num_minibatches = (self.num_envs * self.horizon) // self.minibatch_size
        self.updates_per_iteration = self.epochs * self.num_minibatches
        device = next(iter(self.optimizer.param_groups[0]["params"])).device
        self.updater = MinibatchUpdate(
            self.update_module, optimizer, max_grad_norm=max_grad_norm, call_hooks=self._call,
            graph=cudagraph_update, device=device, kl_reference=self._policy_distribution if kl_reference else None,
        )

    def _policy_distribution(self, minibatch: TensorDictBase) -> dict[str, torch.Tensor]:
        """The policy's current distribution parameters on ``minibatch`` under the loss's ``loc``/``scale`` keys."""
        keys = self.loss.tensor_keys
        params = self.policy.get_dist_params(minibatch.select(*self.policy.in_keys).clone(False))
        return {keys.loc: params.get(keys.loc), keys.scale: params.get(keys.scale)}

    def update_summary(self) -> str:
        """What one iteration's update does, for the front door's banner."""
        shares = f" ({self.world_size} processes x {self.minibatch_size:,})" if self.world_size > 1 else ""
        return (f"{self.epochs} epochs x {self.num_minibatches} minibatches of "
                f"{self.minibatch_size * self.world_size:,}{shares}")

    # ------------------------------------------------------------------ one iteration
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
        data, stats = self.collect()  # 1. rollout
        if data is None or stats is None:
            return None
        env_totals = self._record_episodes(stats)  # device -> host copy: also ends the collection timing on GPU
        t1 = time.perf_counter()
        means = self.update(self.advantage(data))  # 2. advantage, 3. update
        names = list(means)
        values = torch.stack([means[k] for k in names]).tolist()  # the update's only host sync
        t2 = time.perf_counter()
        self.iteration += 1
        self.frames += self.frames_per_batch
        metrics: dict[str, float] = {
            "iteration": float(self.iteration),
            "frames": float(self.frames),
            **self._timing(t0, t1, t2, self.frames_per_batch),
            "train/lr": float(self.optimizer.param_groups[0]["lr"]),
        }
        metrics.update(self._named_update_metrics(dict(zip(names, values))))
        metrics.update(self.window.summary())
        metrics.update(env_totals)
        self._call("on_iteration_end", metrics)
        return metrics

    # ------------------------------------------------------------------ checkpointing
    def _after_optimizer_load(self) -> None:
        self.updater.reset_graph()  # the loaded optimizer state lives in new tensors: capture again


__all__ = ["RESUME_KEYS", "Trainer", "make_env_from_cfg", "observation_norm", "tasks_with_worlds"]
