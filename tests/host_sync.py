"""CPU proof that a piece of torch work can be captured in a CUDA graph: every Python-side conversion of a tensor
(a host synchronisation on a GPU) and every data-dependent output shape is patched to raise while it runs.

C++-internal checks are not seen (e.g. the CPU ``lu_solve`` checks its pivots with ``item()``); the GPU scripts
(``benchmarks/update_check.py``) capture the real step."""

from __future__ import annotations

import importlib

import pytest
import torch

#: ``torch.Tensor`` methods that read a tensor back to the host or give an output of data-dependent shape
TENSOR_METHODS = ("item", "tolist", "__bool__", "__int__", "__float__", "__index__", "nonzero", "cpu", "numpy",
                  "masked_select", "unique")
#: ``torch`` functions with an output of data-dependent shape
TORCH_FUNCTIONS = ("nonzero", "masked_select", "unique", "argwhere")


def _forbidden(name: str):
    def fail(*args, **kwargs):
        raise AssertionError(f"host sync or dynamic shape: {name}")

    return fail


def forbid_host_sync(monkeypatch: pytest.MonkeyPatch) -> None:
    """Patch every host-sync conversion and data-dependent-shape op (listed above, plus boolean-mask indexing) to
    raise ``AssertionError`` until ``monkeypatch.undo()``."""
    for name in TENSOR_METHODS:
        monkeypatch.setattr(torch.Tensor, name, _forbidden(f"Tensor.{name}"))
    for name in TORCH_FUNCTIONS:
        monkeypatch.setattr(torch, name, _forbidden(f"torch.{name}"))
    getitem = torch.Tensor.__getitem__

    def checked_getitem(self, index):
        for i in index if isinstance(index, tuple) else (index,):
            if isinstance(i, torch.Tensor) and i.dtype == torch.bool:
                raise AssertionError("boolean-mask indexing (data-dependent shape)")
        return getitem(self, index)

    monkeypatch.setattr(torch.Tensor, "__getitem__", checked_getitem)


def allow_capturable_on_cpu(monkeypatch: pytest.MonkeyPatch) -> None:
    """Let ``capturable=True`` torch optimizers (RAdam, Adam, ...) run on the CPU, so that the code path a CUDA
    graph captures (step counts on the device, ``torch.where`` instead of Python branches) is the one checked:
    torch only refuses it there by a device-type assertion."""
    import torch.optim.optimizer as optimizer_module

    supported = optimizer_module._get_capturable_supported_devices

    def with_cpu(*args, **kwargs):
        return [*supported(*args, **kwargs), "cpu"]

    for module_name in ("torch.optim.optimizer", "torch.optim.radam", "torch.optim.adam"):
        module = importlib.import_module(module_name)
        if hasattr(module, "_get_capturable_supported_devices"):
            monkeypatch.setattr(module, "_get_capturable_supported_devices", with_cpu)
