"""The on-policy rollout, written out (LeanRL style): ``T`` x (policy, env step) into a preallocated ``[N, T]``
TensorDict, with the carried state exposed for exact checkpoints."""

from __future__ import annotations

from typing import Any, Callable, Sequence

import torch
from tensordict import TensorDictBase
from tensordict.nn import CudaGraphModule
from tensordict.utils import NestedKey
from torchrl.envs import EnvBase, TransformedEnv

StepCallback = Callable[[int, int], None]


def base_env(env: EnvBase) -> EnvBase:
    """The innermost env of a (possibly nested) ``TransformedEnv``."""
    while isinstance(env, TransformedEnv):
        env = env.base_env
    return env


def ensure_native_autoreset(env: EnvBase) -> None:
    """TorchRL reads ``_torchrl_native_autoreset`` from the *instance* ``__dict__``; a class attribute alone
    silently falls back to TorchRL-driven resets (a second reset of finished rows + a host sync per step)."""
    base = base_env(env)
    if getattr(type(base), "_torchrl_native_autoreset", False) and not base.__dict__.get("_torchrl_native_autoreset"):
        base.__dict__["_torchrl_native_autoreset"] = True
    if isinstance(env, TransformedEnv) and base.__dict__.get("_torchrl_native_autoreset"):
        env.__dict__["_torchrl_native_autoreset"] = True


