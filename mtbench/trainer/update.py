"""Minibatch updates: gradients of any TorchRL loss (or gradient-manipulation wrapper), clip, optimizer step,
with hook points, metrics summed on the device, optionally replayed from a CUDA graph."""

from __future__ import annotations

import contextlib
from typing import Any, Callable, Iterable, Iterator, Mapping, Sequence

import torch
from tensordict import TensorDictBase
from torch import nn

from ..objectives import compute_gradients
from ..utils import GraphedStage, distributed

HookCaller = Callable[[str, Any], None]
#: the policy's current distribution parameters on a minibatch, ``{key: tensor}`` (e.g. ``loc``, ``scale``)
ReferenceFn = Callable[[TensorDictBase], Mapping[str, torch.Tensor]]


class MinibatchUpdate:
    """One optimisation step per minibatch: ``zero_grad`` -> ``compute_gradients(update_module, minibatch)``
    (``update_module.backward`` for the gradient methods, else the sum of the ``loss_*`` terms) -> grad-norm
    clip (global, or per parameter group) -> hooks ``before_optimizer_step`` -> ``optimizer.step()`` ->
    ``after_step()`` (e.g. a soft target-network update) -> hooks ``on_update``.

    The scalar metrics of every update are stacked into one device vector (key order fixed by the first update)
    and summed over :meth:`epochs` (minibatches of a rollout) or :meth:`run` (any sequence of batches, e.g. replay
    samples); nothing is read back to the host. With ``graph=True`` (CUDA) the whole step of :meth:`epochs` is
    captured once, after 3 eager warm-up updates on a side stream, and replayed; every minibatch is gathered
    into static buffers with ``index_select``. This works for the plain loss and for the gradient methods
    (PCGrad, CAGrad, FAMO: their step is sync-free, PCGrad's order generator is registered with the graph through
    ``update_module.cuda_graph_generators()``); Python-side state of the update module does not advance during
    replays, so a module with gradient diagnostics (``diagnostics_every > 0``) has them scheduled here instead:
    before each graphed update that is due, ``update_module.measure_diagnostics(minibatch)`` runs eagerly, and
    ``count_update()`` follows every update.

    :meth:`drawn` runs updates on batches that a function makes on the device (the off-policy loop's draw from
    its full replay buffer); with ``graph=True`` the draw is captured with the step and replayed with it.

    With ``kl_reference`` (rl_games' ``update_mu_sigma``), every update of :meth:`epochs` first evaluates the
    policy's distribution on its minibatch (no gradient; inside the captured step with ``graph=True``), and after
    the step writes it into the batch at the minibatch's rows: from the second epoch on, a loss that measures its
    ``kl`` against the batch's ``loc``/``scale`` measures it against the policy one epoch earlier (the first epoch:
    the behaviour policy). After every epoch the hooks of ``"on_epoch_end"`` get the epoch's per-update means.

    Args:
        update_module: the loss, or the gradient-method wrapper around it.
        optimizer: over the parameters to update (``capturable=True`` for ``graph=True``: fused Adam, or PQN's
            :class:`~mtbench.trainer.skip_found_inf.RAdam`).
        max_grad_norm: grad-norm clip (``None``: no clip, the norm is still reported as ``grad_norm``).
        clip_groups: clip each named group of parameters separately to ``max_grad_norm`` (e.g. SAC's actor, Q
            networks and temperatures, as MTBench clips each of its optimizers) and report their norms as
            ``grad_norm_<name>``; ``None``: one global clip over all the optimizer's parameters.
        after_step: called after every ``optimizer.step()`` (inside the captured step with ``graph=True``).
        kl_reference: ``kl_reference(minibatch) -> {key: tensor}``, the policy's distribution parameters before the
            step, written back into the batch by :meth:`epochs` (above); ``None``: the batch is not changed.
        call_hooks: ``call_hooks(point, metrics)`` runs the hooks of ``point`` (``"before_optimizer_step"``,
            ``"on_update"``); they must be graph-safe.
        graph: replay the update from a CUDA graph. On a CPU device the same code path runs (minibatches gathered
            into the static buffers, the step called eagerly), which the tests compare with the eager path.
        device: the device of the parameters.
    """

    def __init__(
        self,
        update_module: nn.Module,
        optimizer: torch.optim.Optimizer,
        *,
        max_grad_norm: float | None,
        call_hooks: HookCaller,
        graph: bool = False,
        device: torch.device | str = "cpu",
        clip_groups: Mapping[str, Sequence[torch.Tensor]] | None = None,
        after_step: Callable[[], None] | None = None,
        kl_reference: ReferenceFn | None = None,
    ) -> None:
        self.update_module = update_module
        self.optimizer = optimizer
        self.params = [p for group in optimizer.param_groups for p in group["params"]]
        self.max_grad_norm = max_grad_norm
        self.clip_groups = None if clip_groups is None else {k: list(v) for k, v in clip_groups.items()}
        self.after_step = after_step
        self.kl_reference = kl_reference
        self._reference: dict[str, torch.Tensor] | None = None  # the last update's pre-step distribution
        self.call_hooks = call_hooks
        self.graph = bool(graph)
        self.device = torch.device(device)
        self.metric_keys: list[str] | None = None
        self._metric_buf: torch.Tensor | None = None
        self._static: TensorDictBase | None = None
        # gradient diagnostics scheduled by this updater when the step is replayed (graph replays run no Python)
        self._diagnostics = self.graph and int(getattr(update_module, "diagnostics_every", 0) or 0) > 0
        if hasattr(update_module, "diagnostics_in_backward"):
            update_module.diagnostics_in_backward = not self._diagnostics
        stream = torch.cuda.Stream(self.device) if self.graph and self.device.type == "cuda" else None
        self._stage = GraphedStage(self._static_step, self.device, warmup=3, stream=stream,
                                   generators=self._graph_generators, enabled=self.graph, name="minibatch update")
        # the draw of :meth:`drawn` and the update on its batch, captured together
        self._draw: Callable[[], TensorDictBase] | None = None
        self._drawn_stage = GraphedStage(self._drawn_step, self.device, warmup=3, stream=stream,
                                         generators=self._graph_generators, enabled=self.graph,
                                         name="drawn minibatch update")

    def _graph_generators(self) -> list[torch.Generator]:
        """Non-default generators the update draws from (PCGrad's task orders), registered with the graph."""
        gens = getattr(self.update_module, "cuda_graph_generators", None)
        return list(gens()) if callable(gens) else []

    def reset_graph(self) -> None:
        """Capture again at the next update (e.g. the optimizer state was loaded into new tensors)."""
        self._stage.reset()
        self._drawn_stage.reset()

    def step(self, minibatch: TensorDictBase) -> TensorDictBase:
        """One update on ``minibatch``; returns its metrics (detached device tensors, ``grad_norm`` added)."""
        if self.kl_reference is not None:
            self._keep_reference(minibatch)
        self.optimizer.zero_grad(set_to_none=True)
        out = compute_gradients(self.update_module, minibatch)
        if distributed.is_active():  # torchrun: the gradient of the union of the ranks' minibatches
            for p in self.params:
                if p.grad is None:
                    p.grad = torch.zeros_like(p)
            distributed.all_reduce_mean_([p.grad for p in self.params])
        group_norms: dict[str, torch.Tensor] = {}
        if self.clip_groups is not None:
            for name, params in self.clip_groups.items():
                group_norms[name] = self._clip(params)
            grad_norm = torch.linalg.vector_norm(torch.stack(list(group_norms.values())))
        else:
            grad_norm = self._clip(self.params)
        metrics = out.select(*[k for k in out.keys() if isinstance(k, str)]).clone(False)
        metrics.set("grad_norm", grad_norm.detach())
        for name, norm in group_norms.items():
            metrics.set(f"grad_norm_{name}", norm.detach())
        if distributed.is_active():  # every rank's hooks (e.g. the adaptive learning rate) see the same numbers
            distributed.all_reduce_mean_([v for v in metrics.values() if isinstance(v, torch.Tensor)
                                          and v.is_floating_point()])
        self.call_hooks("before_optimizer_step", metrics)
        self.optimizer.step()
        if self.after_step is not None:
            self.after_step()
        self.call_hooks("on_update", metrics)
        return metrics

    def _keep_reference(self, minibatch: TensorDictBase) -> None:
        """The policy's distribution on ``minibatch`` before the step, into persistent buffers (which the replays
        of a captured step write)."""
        assert self.kl_reference is not None
        with torch.no_grad():
            params = {k: v.detach() for k, v in self.kl_reference(minibatch).items()}
        if self._reference is None:  # the first calls are eager (graph warm-up)
            self._reference = {k: v.clone() for k, v in params.items()}
        else:
            for k, v in params.items():
                self._reference[k].copy_(v)

    def _write_reference(self, batch: TensorDictBase, idx: torch.Tensor) -> None:
        """The last update's pre-step distribution into ``batch`` at rows ``idx`` (rl_games ``update_mu_sigma``)."""
        if self.kl_reference is None or self._reference is None:
            return
        for key, value in self._reference.items():
            batch.get(key).index_copy_(0, idx, value.to(batch.get(key).dtype))

    def _clip(self, params: Sequence[torch.Tensor]) -> torch.Tensor:
        """Clip the gradients of ``params`` to ``max_grad_norm`` (if set); their norm before clipping."""
        if self.max_grad_norm is not None:
            return torch.nn.utils.clip_grad_norm_(params, self.max_grad_norm)
        grads = [torch.linalg.vector_norm(p.grad) for p in params if p.grad is not None]
        if not grads:
            return torch.zeros((), device=self.device)
        return torch.linalg.vector_norm(torch.stack(grads))

    def _vector(self, metrics: TensorDictBase) -> torch.Tensor:
        if self.metric_keys is None:
            self.metric_keys = [k for k, v in metrics.items() if isinstance(v, torch.Tensor) and v.numel() == 1]
        return torch.stack([metrics[k].detach().reshape(()).float() for k in self.metric_keys])

    @contextlib.contextmanager
    def _diagnostics_in_backward(self) -> Iterator[None]:
        """Eager updates of a graphed updater: the module measures its scheduled diagnostics in its backward (and
        counts its updates), as in the eager path."""
        if not self._diagnostics:
            yield
            return
        self.update_module.diagnostics_in_backward = True
        try:
            yield
        finally:
            self.update_module.diagnostics_in_backward = False

    def _keep(self, vector: torch.Tensor) -> None:
        """Copy an update's metric vector into the persistent buffer that the replays write."""
        if self._metric_buf is None:  # the first calls are eager (graph warm-up)
            self._metric_buf = torch.zeros_like(vector)
        self._metric_buf.copy_(vector)

    def _means(self, total: torch.Tensor, count: int) -> dict[str, torch.Tensor]:
        """``{key: per-update mean}`` of the summed metric vector ``total`` over ``count`` updates."""
        assert self.metric_keys is not None
        return {k: total[j] / count for j, k in enumerate(self.metric_keys)}

    def _static_step(self) -> None:
        self._keep(self._vector(self.step(self._static)))

    def _drawn_step(self) -> None:
        assert self._draw is not None
        self._keep(self._vector(self.step(self._draw())))

    def epochs(self, batch: TensorDictBase, epochs: int, minibatch_size: int) -> tuple[dict[str, torch.Tensor], int]:
        """``epochs`` passes over a random permutation of the flat ``batch`` in minibatches of ``minibatch_size``
        (which divides the batch); the hooks of ``"on_epoch_end"`` after each pass. With ``kl_reference`` the
        batch's distribution entries are rewritten (class docstring). Returns ``({key: per-update mean}, number of
        updates)`` (device tensors)."""
        n = batch.batch_size[0]
        num_minibatches = n // minibatch_size
        if self.graph and self._static is None:
            self._static = batch[:minibatch_size].clone()
        total: torch.Tensor | None = None
        for _ in range(epochs):
            epoch_total: torch.Tensor | None = None
            perm = torch.randperm(n, device=batch.device)
            for i in range(num_minibatches):
                idx = perm[i * minibatch_size : (i + 1) * minibatch_size]
                if self.graph:
                    for key, value in self._static.items(True, True):
                        torch.index_select(batch.get(key), 0, idx, out=value)
                    if self._diagnostics:
                        if self.update_module.diagnostics_due():
                            self.update_module.measure_diagnostics(self._static)
                        self.update_module.count_update()
                    self._stage()
                    vector = self._metric_buf
                else:
                    vector = self._vector(self.step(batch[idx]))
                self._write_reference(batch, idx)
                epoch_total = vector.clone() if epoch_total is None else epoch_total.add_(vector)
            assert epoch_total is not None
            self.call_hooks("on_epoch_end", self._means(epoch_total, num_minibatches))
            total = epoch_total if total is None else total.add_(epoch_total)
        count = epochs * num_minibatches
        assert total is not None and self.metric_keys is not None
        return self._means(total, count), count

    def drawn_ready(self, draw: Callable[[], TensorDictBase]) -> bool:
        """Whether :meth:`drawn` with ``draw`` replays its captured graph (on a CPU: runs that path) from now on,
        without warm-up or capture."""
        return draw == self._draw and (self._drawn_stage.captured or not self._drawn_stage.enabled)

    def drawn(self, draw: Callable[[], TensorDictBase], count: int) -> tuple[dict[str, torch.Tensor], int]:
        """``count`` updates, each on the batch returned by ``draw()``. With ``graph=True`` (CUDA) ``draw`` and
        the update are captured together, after 3 eager warm-up updates, and replayed ``count`` times: ``draw``
        must then draw its random numbers on the device, read only tensors that outlive the capture and return a
        batch of fixed shapes without synchronising with the host (e.g. indices drawn on the device from a full
        replay buffer, gathered into static buffers and normalised). Another ``draw`` (compared with ``==``)
        captures again. A module with scheduled gradient diagnostics runs its due updates eagerly, with the
        diagnostics measured in its backward as in the eager path (same draws, same random numbers).

        Returns ``({key: per-update mean}, number of updates)`` (device tensors; ``({}, 0)`` for ``count=0``)."""
        if draw != self._draw:
            self._draw = draw
            self._drawn_stage.reset()
        total: torch.Tensor | None = None
        for _ in range(count):
            if self._diagnostics and self.update_module.diagnostics_due():
                with self._diagnostics_in_backward():  # this update as the eager path runs it
                    vector = self._vector(self.step(draw()))
            else:
                self._drawn_stage()
                if self._diagnostics:
                    self.update_module.count_update()
                vector = self._metric_buf
            total = vector.clone() if total is None else total.add_(vector)
        if total is None or self.metric_keys is None:
            return {}, 0
        return self._means(total, count), count

    def run(self, batches: Iterable[TensorDictBase]) -> tuple[dict[str, torch.Tensor], int]:
        """One eager update per batch of ``batches`` (e.g. replay samples, drawn lazily so that each update sees
        the parameters of the previous one), also with ``graph=True`` (e.g. while the off-policy loop's replay
        buffer fills: its length, the bound of the draws, still changes). Returns ``({key: per-update mean},
        number of updates)`` (device tensors; ``({}, 0)`` for no batch)."""
        total: torch.Tensor | None = None
        count = 0
        with self._diagnostics_in_backward():
            for batch in batches:
                vector = self._vector(self.step(batch))
                total = vector.clone() if total is None else total.add_(vector)
                count += 1
        if total is None or self.metric_keys is None:
            return {}, 0
        return self._means(total, count), count


__all__ = ["MinibatchUpdate"]
