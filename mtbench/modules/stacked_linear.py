"""A stack of ``n`` independent linear layers stored in one batched weight tensor.

Used for mixtures of experts (all ``n`` layers applied in parallel) and for per-task output heads (one layer per
task, the output of sample ``i`` taken from layer ``task_id[i]``). Keeping the ``n`` layers in one tensor replaces
Python loops over experts/tasks by a single batched matmul.
"""

from __future__ import annotations

import math

import torch
from torch import nn

from .task_rows import task_rows


class StackedLinear(nn.Module):
    """``n`` independent ``Linear(in_features, out_features)`` layers: ``weight [n, in, out]``, ``bias [n, out]``.

    Default initialisation matches ``nn.Linear`` slice by slice (``kaiming_uniform(a=sqrt(5))``, bias
    ``U(-1/sqrt(in), 1/sqrt(in))``); :meth:`xavier_` gives the per-expert Xavier + zero-bias initialisation used by
    the mixture-of-experts architectures.
    """

    def __init__(self, n: int, in_features: int, out_features: int, bias: bool = True) -> None:
        super().__init__()
        if n < 1:
            raise ValueError(f"StackedLinear: n must be >= 1, got {n}")
        self.n = n
        self.in_features = in_features
        self.out_features = out_features
        self.weight = nn.Parameter(torch.empty(n, in_features, out_features))
        self.bias = nn.Parameter(torch.empty(n, out_features)) if bias else None
        self.reset_parameters()

    def reset_parameters(self) -> None:
        """``nn.Linear``'s default initialisation, applied to each of the ``n`` layers independently."""
        bound = 1.0 / math.sqrt(self.in_features) if self.in_features > 0 else 0.0
        with torch.no_grad():
            # kaiming_uniform(a=sqrt(5)) on a fan_in=in layer == U(-1/sqrt(in), 1/sqrt(in))
            self.weight.uniform_(-bound, bound)
            if self.bias is not None:
                self.bias.uniform_(-bound, bound)

    def xavier_(self, gain: float = 1.0) -> "StackedLinear":
        """Per-layer Xavier-uniform weights (fan_in=in, fan_out=out) and zero bias; returns ``self``."""
        bound = gain * math.sqrt(6.0 / (self.in_features + self.out_features))
        with torch.no_grad():
            self.weight.uniform_(-bound, bound)
            if self.bias is not None:
                self.bias.zero_()
        return self

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """Apply all ``n`` layers.

        ``x`` is either ``[B, in]`` (the same input for every layer) or ``[n, B, in]`` (one input per layer);
        the result is ``[n, B, out]``.
        """
        if x.dim() == 2:
            y = torch.matmul(x, self.weight)  # [B, in] @ [n, in, out] -> [n, B, out]
        elif x.dim() == 3:
            y = torch.bmm(x, self.weight)
        else:
            raise ValueError(f"StackedLinear expects [B, in] or [n, B, in] inputs, got shape {tuple(x.shape)}")
        if self.bias is not None:
            y = y + self.bias.unsqueeze(1)
        return y

    def forward_selected(self, x: torch.Tensor, index: torch.Tensor) -> torch.Tensor:
        """Apply layer ``index[i]`` to row ``x[i]``: ``x [B, in]``, ``index [B]`` -> ``[B, out]``.

        All ``n`` layers are evaluated with one matmul (``[B, in] @ [in, n*out]``) and the wanted output is
        gathered; the gather's backward sends exactly zero gradient to the layers a sample did not select, so the
        loss of task ``k`` never reaches another task's head. This is cheaper than gathering a ``[B, in, out]``
        weight tensor whenever ``n * out`` is small (output heads).
        """
        flat_w = self.weight.permute(1, 0, 2).reshape(self.in_features, self.n * self.out_features)
        y = torch.matmul(x, flat_w).reshape(x.shape[0], self.n, self.out_features)
        gather_idx = index.view(-1, 1, 1).expand(-1, 1, self.out_features)
        y = torch.gather(y, 1, gather_idx).squeeze(1)
        if self.bias is not None:
            y = y + task_rows(self.bias, index)
        return y

    def extra_repr(self) -> str:
        return f"n={self.n}, in_features={self.in_features}, out_features={self.out_features}, bias={self.bias is not None}"
