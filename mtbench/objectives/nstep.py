"""n-step transitions for a replay buffer, from consecutive ``[N, T]`` rollouts of a native-autoreset env.

For every start step ``t`` whose window ``t .. t+n-1`` is complete, one transition

* ``observation``, ``action``, ``task_id`` (and any other ``first_step_keys``) of step ``t``;
* ``("next", reward) = sum_{i<k} gamma^i r_{t+i}``, where ``k`` is ``n``, or ``j + 1`` when the window holds a
  finished episode and ``t + j`` is its first ``done`` step (the sum stops there: MTBench's
  ``compute_nstep_return``);
* ``steps_to_next_obs = k``: TorchRL's value estimators then discount the bootstrap by ``gamma ** k``;
* ``("next", terminated)`` of step ``t + k - 1``: no bootstrap after a termination;
* ``("next", observation)``: ``s_{t+n}`` when no episode ended in the window; otherwise the env (native autoreset)
  has already replaced the final observation by the next episode's first one (TorchRL NaN-fills
  ``("next", observation)`` on those rows), and the observation ``s_{t+k-1}`` of the ``done`` step stands in for
  it. On a truncation the target therefore bootstraps ``gamma^k V(s_{t+k-1})`` -- the truncation bootstrap of
  TorchRL's ``GAE(auto_reset_env=True)`` and rl_games' ``value_bootstrap`` (``r_T += gamma V(s_T)``); on a
  termination the observation is masked out by ``terminated``.

TorchRL's ``MultiStepTransform`` needs the true final observation of every episode, which native-autoreset
envs (mtbench's) do not return; it would also feed the NaN rows to the networks.
"""

from __future__ import annotations

from typing import Any, Sequence

import torch
from tensordict import TensorDict, TensorDictBase
from tensordict.utils import NestedKey


def nstep_transitions(
    steps: TensorDictBase,
    n: int,
    gamma: float,
    *,
    observation_keys: Sequence[NestedKey] = ("observation",),
    first_step_keys: Sequence[NestedKey] = ("action", "task_id"),
    task_id_key: NestedKey = "task_id",
    reward_key: NestedKey = "reward",
    done_key: NestedKey = "done",
    terminated_key: NestedKey = "terminated",
) -> TensorDictBase | None:
    """The n-step transitions of the consecutive env steps ``steps`` (``[N, L]``, time last; keys as a TorchRL
    rollout: root entries at ``t``, ``("next", ...)`` after step ``t``), one per start ``t`` in ``[0, L - n]``:
    ``[N, L - n + 1]`` (``None`` when ``L < n``). See the module docstring for the entries."""
    if int(n) < 1:
        raise ValueError(f"nstep must be an integer >= 1; got {n}")
    if not 0.0 < gamma <= 1.0:
        raise ValueError(f"gamma must be in (0, 1]; got {gamma}")
    if steps.batch_dims != 2:
        raise ValueError(f"steps must be a [num_envs, time] TensorDict; got batch size {tuple(steps.batch_size)}")
    num_envs, length = steps.batch_size
    count = length - n + 1
    if count <= 0:
        return None
    device = steps.device
    windows = torch.arange(count, device=device)[:, None] + torch.arange(n, device=device)[None, :]  # [C, n]
    reward = steps.get(("next", reward_key))
    reward = reward.reshape(num_envs, length)
    done = steps.get(("next", done_key)).reshape(num_envs, length)
    terminated = steps.get(("next", terminated_key), done).reshape(num_envs, length)
    done_w = done[:, windows]  # [N, C, n]
    # steps up to and including the first done of the window
    used = (done_w.long().cumsum(-1) - done_w.long()) == 0
    k = used.sum(-1)  # [N, C], in 1..n
    discounts = gamma ** torch.arange(n, device=device, dtype=reward.dtype)
    ret = (reward[:, windows] * discounts * used).sum(-1)
    end = torch.arange(count, device=device)[None, :] + k - 1  # [N, C]: last step of each transition
    ended = done.gather(1, end)  # an episode ended inside the window (at its last step)
    out = TensorDict({}, batch_size=[num_envs, count], device=device)
    for key in first_step_keys:
        out.set(key, steps.get(key)[:, :count])
    for key in observation_keys:
        obs = steps.get(key)
        index = end.reshape(num_envs, count, *([1] * (obs.ndim - 2))).expand(num_envs, count, *obs.shape[2:])
        final = steps.get(("next", key)).gather(1, index)
        stand_in = obs.gather(1, index)
        out.set(key, obs[:, :count])
        out.set(("next", key), torch.where(ended.reshape(*ended.shape, *([1] * (obs.ndim - 2))), stand_in, final))
    if task_id_key in steps.keys(True):
        out.set(("next", task_id_key), steps.get(task_id_key)[:, :count])
    out.set(("next", reward_key), ret.unsqueeze(-1))
    out.set(("next", done_key), ended.unsqueeze(-1))
    out.set(("next", terminated_key), terminated.gather(1, end).unsqueeze(-1))
    out.set("steps_to_next_obs", k.unsqueeze(-1))
    return out


