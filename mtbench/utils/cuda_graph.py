"""Replay a fixed piece of torch work from a CUDA graph after a few eager calls."""

from __future__ import annotations

from typing import Callable, Sequence

import torch


class GraphedStage:
    """A zero-argument function that reads and writes only persistent tensors, captured once into a CUDA graph.

    The first ``warmup`` calls run eagerly (lazy initialisation, allocator warm-up); the next call captures ``fn``
    into a :class:`torch.cuda.CUDAGraph` and every call from then on replays it on the current stream: one launch
    instead of one per kernel, no Python. ``fn`` must therefore be free of host synchronisation and of
    data-dependent Python control flow, and must communicate only through tensors that outlive the capture
    (buffers updated in place). Temporaries live in the graph's memory pool.

    On a CPU device, or with ``enabled=False``, every call runs ``fn`` eagerly: same code, same results.

    Args:
        fn: the work to capture.
        device: the device the work runs on.
        warmup: eager calls before the capture.
        pool: memory pool shared with other stages (``torch.cuda.graph_pool_handle()``); stages sharing a pool
            must be replayed in the order they were captured.
        stream: side stream used for the warm-up calls and the capture (stages sharing a pool should share it);
            ``None``: warm up on the current stream, capture on a stream of torch's choosing.
        generators: non-default ``torch.Generator`` objects ``fn`` draws from (registered with the graph so that
            every replay advances them as an eager call would), or a zero-argument callable returning them, called
            at capture time (for generators created lazily by the warm-up calls).
        enabled: False: always eager.
        name: shown in error messages.
    """

    def __init__(
        self,
        fn: Callable[[], None],
        device: torch.device | str,
        *,
        warmup: int = 1,
        pool: object | None = None,
        stream: torch.cuda.Stream | None = None,
        generators: Sequence[torch.Generator] | Callable[[], Sequence[torch.Generator]] = (),
        enabled: bool = True,
        name: str = "",
    ) -> None:
        self.fn = fn
        self.device = torch.device(device)
        self.enabled = bool(enabled) and self.device.type == "cuda"
        self.warmup = int(warmup)
        self.pool = pool
        self.stream = stream
        self.generators = generators if callable(generators) else tuple(generators)
        self.name = name or getattr(fn, "__name__", "stage")
        self.graph: torch.cuda.CUDAGraph | None = None
        self._calls = 0

    @property
    def captured(self) -> bool:
        return self.graph is not None

    def __call__(self) -> None:
        if not self.enabled:
            self.fn()
            return
        if self.graph is None:
            if self._calls < self.warmup:
                self._calls += 1
                self._eager_on_side_stream()
                return
            self._capture()
        self.graph.replay()

    def _eager_on_side_stream(self) -> None:
        # warm-up on the capture stream (as PyTorch recommends before capturing autograd / cuBLAS work)
        if self.stream is None:
            self.fn()
            return
        main = torch.cuda.current_stream(self.device)
        self.stream.wait_stream(main)
        with torch.cuda.stream(self.stream):
            self.fn()
        main.wait_stream(self.stream)

    def _capture(self) -> None:
        graph = torch.cuda.CUDAGraph()
        for gen in self.generators() if callable(self.generators) else self.generators:
            graph.register_generator_state(gen)
        try:
            with torch.cuda.graph(graph, pool=self.pool, stream=self.stream):
                self.fn()
        except Exception as err:
            raise RuntimeError(
                f"capturing '{self.name}' in a CUDA graph failed ({type(err).__name__}: {err}); the captured code "
                "must not synchronise with the host or create tensors from Python data. Disable the capture "
                "(cudagraph_update=false for the minibatch update, torch_graphs=False for the env) to run it eagerly."
            ) from err
        self.graph = graph

    def reset(self) -> None:
        """Drop the captured graph (the next call captures again), e.g. after buffers were re-allocated."""
        self.graph = None
