"""The hook protocol of the training loops: small objects called at defined points of an iteration."""

from __future__ import annotations

from typing import Any

from tensordict import TensorDictBase


class TrainerHook:
    """Base class of trainer hooks; override the points you need (all default to no-ops).

    The loop (``Trainer``, or any loop with ``iteration``, ``frames``, ``total_iterations``, ``optimizer`` and
    ``save(path)``) calls, in order:

    * :meth:`on_train_start` -- once per ``train()`` call, before the first iteration;
    * :meth:`on_iteration_start` -- before each iteration's rollout;
    * :meth:`on_rollout_step` -- after every env step of the rollout (host side; keep it cheap);
    * :meth:`before_optimizer_step` / :meth:`on_update` -- inside every minibatch update, after the gradients
      are written and clipped / after ``optimizer.step()``. ``metrics`` holds the update's scalar device tensors
      (``loss_*``, ``grad_norm``, ...) and may be extended. The update may be replayed from a CUDA graph: these
      two must only do sync-free tensor work (no ``.item()``, no Python branch on a tensor);
    * :meth:`on_epoch_end` -- after each epoch of the on-policy update, with the epoch's per-update means (device
      tensors; called eagerly, outside any graph, no host sync expected);
    * :meth:`on_iteration_end` -- after each iteration with its host-side metrics (a dict of floats the hook
      may extend or edit; later hooks see the edits);
    * :meth:`on_train_end` -- after the loop (``stopped``: a stop request ended it early);
    * :meth:`on_error` -- instead of :meth:`on_train_end` when the loop raised (release resources; the state
      may be mid-update: no checkpoint).

    :meth:`state_dict` / :meth:`load_state_dict` are saved in and restored from checkpoints under ``name``.
    """

    #: key of the hook's state in checkpoints (unique per trainer)
    name: str = "hook"

    def on_train_start(self, trainer: Any) -> None:
        """Before the first iteration of a ``train()`` call."""

    def on_iteration_start(self, trainer: Any) -> None:
        """Before an iteration's rollout."""

    def on_rollout_step(self, trainer: Any, step: int, horizon: int) -> None:
        """After env step ``step`` (1..``horizon``) of the rollout."""

    def before_optimizer_step(self, trainer: Any, metrics: TensorDictBase) -> None:
        """Gradients written and clipped, ``optimizer.step()`` next (device work only, graph-safe)."""

    def on_update(self, trainer: Any, metrics: TensorDictBase) -> None:
        """After ``optimizer.step()`` of a minibatch update (device work only, graph-safe)."""

    def on_epoch_end(self, trainer: Any, metrics: dict[str, Any]) -> None:
        """After an epoch of minibatch updates (on-policy loop), with ``{key: per-update mean}`` device tensors."""

    def on_iteration_end(self, trainer: Any, metrics: dict[str, float]) -> None:
        """After an iteration, with its metrics (host floats)."""

    def on_train_end(self, trainer: Any, stopped: bool) -> None:
        """After the loop; ``stopped``: ended by a stop request (SIGINT/SIGTERM) rather than by its length."""

    def on_error(self, trainer: Any, error: BaseException) -> None:
        """The loop raised ``error`` (it is re-raised after the hooks ran)."""

    def state_dict(self) -> dict[str, Any]:
        return {}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        """Restore :meth:`state_dict`."""


__all__ = ["TrainerHook"]