class NStepTransitions:
    """:func:`nstep_transitions` over a stream of rollouts: the last ``n - 1`` env steps of a rollout are carried
    to the next call, so that a rollout of ``T`` steps yields ``T`` transitions per world once ``n - 1`` steps
    have been seen (a horizon of 1 works, as in MTBench's ``NStepReplay``). The carried steps are part of
    :meth:`state_dict` (exact resume).

    ``transitions = NStepTransitions(n, gamma)(rollout)`` -> flat ``[N * T']`` TensorDict (or ``None`` before the
    first complete window), ready for ``replay_buffer.extend``. Keyword arguments as :func:`nstep_transitions`.
    """

    def __init__(self, n: int, gamma: float, **keys: Any) -> None:
        if not (isinstance(n, int) and not isinstance(n, bool) and n >= 1):
            raise ValueError(f"loss.nstep must be an integer >= 1; got {n!r}")
        if not 0.0 < gamma <= 1.0:
            raise ValueError(f"loss.gamma must be in (0, 1]; got {gamma}")
        self.n = n
        self.gamma = float(gamma)
        self.keys = keys
        obs = tuple(keys.get("observation_keys", ("observation",)))
        first = tuple(keys.get("first_step_keys", ("action", "task_id")))
        nxt = [("next", k) for k in (*obs, keys.get("reward_key", "reward"), keys.get("done_key", "done"),
                                     keys.get("terminated_key", "terminated"))]
        self._needed = [*obs, *first, *nxt]
        self._carry: TensorDictBase | None = None

    def __call__(self, rollout: TensorDictBase) -> TensorDictBase | None:
        steps = rollout.select(*self._needed, strict=False)
        if self._carry is not None:
            steps = torch.cat([self._carry, steps], dim=1)
        out = nstep_transitions(steps, self.n, self.gamma, **self.keys)
        keep = self.n - 1
        # a copy: the rollout buffer is overwritten by the next rollout
        self._carry = steps[:, max(0, steps.shape[1] - keep):].clone() if keep else None
        return None if out is None else out.reshape(-1)

    @property
    def carried_steps(self) -> int:
        """Env steps held for the next call (at most ``n - 1``)."""
        return 0 if self._carry is None else int(self._carry.shape[1])

    def state_dict(self) -> dict[str, Any]:
        """The carried env steps (on the CPU)."""
        return {"n": self.n, "carry": None if self._carry is None else self._carry.to("cpu")}

    def load_state_dict(self, state: dict[str, Any], device: torch.device | str | None = None) -> None:
        if int(state["n"]) != self.n:
            raise ValueError(f"the checkpoint carries {state['n']}-step windows, this run uses loss.nstep={self.n}")
        carry = state.get("carry")
        self._carry = None if carry is None else carry.to(device) if device is not None else carry


__all__ = ["NStepTransitions", "nstep_transitions"]