class Rollout:
    """``collect()`` = ``horizon`` times ``policy(td)`` then ``env.step_and_maybe_reset(td)``, stacked into a
    preallocated ``[N, T]`` TensorDict (time last), no host synchronisation per step.

    The loop carries the env's current root TensorDict (observations of the running episodes) from one call to
    the next; :meth:`state_dict` holds it (and the steps of an interrupted rollout), so that a checkpoint taken
    between two env steps continues exactly. The env is reset at the first :meth:`collect` unless a state was
    loaded.

    Args:
        env: a batched env with TorchRL native autoreset (``_torchrl_native_autoreset``): mtbench's envs.
        policy: a ``TensorDictModule`` writing the action (and e.g. ``loc``/``scale``/``action_log_prob``) into
            the TensorDict it receives.
        horizon: env steps per rollout (T).
        cudagraph_policy: replay the policy from a CUDA graph (``tensordict.nn.CudaGraphModule``, as TorchRL's
            ``Collector(cudagraph_policy=...)``); ``True`` or the module's keyword arguments. CUDA only.
        hold_keys: root entries (e.g. ``"observation"``) that keep, at every step of a rollout, the value they had
            at its first step: the policy acts on them and the rollout stores them (MTBench's MT-PQN, whose rollout
            loop never refreshes its observation: ``loss.hold_observation``). The env is unaffected: the carried
            state and the ``("next", ...)`` entries keep the true observations, so the next rollout starts from
            the true current one. Held across episode ends inside the rollout, as MTBench. ``()``: none.
        hold_period: with ``hold_keys``, the held entries are taken afresh every ``hold_period`` steps (at steps 0,
            ``hold_period``, ...) instead of once per rollout (``None``: ``horizon``, MTBench's behaviour).
    """

    def __init__(
        self,
        env: EnvBase,
        policy: Callable[[TensorDictBase], TensorDictBase],
        horizon: int,
        *,
        cudagraph_policy: bool | dict[str, Any] = False,
        hold_keys: Sequence[NestedKey] = (),
        hold_period: int | None = None,
    ) -> None:
        if int(horizon) < 1:
            raise ValueError(f"horizon must be >= 1, got {horizon}")
        if hold_period is not None and not 1 <= int(hold_period) <= int(horizon):
            raise ValueError(f"hold_period must be in [1, {int(horizon)}] (the horizon) or None, got {hold_period}")
        ensure_native_autoreset(env)
        if not base_env(env).__dict__.get("_torchrl_native_autoreset", False):
            raise ValueError(f"{type(base_env(env)).__name__} does not use TorchRL native autoreset "
                             "(_torchrl_native_autoreset = True); the rollout needs it (no host sync per step)")
        self.env = env
        self.horizon = int(horizon)
        self.policy = policy
        self._out_keys = list(getattr(policy, "out_keys", []))
        self._graphed = bool(cudagraph_policy)
        if self._graphed:
            if env.device is None or torch.device(env.device).type != "cuda":
                raise ValueError("cudagraph_policy needs a CUDA env device")
            options = {"warmup": 10, **(cudagraph_policy if isinstance(cudagraph_policy, dict) else {})}
            self.policy = CudaGraphModule(policy, in_keys=[], out_keys=[], device=env.device, **options)
        self.hold_keys = list(hold_keys)
        self.hold_period = self.horizon if hold_period is None else int(hold_period)
        self._carry: TensorDictBase | None = None
        self._steps: list[TensorDictBase] = []
        self._buffer: TensorDictBase | None = None

    @property
    def num_envs(self) -> int:
        return int(self.env.batch_size.numel())

    @property
    def steps_done(self) -> int:
        """Env steps already collected of an interrupted rollout (0 between rollouts)."""
        return len(self._steps)

    def _act(self, td: TensorDictBase) -> TensorDictBase:
        if not self._graphed:
            return self.policy(td)
        try:
            torch.compiler.cudagraph_mark_step_begin()
        except (AttributeError, NotImplementedError):  # pragma: no cover - older torch
            pass
        out = self.policy(td)  # static output buffers of the graph: copy them out
        return td.update(out.select(*self._out_keys, strict=False).clone())

    @torch.no_grad()
    def collect(
        self, on_step: StepCallback | None = None, should_stop: Callable[[], bool] | None = None
    ) -> TensorDictBase | None:
        """Run the (rest of the) rollout; returns the ``[N, T]`` TensorDict, or ``None`` when ``should_stop()``
        became true after a step (the steps so far are kept: the next call, or a checkpoint, continues them).

        ``on_step(step, horizon)`` is called after every env step (``step`` = steps done, 1..T).
        The returned TensorDict is reused by the next rollout: add keys to a shallow copy (``clone(False)``).
        """
        td = self._carry if self._carry is not None else self.env.reset()
        steps = self._steps
        # the held entries: those of the first step of the current hold (an interrupted rollout stored them there)
        held = None
        if self.hold_keys and len(steps) % self.hold_period:
            held = steps[len(steps) - len(steps) % self.hold_period].select(*self.hold_keys).clone()
        while len(steps) < self.horizon:
            if self.hold_keys:
                if len(steps) % self.hold_period == 0:  # a hold starts: the true current entries
                    held = td.select(*self.hold_keys).clone()
                td = td.clone(False).update(held)  # a shallow copy: the carried state keeps the true entries
            td = self._act(td)
            td, td_next = self.env.step_and_maybe_reset(td)
            steps.append(td)
            td = self._carry = td_next
            if on_step is not None:
                on_step(len(steps), self.horizon)
            if should_stop is not None and len(steps) < self.horizon and should_stop():
                return None
        dim = self.env.batch_dims
        if self._buffer is None:
            self._buffer = torch.stack(steps, dim)
        else:
            torch.stack(steps, dim, out=self._buffer)
        steps.clear()
        return self._buffer

    def state_dict(self) -> dict[str, Any]:
        """The carried root TensorDict and the steps of an interrupted rollout (on the CPU)."""
        steps = torch.stack(self._steps, self.env.batch_dims).to("cpu") if self._steps else None
        carry = None if self._carry is None else self._carry.to("cpu").clone()
        return {"carry": carry, "steps": steps}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        device = self.env.device
        carry, steps = state.get("carry"), state.get("steps")
        self._carry = None if carry is None else carry.to(device)
        self._steps = [] if steps is None else list(steps.to(device).unbind(self.env.batch_dims))


__all__ = ["Rollout", "base_env", "ensure_native_autoreset"]
