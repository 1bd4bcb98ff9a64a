"""The replay buffer of the off-policy loop: TorchRL's ``ReplayBuffer`` on a ``LazyTensorStorage`` on the env's
device (uniform sampling with replacement), a compact checkpoint state (the filled rows only) and replay samples
with observations normalised by the current per-task statistics."""

from __future__ import annotations

from typing import Any

import torch
from tensordict import TensorDictBase
from tensordict.utils import NestedKey
from torchrl.data import LazyTensorStorage, RandomSampler, ReplayBuffer

from ..transforms import PerTaskObservationNorm, PerTaskRunningMeanStd


def make_replay_buffer(capacity: int, batch_size: int, device: torch.device | str) -> ReplayBuffer:
    """``ReplayBuffer(LazyTensorStorage(capacity, device=device), RandomSampler(), batch_size=batch_size)``: the
    transitions stay on ``device`` (extend and sample never copy through the host), ``sample()`` draws
    ``batch_size`` uniform indices with replacement (MTBench's ``ReplayBuffer.sample_batch``) from the torch
    generator of ``device``, the oldest transitions are overwritten once ``capacity`` is reached."""
    if not (isinstance(capacity, int) and capacity >= 1):
        raise ValueError(f"loss.replay_buffer_size must be an integer >= 1; got {capacity!r}")
    if not (isinstance(batch_size, int) and 1 <= batch_size <= capacity):
        raise ValueError(f"loss.batch_size must be an integer in [1, loss.replay_buffer_size = {capacity}]; got "
                         f"{batch_size!r}")
    return ReplayBuffer(storage=LazyTensorStorage(capacity, device=torch.device(device)), sampler=RandomSampler(),
                        batch_size=batch_size)


def replay_state_dict(buffer: ReplayBuffer) -> dict[str, Any]:
    """The buffer's content for a checkpoint: the ``len(buffer)`` filled rows (on the CPU, in storage order) and
    the writer's cursor; :func:`load_replay_state_dict` puts them back at the same storage positions."""
    size = len(buffer)
    data = buffer.storage[:size] if size else None  # a view of the storage: copied, so that only these rows are saved
    if data is not None:
        data = data.clone() if data.device == torch.device("cpu") else data.to("cpu")
    return {"size": size, "capacity": buffer.storage.max_size, "data": data, "writer": buffer.writer.state_dict()}


def load_replay_state_dict(buffer: ReplayBuffer, state: dict[str, Any], device: torch.device | str) -> None:
    """Restore :func:`replay_state_dict` into an empty buffer of the same capacity (same rows at the same
    positions, same write cursor: the next samples and writes are those of the saved run)."""
    if int(state["capacity"]) != buffer.storage.max_size:
        raise ValueError(f"the checkpoint's replay buffer holds {state['capacity']} transitions, this run's "
                         f"loss.replay_buffer_size is {buffer.storage.max_size}")
    buffer.empty()
    if state["data"] is not None:
        buffer.extend(state["data"].to(device))
    buffer.writer.load_state_dict(state["writer"])


def normalize_observations(
    batch: TensorDictBase,
    norm: PerTaskObservationNorm | PerTaskRunningMeanStd | None,
    *,
    observation_key: NestedKey = "observation",
    task_id_key: NestedKey = "task_id",
) -> TensorDictBase:
    """Normalise ``observation`` and ``("next", observation)`` of replay samples in place with the current
    per-task statistics of ``norm`` (not updated: the env transform updates them during collection). The buffer
    keeps raw observations, so every sample is normalised with the latest statistics (MTBench normalises replay
    samples at update time too). ``norm`` may also be the statistics themselves (e.g. a snapshot of them)."""
    if norm is None:
        return batch
    stats = norm.stats if isinstance(norm, PerTaskObservationNorm) else norm
    task_id = batch.get(task_id_key).reshape(batch.batch_size)
    s = stats.dim
    for key in (observation_key, ("next", observation_key)):
        obs = batch.get(key)
        batch.set(key, torch.cat([stats.normalize(obs[..., :s], task_id), obs[..., s:]], dim=-1))
    return batch


__all__ = ["load_replay_state_dict", "make_replay_buffer", "normalize_observations", "replay_state_dict"]
