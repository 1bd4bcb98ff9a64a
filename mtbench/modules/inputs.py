"""Shared input handling for multi-task networks: ``(observation, task_id)`` -> flat 2-D batch.

Every mtbench network accepts ``observation: [..., obs_dim]`` (state followed by the one-hot task id, see
docs/design.md) and ``task_id: LongTensor[...]`` (possibly with a trailing singleton dim). The helpers here
validate the shapes (shape checks only: no host sync), flatten arbitrary leading batch dims to one, and restore
them on the output.
"""

from __future__ import annotations

import torch


def flatten_inputs(
    observation: torch.Tensor, task_id: torch.Tensor, obs_dim: int, owner: str = "network"
) -> tuple[torch.Tensor, torch.Tensor, torch.Size]:
    """Validate and flatten ``(observation, task_id)``.

    Returns ``(obs [B, obs_dim], task_id [B] int64, batch_shape)`` with ``B = prod(batch_shape)``.
    ``task_id`` may carry a trailing singleton dim (squeezed) or be broadcastable to the batch shape.
    """
    if observation.shape[-1:] != (obs_dim,):
        raise ValueError(
            f"{owner}: observation has trailing dim {tuple(observation.shape[-1:])}, expected obs_dim={obs_dim} "
            "(state followed by the one-hot task id)"
        )
    if task_id is None:
        raise ValueError(f"{owner}: task_id is required (LongTensor shaped like the batch)")
    if task_id.dtype.is_floating_point or task_id.dtype == torch.bool:
        raise ValueError(f"{owner}: task_id must be an integer tensor, got dtype {task_id.dtype}")
    batch_shape = observation.shape[:-1]
    if task_id.dim() == observation.dim() and task_id.shape[-1] == 1:
        task_id = task_id.squeeze(-1)
    if task_id.shape != batch_shape:
        try:
            task_id = task_id.expand(batch_shape)
        except RuntimeError:
            raise ValueError(
                f"{owner}: task_id shape {tuple(task_id.shape)} does not match the observation batch shape "
                f"{tuple(batch_shape)} (a trailing singleton dim is allowed)"
            ) from None
    return observation.reshape(-1, obs_dim), task_id.reshape(-1).long(), batch_shape


def unflatten_output(output: torch.Tensor, batch_shape: torch.Size) -> torch.Tensor:
    """Reshape a flat ``[B, out_dim]`` output back to ``[*batch_shape, out_dim]``."""
    return output.reshape(*batch_shape, output.shape[-1])


def check_sizes(owner: str, obs_dim: int, out_dim: int, num_tasks: int) -> int:
    """Validate constructor sizes and return the state dim ``obs_dim - num_tasks``."""
    if num_tasks < 1:
        raise ValueError(f"{owner}: num_tasks must be >= 1, got {num_tasks}")
    if obs_dim <= num_tasks:
        raise ValueError(
            f"{owner}: obs_dim={obs_dim} must exceed num_tasks={num_tasks} (observation = state + one-hot)"
        )
    if out_dim < 1:
        raise ValueError(f"{owner}: out_dim must be >= 1, got {out_dim}")
    return obs_dim - num_tasks
