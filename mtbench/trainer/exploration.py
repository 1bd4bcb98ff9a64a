"""The collection policy of the off-policy loop: the stochastic actor, or uniform random actions (warm-up)."""

from __future__ import annotations

from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase
from torchrl.data import TensorSpec


class ExplorationPolicy(TensorDictModuleBase):
    """Writes ``action`` into the TensorDict it receives and nothing else: a sample of ``actor`` (run on a shallow
    selection of its inputs, so that its intermediate outputs, e.g. ``loc``/``scale``, stay out of the rollout),
    or, while :attr:`random` is set, a uniform sample of ``action_spec`` (MTBench's warm-up: ``rand * 2 - 1`` in
    ``[-1, 1]``). Both draw from the torch generator of the env's device (part of checkpoints)."""

    def __init__(self, actor: TensorDictModuleBase, action_spec: TensorSpec, action_key: str = "action") -> None:
        super().__init__()
        self.actor = actor
        self.action_spec = action_spec
        self.action_key = action_key
        self.in_keys = list(actor.in_keys)
        self.out_keys = [action_key]
        self.random = False

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        if self.random:
            action = self.action_spec.rand()
        else:
            action = self.actor(tensordict.select(*self.in_keys, strict=False)).get(self.action_key)
        tensordict.set(self.action_key, action)
        return tensordict


__all__ = ["ExplorationPolicy"]
