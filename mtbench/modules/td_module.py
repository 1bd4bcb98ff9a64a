"""TensorDictModule builder wrapping :func:`make_network` for TorchRL pipelines."""

from __future__ import annotations

from typing import Any, Sequence

from tensordict.nn import TensorDictModule

from .registry import make_network


def make_td_network(
    arch: str,
    *,
    obs_dim: int,
    out_dim: int,
    num_tasks: int,
    out_key: str | tuple[str, ...],
    task_descriptions: Sequence[str] | None = None,
    in_keys: Sequence[str | tuple[str, ...]] = ("observation", "task_id"),
    **kwargs: Any,
) -> TensorDictModule:
    """Build ``arch`` and wrap it as ``TensorDictModule(net, in_keys=[observation, task_id], out_keys=[out_key])``.

    ``in_keys`` must name the observation then the task id (two keys). Example (critic)::

        value = make_td_network("moore", obs_dim=49, out_dim=1, num_tasks=10, out_key="state_value")
    """
    in_keys = list(in_keys)
    if len(in_keys) != 2:
        raise ValueError(f"make_td_network: in_keys must be (observation_key, task_id_key), got {in_keys!r}")
    net = make_network(arch, obs_dim=obs_dim, out_dim=out_dim, num_tasks=num_tasks,
                       task_descriptions=task_descriptions, **kwargs)
    return TensorDictModule(net, in_keys=in_keys, out_keys=[out_key])
