"""Name -> network constructor registry used by configs (``arch=<name>``)."""

from __future__ import annotations

from typing import Any, Callable

from torch import nn

from .mlp import MLP

ARCHITECTURES: dict[str, Callable[..., nn.Module]] = {
    "mlp": MLP,
}


def register_architecture(name: str, constructor: Callable[..., nn.Module]) -> None:
    """Register a network constructor ``constructor(obs_dim=, out_dim=, num_tasks=, **kwargs)``."""
    ARCHITECTURES[name] = constructor


def make_network(arch: str, *, obs_dim: int, out_dim: int, num_tasks: int, **kwargs: Any) -> nn.Module:
    """Build the network ``arch`` mapping ``(observation, task_id)`` to ``out_dim`` features."""
    if arch not in ARCHITECTURES:
        raise ValueError(f"unknown arch {arch!r}; valid choices: {sorted(ARCHITECTURES)}")
    if num_tasks < 1 or obs_dim <= num_tasks:
        raise ValueError(
            f"arch {arch!r}: obs_dim={obs_dim} must exceed num_tasks={num_tasks} (observation = state + one-hot)"
        )
    return ARCHITECTURES[arch](obs_dim=obs_dim, out_dim=out_dim, num_tasks=num_tasks, **kwargs)
