"""Bang-off-bang discrete actions for a continuous-action env (MTBench's ``meta-world-discrete-v2`` variant).

Every action dimension takes one of ``bins`` values spaced evenly over the env's action bounds, ends included:
bin ``b`` of a ``[-1, 1]`` dimension is ``-1 + 2 b / (bins - 1)`` (``bins=3``: ``{-1, 0, +1}``; ``bins=2``:
``{-1, +1}``), MTBench's ``pqn_agent.py`` map. The gripper dimension is mapped like the others (MTBench treats
all four dimensions alike).

:class:`DiscreteActions` is TorchRL's :class:`~torchrl.envs.transforms.ActionDiscretizer` with that map (bins at
both ends of the interval instead of the interval medians) and a ``Categorical(bins)`` action spec of shape
``[*batch, A]``: ``A`` categorical components (int64) with ``bins`` values each, the spec stock TorchRL Q-value
modules and exploration modules take (``QValueModule(action_space="categorical")`` gives the per-dimension
arg-max of ``[..., A, bins]`` action values, ``EGreedyModule`` samples uniform bins for every dimension with one
``randint``). (``ActionDiscretizer`` writes a ``MultiCategorical`` spec, which ``QValueModule`` does not accept and
whose batched ``rand()`` loops over every element in Python.)
"""

from __future__ import annotations

import numbers

import torch
from torchrl.data import Categorical, Composite
from torchrl.envs.transforms import ActionDiscretizer

ACTION_MODES = ("continuous", "discrete")


def check_bins(bins: object) -> int:
    """``bins`` as an int >= 2, else one ``ValueError`` naming the parameter and the valid range."""
    if not (isinstance(bins, numbers.Integral) and not isinstance(bins, bool) and bins >= 2):
        raise ValueError(f"bins must be an integer >= 2 (values per action dimension, 3 = bang-off-bang); "
                         f"got {bins!r}")
    return int(bins)


def bin_values(bins: int, low: float = -1.0, high: float = 1.0) -> torch.Tensor:
    """The ``bins`` action values of one dimension: ``low + b (high - low) / (bins - 1)``, ``b = 0..bins-1``."""
    bins = check_bins(bins)
    return low + torch.arange(bins, dtype=torch.float64) * ((high - low) / (bins - 1))


class DiscreteActions(ActionDiscretizer):
    """Map integer bins ``[*batch, A]`` to the continuous action of the parent env (``ActionDiscretizer``).

    ``env.action_spec`` becomes ``Categorical(bins, shape=[*batch, A], dtype=int64)``; the rollout keeps the
    integer action under ``action_key`` and the parent env receives ``bin_values(bins, low, high)[action]`` per
    dimension (a ``gather``: no host synchronisation). The bin values are derived from the parent's ``Bounded``
    action spec; they are buffers that are not saved in ``state_dict`` (the transform has no state).

    Args:
        bins: values per action dimension (>= 2; 3 = MTBench's bang-off-bang).
        action_key: the action entry (the integer bins in, the continuous action out).
    """

    def __init__(self, bins: int = 3, action_key: str = "action") -> None:
        super().__init__(check_bins(bins), action_key=action_key, categorical=True)
        self.bins = int(bins)

    def custom_arange(self, nint: int, device: torch.device) -> torch.Tensor:
        """Positions of the bins in the normalised interval: ``b / (nint - 1)`` (both ends included)."""
        return torch.arange(nint, dtype=self.dtype, device=device) / (nint - 1)

    def transform_input_spec(self, input_spec: Composite) -> Composite:
        input_spec = super().transform_input_spec(input_spec)
        key = ("full_action_spec", self.out_keys_inv[0])
        multi = input_spec[key]
        input_spec[key] = Categorical(self.bins, shape=multi.shape, dtype=torch.int64, device=multi.device)
        for name in ("intervals", "nvec"):  # derived from the parent's spec: not state
            value = getattr(self, name)
            delattr(self, name)
            self.register_buffer(name, value, persistent=False)
        return input_spec

    def __repr__(self) -> str:
        return f"{type(self).__name__}(bins={self.bins}, action_key={self.action_key!r})"


__all__ = ["ACTION_MODES", "DiscreteActions", "bin_values", "check_bins"]
