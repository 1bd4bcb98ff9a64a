"""Aggregate scores over seeds with 95 % stratified bootstrap confidence intervals (Agarwal et al. 2021), through
``rliable`` (``pip install 'mtbench[paper]'``).

Scores are arranged as rliable expects: ``[num_runs, num_tasks]`` (a 1-D array of per-seed scores is one task).
A table cell is the final ``success/mean`` (or progress) of each seed: one "task", so the stratified bootstrap
is the ordinary bootstrap over seeds. Learning curves are ``[num_runs, num_points]``: every point is its own
stratum, which gives rliable's pointwise intervals.

Reproducibility: rliable's ``StratifiedBootstrap`` draws its indices from NumPy's *global* generator
(``np.random.choice``) and ignores ``random_state``; :func:`interval_estimates` seeds the global generator for
the call and restores its previous state afterwards.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np

__all__ = ["Estimate", "curve_intervals", "interval_estimates", "iqm", "seeded_global_numpy"]

DEFAULT_REPS = 10_000


@dataclass(frozen=True)
class Estimate:
    """A point estimate with its confidence interval ``[lo, hi]``."""

    value: float
    lo: float
    hi: float

    def scaled(self, factor: float) -> "Estimate":
        return Estimate(self.value * factor, self.lo * factor, self.hi * factor)

    def fmt(self, digits: int = 2) -> str:
        return f"{self.value:.{digits}f} [{self.lo:.{digits}f}, {self.hi:.{digits}f}]"


def _rliable():
    try:
        from rliable import library, metrics
    except ImportError as err:  # pragma: no cover - exercised only without the extra
        raise ImportError("the paper reports need rliable: pip install 'mtbench[paper]'") from err
    return library, metrics


@contextlib.contextmanager
def seeded_global_numpy(seed: int | None) -> Iterator[None]:
    """Seed NumPy's global generator inside the block (``None``: leave it alone); restore its state after."""
    if seed is None:
        yield
        return
    state = np.random.get_state()
    np.random.seed(seed)
    try:
        yield
    finally:
        np.random.set_state(state)


def iqm(scores: np.ndarray) -> float:
    """Interquartile mean (25 % trimmed mean over all entries), rliable's ``aggregate_iqm``."""
    _, metrics = _rliable()
    return float(metrics.aggregate_iqm(np.asarray(scores, dtype=np.float64)))


def _as_runs_by_tasks(scores: np.ndarray) -> np.ndarray:
    arr = np.asarray(scores, dtype=np.float64)
    if arr.ndim == 1:
        arr = arr[:, None]
    if arr.ndim != 2 or arr.shape[0] < 1 or arr.shape[1] < 1:
        raise ValueError(f"scores must be [num_runs] or [num_runs, num_tasks] with at least one run; got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError("scores must be finite (drop runs whose final score is NaN/inf first)")
    return arr


def interval_estimates(
    scores: np.ndarray,
    *,
    reps: int = DEFAULT_REPS,
    confidence: float = 0.95,
    seed: int | None = 0,
    method: str = "percentile",
) -> dict[str, Estimate]:
    """Mean and IQM of ``scores`` (``[num_runs]`` or ``[num_runs, num_tasks]``) with stratified bootstrap CIs.

    Calls ``rliable.library.get_interval_estimates`` once with ``func = [aggregate_mean, aggregate_iqm]``, so both
    intervals come from the same resamples. Returns ``{"mean": Estimate, "iqm": Estimate}``.
    """
    library, metrics = _rliable()
    arr = _as_runs_by_tasks(scores)

    def func(x: np.ndarray) -> np.ndarray:
        return np.array([metrics.aggregate_mean(x), metrics.aggregate_iqm(x)])

    with seeded_global_numpy(seed):
        points, intervals = library.get_interval_estimates(
            {"scores": arr}, func, method=method, reps=int(reps), confidence_interval_size=confidence)
    point, ci = points["scores"], intervals["scores"]
    return {name: Estimate(float(point[i]), float(ci[0, i]), float(ci[1, i])) for i, name in enumerate(("mean", "iqm"))}


def curve_intervals(
    curves: np.ndarray,
    *,
    reps: int = 2_000,
    confidence: float = 0.95,
    seed: int | None = 0,
    func: Callable[[np.ndarray], np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pointwise mean over runs of ``curves`` (``[num_runs, num_points]``) with its pointwise bootstrap CI.

    Returns ``(mean, lo, hi)``, each ``[num_points]``.
    """
    library, _ = _rliable()
    arr = np.asarray(curves, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[0] < 1:
        raise ValueError(f"curves must be [num_runs, num_points]; got {arr.shape}")
    fn = func or (lambda x: np.mean(x, axis=0))
    with seeded_global_numpy(seed):
        points, intervals = library.get_interval_estimates({"c": arr}, fn, reps=int(reps),
                                                           confidence_interval_size=confidence)
    return np.asarray(points["c"]), np.asarray(intervals["c"][0]), np.asarray(intervals["c"][1])
