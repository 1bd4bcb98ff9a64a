"""Parameter groups (``actor`` / ``critic`` / ``all``) of a TorchRL loss module."""

from __future__ import annotations

from typing import Iterable, Mapping, Sequence

import torch
from tensordict import TensorDictBase
from torch import nn

PARAM_GROUPS = ("actor", "critic", "all")

# attribute stems searched for each group, in order (functional ``<stem>_params`` first, then ``<stem>``)
_GROUP_STEMS = {
    "actor": ("actor_network",),
    "critic": ("critic_network", "value_network", "qvalue_network"),
}


def _unique_trainable(tensors: Iterable[torch.Tensor]) -> list[nn.Parameter]:
    seen: set[int] = set()
    out: list[nn.Parameter] = []
    for t in tensors:
        # functional losses store parameters shared with another network as detached (non-Parameter) tensors;
        # they belong to the group that owns them
        if isinstance(t, nn.Parameter) and t.requires_grad and id(t) not in seen:
            seen.add(id(t))
            out.append(t)
    return out


def _group_tensors(loss_module: nn.Module, group: str) -> list[nn.Parameter] | None:
    for stem in _GROUP_STEMS[group]:
        params = getattr(loss_module, f"{stem}_params", None)
        if isinstance(params, TensorDictBase):
            return _unique_trainable(params.values(include_nested=True, leaves_only=True))
        net = getattr(loss_module, stem, None) if stem in getattr(loss_module, "_modules", {}) else None
        if isinstance(net, nn.Module):
            return _unique_trainable(net.parameters())
    return None


def resolve_param_group(loss_module: nn.Module, group: str) -> list[nn.Parameter]:
    """Trainable parameters of ``group`` in ``loss_module``.

    * ``"actor"``: ``loss.actor_network_params`` (functional TorchRL losses) or ``loss.actor_network``'s
      parameters (non-functional);
    * ``"critic"``: same with ``critic_network`` (or ``value_network`` / ``qvalue_network``);
    * ``"all"``: every trainable parameter of the loss (target parameters are buffers and never included).

    Parameters shared between actor and critic belong to the actor (TorchRL keeps them as detached
    copies in the critic's parameters). Raises ``ValueError`` when the group does not exist in the loss.
    """
    if group not in PARAM_GROUPS:
        raise ValueError(f"unknown parameter group {group!r}; valid choices: {list(PARAM_GROUPS)}")
    if group == "all":
        params = _unique_trainable(loss_module.parameters())
    else:
        found = _group_tensors(loss_module, group)
        if found is None:
            raise ValueError(
                f"{type(loss_module).__name__} has no {group} network (looked for "
                f"{[s + '_params' for s in _GROUP_STEMS[group]]}); available groups: {available_groups(loss_module)}"
            )
        params = found
    if not params:
        raise ValueError(f"parameter group {group!r} of {type(loss_module).__name__} has no trainable parameter")
    return params


def available_groups(loss_module: nn.Module) -> list[str]:
    """Names of the parameter groups ``loss_module`` provides (``"all"`` always)."""
    out = [g for g in ("actor", "critic") if _group_tensors(loss_module, g)]
    return [*out, "all"]


def terms_reaching(terms: Mapping[str, torch.Tensor], params: Sequence[torch.Tensor]) -> list[str]:
    """Names of the loss terms whose autograd graph reaches at least one of ``params``.

    A term reaches a parameter when back-propagating it would write that parameter's gradient: the walk follows
    ``grad_fn.next_functions`` down to the ``AccumulateGrad`` leaves (host-side graph inspection only: no
    backward pass, no device work). E.g. in TorchRL's ``SACLoss`` only ``loss_qvalue`` reaches the Q networks
    (the actor loss uses detached Q parameters), in ``ClipPPOLoss`` only ``loss_critic`` reaches the critic, and
    a DQN-style ``loss`` reaches its value network.
    """
    targets = {id(p) for p in params}
    out = []
    for name, term in terms.items():
        if not isinstance(term, torch.Tensor) or not term.requires_grad:
            continue
        if term.grad_fn is None:  # the term is itself a leaf parameter
            if id(term) in targets:
                out.append(name)
            continue
        stack, seen = [term.grad_fn], set()
        while stack:
            node = stack.pop()
            if node is None or node in seen:
                continue
            seen.add(node)
            variable = getattr(node, "variable", None)  # AccumulateGrad nodes hold their leaf
            if variable is not None and id(variable) in targets:
                out.append(name)
                break
            stack.extend(next_node for next_node, _ in node.next_functions)
    return out
