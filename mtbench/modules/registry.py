"""Name -> network constructor registry used by configs (``arch=<name>``)."""

from __future__ import annotations

import functools
import inspect
from typing import Any, Callable, Mapping, Sequence

from torch import nn

from .care import CARE
from .mlp import MLP
from .moore import MOORE
from .multihead import MultiHeadMLP
from .paco import PaCo
from .residual_mlp import ResidualMLP
from .soft_modularization import SoftModularization

ARCHITECTURES: dict[str, Callable[..., nn.Module]] = {
    "mlp": MLP,
    "multihead": MultiHeadMLP,
    "soft_modularization": SoftModularization,
    "care": CARE,
    "care_mh": functools.partial(CARE, multi_head=True),
    "paco": PaCo,
    "moore": MOORE,
    "moore_mh": functools.partial(MOORE, multi_head=True),
    "residual_mlp": ResidualMLP,
}

_ROLES = ("actor", "critic")


def register_architecture(name: str, constructor: Callable[..., nn.Module]) -> None:
    """Register a network constructor ``constructor(obs_dim=, out_dim=, num_tasks=, **kwargs)``.

    A constructor that declares a ``task_descriptions`` parameter receives the task descriptions given to
    :func:`make_network`.
    """
    ARCHITECTURES[name] = constructor


def _accepts_task_descriptions(constructor: Callable[..., nn.Module]) -> bool:
    try:
        return "task_descriptions" in inspect.signature(constructor).parameters
    except (TypeError, ValueError):
        return False


def make_network(
    arch: str,
    *,
    obs_dim: int,
    out_dim: int,
    num_tasks: int,
    task_descriptions: Sequence[str] | None = None,
    **kwargs: Any,
) -> nn.Module:
    """Build the network ``arch`` mapping ``(observation, task_id)`` to ``out_dim`` features.

    ``task_descriptions`` (the env's ``task_descriptions``: one sentence per task, length ``num_tasks``) is forwarded
    only to constructors that declare a ``task_descriptions`` parameter (CARE embeds them as its task context).
    """
    if arch not in ARCHITECTURES:
        raise ValueError(f"unknown arch {arch!r}; valid choices: {sorted(ARCHITECTURES)}")
    if num_tasks < 1 or obs_dim <= num_tasks:
        raise ValueError(
            f"arch {arch!r}: obs_dim={obs_dim} must exceed num_tasks={num_tasks} >= 1 (observation = state + one-hot)"
        )
    if isinstance(task_descriptions, str):
        raise ValueError(f"arch {arch!r}: task_descriptions must be a sequence of sentences, got the string "
                         f"{task_descriptions!r}")
    if task_descriptions is not None and len(task_descriptions) != num_tasks:
        raise ValueError(
            f"arch {arch!r}: got {len(task_descriptions)} task_descriptions for num_tasks={num_tasks}; they must "
            "match (pass env.task_descriptions and env.num_tasks)"
        )
    constructor = ARCHITECTURES[arch]
    if task_descriptions is not None and _accepts_task_descriptions(constructor):
        kwargs["task_descriptions"] = list(task_descriptions)
    return constructor(obs_dim=obs_dim, out_dim=out_dim, num_tasks=num_tasks, **kwargs)


def arch_kwargs(arch_cfg: Mapping[str, Any], role: str) -> tuple[str, dict[str, Any]]:
    """Resolve a ``conf/arch/*.yaml`` preset for ``role`` (``"actor"`` or ``"critic"``).

    The preset schema is ``{name, kwargs, actor, critic}``; returns ``(name, {**kwargs, **preset[role]})``.
    Works with plain dicts and OmegaConf ``DictConfig`` objects.
    """
    if role not in _ROLES:
        raise ValueError(f"unknown role {role!r}; valid choices: {list(_ROLES)}")
    if "name" not in arch_cfg:
        raise ValueError(f"arch config needs a 'name' (one of {sorted(ARCHITECTURES)}); got keys {sorted(arch_cfg)}")
    name = str(arch_cfg["name"])
    if name not in ARCHITECTURES:
        raise ValueError(f"unknown arch {name!r}; valid choices: {sorted(ARCHITECTURES)}")
    merged: dict[str, Any] = {}
    for part in (arch_cfg.get("kwargs") or {}, arch_cfg.get(role) or {}):
        for key, value in part.items():
            merged[str(key)] = _to_plain(value)
    return name, merged


def _to_plain(value: Any) -> Any:
    try:  # OmegaConf containers -> plain Python (lists become tuples-friendly lists)
        from omegaconf import DictConfig, ListConfig, OmegaConf

        if isinstance(value, (DictConfig, ListConfig)):
            return OmegaConf.to_container(value, resolve=True)
    except ImportError:  # pragma: no cover - omegaconf is a hard dependency, kept optional here
        pass
    return value
