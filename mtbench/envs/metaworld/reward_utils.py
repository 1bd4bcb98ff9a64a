"""Batched torch ports of the Meta-World v2 reward helpers.

Every function works on tensors with a leading batch (env) dimension: scalars per env have shape ``[N]``,
points have shape ``[N, 3]`` (any extra leading dims broadcast the same way). Parameters documented as
"float or tensor" may be Python numbers (validated like Meta-World does) or tensors broadcastable to ``[N]``
(not validated: checking them would need a host sync).

The hot-path functions never synchronise with the host: no ``.item()``, no ``nonzero()``, no Python ``if`` on
tensor values; all branching is done with ``torch.where``. They are not meant to be differentiated (the masked
branches of ``torch.where`` may hold ``inf``/``nan`` values that would poison gradients).

Numerics follow ``metaworld/utils/reward_utils.py`` (metaworld 3.0.0, the "v2" reward functions) and
``SawyerXYZEnv._gripper_caging_reward``; ``tests/test_reward_utils.py`` checks them against the installed
package. Behaviour that differs from Meta-World, all in cases where Meta-World raises:

* an unknown ``sigmoid`` name always raises ``ValueError`` (Meta-World only notices it when ``margin != 0``);
* negative *tensor* margins act like a zero margin (binary in/out); Meta-World raises for a negative margin.
  In :func:`gripper_caging_reward` this covers the x-z margin ``‖obj_init_xz − init_tcp_xz‖ − xz_thresh``,
  which is negative when the episode starts with the TCP already within ``xz_thresh`` of the object.
"""

from __future__ import annotations

import contextlib
import math
from numbers import Real
from typing import Iterator, Literal, Union

import torch
from torch import Tensor

__all__ = [
    "SIGMOIDS",
    "mtbench_tolerance",
    "above_floor_funnel",
    "check_unit_interval",
    "grasp_place_reward",
    "gripper_caging_reward",
    "polyline_distance",
    "path_direction",
    "path_speed",
    "progress",
    "reach_progress_reward",
    "reach_term",
    "hamacher_product",
    "hamacher_product_checked",
    "rect_prism_tolerance",
    "sigmoids",
    "tolerance",
]

SigmoidType = Literal[
    "gaussian", "hyperbolic", "long_tail", "reciprocal", "cosine", "linear", "quadratic", "tanh_squared"
]
SIGMOIDS: tuple[str, ...] = (
    "gaussian",
    "hyperbolic",
    "long_tail",
    "reciprocal",
    "cosine",
    "linear",
    "quadratic",
    "tanh_squared",
)
# Sigmoids that accept value_at_1 == 0 (they reach exactly 0 at a finite distance).
_ZERO_OK_SIGMOIDS = ("cosine", "linear", "quadratic")
_DEFAULT_VALUE_AT_MARGIN = 0.1

ScalarOrTensor = Union[Tensor, float]


def _as_float_tensor(x: ScalarOrTensor | int) -> Tensor:
    """Returns ``x`` as a floating tensor (a Python number becomes a 0-d CPU tensor of the default dtype)."""
    if isinstance(x, Tensor):
        return x if x.is_floating_point() else x.to(torch.get_default_dtype())
    return torch.as_tensor(x, dtype=torch.get_default_dtype())


def _check_sigmoid_name(sigmoid: str) -> None:
    if sigmoid not in SIGMOIDS:
        raise ValueError(f"Unknown sigmoid type {sigmoid!r}; valid choices are {list(SIGMOIDS)}.")


def _sigmoid_scale(sigmoid: str, value_at_1: float) -> float:
    """Validates ``value_at_1`` for ``sigmoid`` (as Meta-World does); returns the x-scale giving σ(1) = value_at_1."""
    _check_sigmoid_name(sigmoid)
    if sigmoid in _ZERO_OK_SIGMOIDS:
        if not 0 <= value_at_1 < 1:
            raise ValueError(
                f"`value_at_margin` (value_at_1) must be nonnegative and smaller than 1 for the {sigmoid!r} "
                f"sigmoid, got {value_at_1}."
            )
    elif not 0 < value_at_1 < 1:
        raise ValueError(
            f"`value_at_margin` (value_at_1) must be strictly between 0 and 1 for the {sigmoid!r} sigmoid, "
            f"got {value_at_1}."
        )
    if sigmoid == "gaussian":
        return math.sqrt(-2.0 * math.log(value_at_1))
    if sigmoid == "hyperbolic":
        return math.acosh(1.0 / value_at_1)
    if sigmoid == "long_tail":
        return math.sqrt(1.0 / value_at_1 - 1.0)
    if sigmoid == "reciprocal":
        return 1.0 / value_at_1 - 1.0
    if sigmoid == "cosine":
        return math.acos(2.0 * value_at_1 - 1.0) / math.pi
    if sigmoid == "linear":
        return 1.0 - value_at_1
    if sigmoid == "quadratic":
        return math.sqrt(1.0 - value_at_1)
    # tanh_squared
    return math.atanh(math.sqrt(1.0 - value_at_1))


def _apply_sigmoid(x: Tensor, scale: float, sigmoid: str) -> Tensor:
    scaled = x * scale
    if sigmoid == "gaussian":
        return torch.exp(-0.5 * scaled * scaled)
    if sigmoid == "hyperbolic":
        return 1.0 / torch.cosh(scaled)  # cosh overflows to inf for large |x| -> exactly 0, as in float64
    if sigmoid == "long_tail":
        return 1.0 / (scaled * scaled + 1.0)
    if sigmoid == "reciprocal":
        return 1.0 / (scaled.abs() + 1.0)
    if sigmoid == "cosine":
        return torch.where(scaled.abs() < 1.0, (1.0 + torch.cos(math.pi * scaled)) / 2.0, 0.0)
    if sigmoid == "linear":
        # Like Meta-World: 1 - scaled (not |scaled|), so negative inputs give values > 1.
        return torch.where(scaled.abs() < 1.0, 1.0 - scaled, 0.0)
    if sigmoid == "quadratic":
        return torch.where(scaled.abs() < 1.0, 1.0 - scaled * scaled, 0.0)
    t = torch.tanh(scaled)  # tanh_squared
    return 1.0 - t * t


def sigmoids(x: Tensor, value_at_1: float, sigmoid: SigmoidType) -> Tensor:
    """Maps ``x`` to (0, 1] with the named sigmoid: 1 at ``x == 0``, ``value_at_1`` at ``|x| == 1``.

    Port of Meta-World's ``_sigmoids``; raises ``ValueError`` for an unknown ``sigmoid`` or an invalid
    ``value_at_1`` (``0 < v < 1``; ``0 <= v < 1`` for cosine, linear and quadratic).
    """
    scale = _sigmoid_scale(sigmoid, float(value_at_1))
    return _apply_sigmoid(_as_float_tensor(x), scale, sigmoid)


def tolerance(
    x: Tensor,
    bounds: tuple[ScalarOrTensor, ScalarOrTensor] = (0.0, 0.0),
    margin: ScalarOrTensor = 0.0,
    sigmoid: SigmoidType = "gaussian",
    value_at_margin: float = _DEFAULT_VALUE_AT_MARGIN,
) -> Tensor:
    """1 where ``x`` lies in the inclusive ``bounds``, decaying sigmoidally with the distance outside them.

    Args:
        x: values, any shape.
        bounds: ``(lower, upper)``, floats (may be infinite) or tensors broadcastable to ``x``.
        margin: float or tensor broadcastable to ``x``. Outside the bounds the value is
            ``sigmoid(distance_to_nearest_bound / margin)``, which equals ``value_at_margin`` at distance
            ``margin``. Where the margin is 0 the result is binary (1 inside, 0 outside); negative tensor
            margins are treated like 0.
        sigmoid: one of :data:`SIGMOIDS`.
        value_at_margin: in (0, 1) (or [0, 1) for cosine/linear/quadratic). Like Meta-World, it is not
            validated when ``margin`` is the Python number 0.

    Returns:
        Tensor with ``x``'s broadcast shape and floating dtype.

    Raises:
        ValueError: for an unknown sigmoid, Python-number bounds with ``lower > upper``, a negative
        Python-number margin, or an invalid ``value_at_margin``.
    """
    _check_sigmoid_name(sigmoid)
    lower, upper = bounds
    if isinstance(lower, Real) and isinstance(upper, Real) and lower > upper:
        raise ValueError(f"Lower bound must be <= upper bound, got bounds=({lower}, {upper}).")
    x = _as_float_tensor(x)
    in_bounds = (x >= lower) & (x <= upper)
    if _MTBENCH_TOLERANCE:
        return _mtbench_tolerance_value(x, lower, upper, in_bounds, margin, sigmoid, value_at_margin)
    if isinstance(margin, Real):
        if margin < 0:
            raise ValueError(f"`margin` must be non-negative. Current value: {margin}")
        if margin == 0:
            return in_bounds.to(x.dtype)
        scale = _sigmoid_scale(sigmoid, float(value_at_margin))
        d = torch.where(x < lower, lower - x, x - upper) / float(margin)
        return torch.where(in_bounds, 1.0, _apply_sigmoid(d, scale, sigmoid))
    scale = _sigmoid_scale(sigmoid, float(value_at_margin))
    margin = _as_float_tensor(margin)
    positive = margin > 0
    d = torch.where(x < lower, lower - x, x - upper) / torch.where(positive, margin, 1.0)
    outside = torch.where(positive, _apply_sigmoid(d, scale, sigmoid), 0.0)
    return torch.where(in_bounds, 1.0, outside)


#: whether :func:`tolerance` follows the original MTBench (set by :func:`mtbench_tolerance`). A module-level flag,
#: not a ``contextvars.ContextVar``: ``torch.compile`` traces a global (guarding on its value) but not a context
#: variable, and the env's stages are compiled. Rewards are evaluated from one thread.
_MTBENCH_TOLERANCE: bool = False


@contextlib.contextmanager
def mtbench_tolerance(enabled: bool = True) -> Iterator[None]:
    """Within this context :func:`tolerance` (and everything built on it, e.g. :func:`gripper_caging_reward`)
    behaves like the original MTBench's ``isaacgymenvs/tasks/reward_utils.py::tolerance`` (ed2e2b5), which the
    paper's rewards were computed with: it returns **0 inside the bounds** whenever the margin is positive (its
    ``torch.where`` keeps the margin-0 branch's 0 there), and 0 everywhere where the margin is 0; outside the bounds
    with a positive margin it agrees with Meta-World. The env evaluates the ``reward_version="paper"`` rewards in
    this context. The context is read when the reward is traced, so a CUDA graph captured inside it keeps it.
    """
    global _MTBENCH_TOLERANCE
    previous, _MTBENCH_TOLERANCE = _MTBENCH_TOLERANCE, bool(enabled)
    try:
        yield
    finally:
        _MTBENCH_TOLERANCE = previous


def _mtbench_tolerance_value(x: Tensor, lower: ScalarOrTensor, upper: ScalarOrTensor, in_bounds: Tensor,
                             margin: ScalarOrTensor, sigmoid: str, value_at_margin: float) -> Tensor:
    """MTBench's tolerance: ``sigmoid(d / margin)`` outside the bounds where the margin is positive, else 0."""
    scale = _sigmoid_scale(sigmoid, float(value_at_margin))
    margin_t = _as_float_tensor(margin).to(x.device) if isinstance(margin, Tensor) else float(margin)
    if isinstance(margin_t, float) and margin_t < 0:
        raise ValueError(f"`margin` must be non-negative. Current value: {margin}")
    positive = (margin_t > 0) if isinstance(margin_t, Tensor) else torch.full_like(x, margin_t > 0, dtype=torch.bool)
    safe_margin = torch.where(positive, margin_t, 1.0) if isinstance(margin_t, Tensor) else max(margin_t, 1e-30)
    d = torch.where(x < lower, lower - x, x - upper) / safe_margin
    return torch.where(positive & ~in_bounds, _apply_sigmoid(d, scale, sigmoid), 0.0)


def hamacher_product(a: ScalarOrTensor, b: ScalarOrTensor) -> Tensor:
    """Hamacher t-norm ``a·b / (a + b − a·b)``, and 0 where the denominator is 0 (``a = b = 0``).

    Inputs are expected in [0, 1]; they are not checked here (no host sync). Use
    :func:`hamacher_product_checked` while debugging.
    """
    # A Python-number operand stays a number (no host-to-device copy); two numbers give a 0-d tensor.
    if isinstance(a, Tensor):
        a = _as_float_tensor(a)
    if isinstance(b, Tensor):
        b = _as_float_tensor(b)
    elif not isinstance(a, Tensor):
        a = _as_float_tensor(a)
    num = a * b
    den = a + b - num
    positive = den > 0
    return torch.where(positive, num / torch.where(positive, den, 1.0), 0.0)


def check_unit_interval(value: ScalarOrTensor, name: str = "value") -> None:
    """Debug helper: raises ``ValueError`` unless every element of ``value`` lies in [0, 1] (syncs with the host)."""
    v = _as_float_tensor(value)
    bad = ~((v >= 0.0) & (v <= 1.0))
    if bool(bad.any()):
        first = v[bad].flatten()[0].item()
        raise ValueError(f"{name} must range between 0 and 1; {int(bad.sum())} element(s) do not, e.g. {first}.")


def hamacher_product_checked(a: ScalarOrTensor, b: ScalarOrTensor) -> Tensor:
    """:func:`hamacher_product` with Meta-World's range validation (debug only: syncs with the host)."""
    check_unit_interval(a, "a")
    check_unit_interval(b, "b")
    return hamacher_product(a, b)


def rect_prism_tolerance(curr: Tensor, zero: Tensor, one: Tensor) -> Tensor:
    """Reward ramp inside an axis-aligned box, 1.0 outside it.

    ``zero`` and ``one`` are opposite corners (``[..., 3]``, broadcastable to ``curr``). Inside the box (bounds
    inclusive, in either corner order) the value is ``∏_axis (curr − zero) / (one − zero)``: 0 at the ``zero``
    face, 1 at the ``one`` corner. Outside it is 1.0. As in Meta-World a box that is flat along an axis gives
    ``nan`` (0/0) for points on it.

    Returns:
        Tensor of shape ``curr.shape[:-1]``.
    """
    curr, zero, one = _as_float_tensor(curr), _as_float_tensor(zero), _as_float_tensor(one)
    lo, hi = torch.minimum(zero, one), torch.maximum(zero, one)
    in_prism = ((curr >= lo) & (curr <= hi)).all(dim=-1)
    scale = ((curr - zero) / (one - zero)).prod(dim=-1)
    return torch.where(in_prism, scale, 1.0)


def gripper_caging_reward(
    action: Tensor,
    obj_pos: Tensor,
    obj_radius: ScalarOrTensor,
    pad_success_thresh: ScalarOrTensor,
    object_reach_radius: ScalarOrTensor,
    xz_thresh: ScalarOrTensor,
    *,
    left_pad: Tensor,
    right_pad: Tensor,
    tcp_center: Tensor,
    obj_init_pos: Tensor,
    init_tcp: Tensor,
    desired_gripper_effort: ScalarOrTensor = 1.0,
    high_density: bool = False,
    medium_density: bool = False,
    pad_axis: int = 1,
) -> Tensor:
    """Batched functional port of Meta-World's ``SawyerXYZEnv._gripper_caging_reward``.

    Args:
        action: ``[N, A]`` actions; ``action[..., 3]`` is the gripper effort (+1 = close, as in Meta-World).
        obj_pos: ``[N, 3]`` current object position.
        obj_radius: inner bound of the pad-to-object distance along the pad axis (float or ``[N]``).
        pad_success_thresh: outer bound of the pad-to-object distance along the pad axis (float or ``[N]``).
        object_reach_radius: TCP-to-object radius of the ``medium_density`` reach term (float or ``[N]``).
        xz_thresh: TCP-to-object radius in the plane orthogonal to the pad axis (float or ``[N]``).
        left_pad, right_pad: ``[N, 3]`` finger pad positions (Meta-World: ``leftpad``/``rightpad`` body origins).
        tcp_center: ``[N, 3]`` current tool centre point (midpoint of the fingertips).
        obj_init_pos: ``[N, 3]`` object position at the episode start.
        init_tcp: ``[N, 3]`` TCP position at the episode start.
        desired_gripper_effort: effort that counts as fully closed (float or ``[N]``).
        high_density: average the result with the caging term.
        medium_density: average the result with a TCP-to-object reach term.
        pad_axis: world axis along which the pads separate (Meta-World: 1 = y); the "xz" plane is the
            other two axes.

    Returns:
        ``[N]`` reward in [0, 1].
    """
    if high_density and medium_density:
        raise ValueError("Can only be either high_density or medium_density")
    if pad_axis not in (0, 1, 2):
        raise ValueError(f"pad_axis must be one of 0, 1, 2, got {pad_axis!r}.")
    a, b = (i for i in range(3) if i != pad_axis)
    plane = slice(a, b + 1, b - a)  # the two other axes as a slice: a list index would be a host-to-device copy

    # Caging along the pad axis: each pad must sit between obj_radius and pad_success_thresh from the object.
    obj_p = obj_pos[..., pad_axis]
    obj_init_p = obj_init_pos[..., pad_axis]
    pad_caging = []
    for pad in (left_pad, right_pad):
        pad_p = pad[..., pad_axis]
        margin = ((pad_p - obj_init_p).abs() - pad_success_thresh).abs()
        pad_caging.append(
            tolerance(
                (pad_p - obj_p).abs(),
                bounds=(obj_radius, pad_success_thresh),
                margin=margin,
                sigmoid="long_tail",
            )
        )
    caging_pad_axis = hamacher_product(pad_caging[0], pad_caging[1])

    # Caging in the orthogonal plane: TCP close to the object.
    xz_margin = torch.linalg.vector_norm(obj_init_pos[..., plane] - init_tcp[..., plane], dim=-1) - xz_thresh
    caging_xz = tolerance(
        torch.linalg.vector_norm(tcp_center[..., plane] - obj_pos[..., plane], dim=-1),
        bounds=(0.0, xz_thresh),
        margin=xz_margin,  # a tensor: negative values act as 0 (Meta-World raises there)
        sigmoid="long_tail",
    )

    effort = action[..., 3].clamp_min(0.0)
    if isinstance(desired_gripper_effort, Tensor):
        effort = torch.minimum(effort, desired_gripper_effort)
    else:
        effort = effort.clamp_max(float(desired_gripper_effort))
    gripper_closed = effort / desired_gripper_effort

    caging = hamacher_product(caging_pad_axis, caging_xz)
    gripping = torch.where(caging > 0.97, gripper_closed, 0.0)
    caging_and_gripping = hamacher_product(caging, gripping)

    if high_density:
        caging_and_gripping = (caging_and_gripping + caging) / 2.0
    if medium_density:
        tcp_to_obj = torch.linalg.vector_norm(obj_pos - tcp_center, dim=-1)
        tcp_to_obj_init = torch.linalg.vector_norm(obj_init_pos - init_tcp, dim=-1)
        reach = tolerance(
            tcp_to_obj,
            bounds=(0.0, object_reach_radius),
            margin=(tcp_to_obj_init - object_reach_radius).abs(),
            sigmoid="long_tail",
        )
        caging_and_gripping = (caging_and_gripping + reach) / 2.0
    return caging_and_gripping


def above_floor_funnel(
    hand_pos: Tensor,
    center: Tensor,
    threshold: ScalarOrTensor,
    *,
    log_scale: float = 0.04,
    log_offset: float = 0.4,
    z_tolerance: float = 0.01,
) -> Tensor:
    """Keeps the hand above a log-shaped "floor" funnel centred on a handle (Meta-World door / box-close).

    ``floor = 0`` within horizontal radius ``threshold`` of ``center``, else
    ``log_scale·ln(radius − threshold) + log_offset``. The result is 1 where ``hand_z >= floor``, else
    ``tolerance(floor − hand_z, (0, z_tolerance), margin=floor / 2, long_tail)``.

    Heights are absolute, as in Meta-World (table surface at z = 0): a scene whose table sits elsewhere must
    pass z relative to the table. Meta-World uses ``threshold=0.12`` with ``center = handle + (−0.05, 0, 0)``
    for the door and ``threshold=0.02`` with ``center = lid + (0, 0, 0.02)`` for box-close.

    Args:
        hand_pos: ``[N, 3]`` hand (end-effector) position.
        center: ``[N, 3]`` (or ``[N, 2]``) funnel centre; only x and y are used.
        threshold: radius of the flat part of the funnel (float or ``[N]``).

    Returns:
        ``[N]`` value in [0, 1].
    """
    radius = torch.linalg.vector_norm(hand_pos[..., :2] - center[..., :2], dim=-1)
    outside = radius > threshold
    shifted = torch.where(outside, radius - threshold, 1.0)  # keep log() finite in the masked branch
    floor = torch.where(outside, log_scale * torch.log(shifted) + log_offset, 0.0)
    hand_z = hand_pos[..., 2]
    below = tolerance(floor - hand_z, bounds=(0.0, z_tolerance), margin=floor / 2.0, sigmoid="long_tail")
    return torch.where(hand_z >= floor, 1.0, below)


# --- added for group a ---
# MTBench measures the gripper openness from the two finger-tip positions normalised by 0.095 m (its Franka's
# fully open tip distance); Meta-World's ``obs[3]`` (``TaskState.gripper_open``) divides by 0.1 instead.
MTBENCH_OPEN_DISTANCE = 0.095


def mtbench_gripper_openness(left_pad: Tensor, right_pad: Tensor) -> Tensor:
    """MTBench's ``clip(‖right_pad − left_pad‖ / 0.095, 0, 1)`` (1 = open; ``1 −`` it is its "tcp_closed"),
    ``[N]`` from pad positions ``[N, 3]``. The Panda's pads are 0.56 mm apart when closed (closedness 0.994) and
    10.1 cm apart when open (openness 1)."""
    return (torch.linalg.vector_norm(right_pad - left_pad, dim=-1) / MTBENCH_OPEN_DISTANCE).clamp(0.0, 1.0)


def scaled_norm(d: Tensor, scale: tuple[float, float, float]) -> Tensor:
    """``‖d · scale‖`` for vectors ``[..., 3]`` with a per-axis scale given as Python floats (MTBench's
    ``torch.norm(err * scale)``; no host-to-device copy)."""
    return torch.linalg.vector_norm(torch.stack([d[..., 0] * scale[0], d[..., 1] * scale[1], d[..., 2] * scale[2]],
                                                dim=-1), dim=-1)


# --- reward_version="v2": shaping of our design (docs/metaworld.md, "reward_version v2") ---
V2_LIFTED = 0.01
"""Height (m) above its start by which a held object counts as lifted in :func:`grasp_place_reward` (pick_place's
paper-era ``obj_z - 0.01 > obj_init_z``)."""


def progress(dist: Tensor, dist0: Tensor, radius: float) -> Tensor:
    """Linear progress ``[N]`` in [0, 1] of a distance towards ``radius``: 0 at (or beyond) the start distance
    ``dist0``, 1 within ``radius``. Unlike a long-tail ``tolerance`` it pays every centimetre of the way the same."""
    span = (dist0 - radius).clamp_min(1e-3)
    return ((dist0 - dist) / span).clamp(0.0, 1.0)


def reach_term(reach_dist: Tensor, reach_dist0: Tensor, reach_radius: float) -> Tensor:
    """The v2 reach term ``[N]`` in (0, 1]: ``tolerance(reach_dist, (0, reach_radius), margin=max(reach_dist0 −
    reach_radius, 0.05), long_tail)``, 1 within ``reach_radius``, 0.1 at the start distance."""
    return tolerance(reach_dist, bounds=(0.0, reach_radius), margin=(reach_dist0 - reach_radius).clamp_min(0.05),
                     sigmoid="long_tail")


def reach_progress_reward(reach_dist: Tensor, reach_dist0: Tensor, reach_radius: float, dist: Tensor, dist0: Tensor,
                          radius: float) -> Tensor:
    """The v2 reward ``[N]`` (0..8) of a task that reaches a part and then moves it (dial_turn, door_close)::

        reach = tolerance(reach_dist, (0, reach_radius), margin=max(reach_dist0 − reach_radius, 0.05), long_tail)
        done  = progress(dist, dist0, radius)         # linear in the part's distance to the goal, 1 at success
        r = 2·max(reach, done) + 6·done

    ``reach_dist``/``reach_dist0``: the TCP's current/initial distance to the part; ``dist``/``dist0``: the part's
    current/initial distance to the goal. Reaching pays up to 2 on its own and every centimetre towards the goal pays
    the same; ``max(reach, done)`` keeps the reach term once the part moves, so that leaving it costs nothing."""
    reach = reach_term(reach_dist, reach_dist0, reach_radius)
    done = progress(dist, dist0, radius)
    return 2.0 * torch.maximum(reach, done) + 6.0 * done


def polyline_distance(p: Tensor, points: list[Tensor], stage: Tensor) -> Tensor:
    """Length ``[N]`` of the path from ``p`` through ``points[stage], points[stage + 1], ...`` to the last point
    (the goal). ``points`` are ``[N, 3]`` waypoints ending with the goal; ``stage`` ``[N]`` (integer) is the index of
    the next waypoint of each world, e.g. 0 before a wall, ``len(points) - 1`` once the way to the goal is free."""
    k = len(points)
    # tails[i]: length of the fixed part points[i] -> ... -> points[-1]
    tails = [p.new_zeros(p.shape[:-1])]
    for i in range(k - 2, -1, -1):
        tails.insert(0, tails[0] + torch.linalg.vector_norm(points[i + 1] - points[i], dim=-1))
    options = torch.stack([torch.linalg.vector_norm(points[i] - p, dim=-1) + tails[i] for i in range(k)], dim=-1)
    return options.gather(-1, stage.long().clamp(0, k - 1).unsqueeze(-1)).squeeze(-1)


V2_PROGRESS_GAIN = 1.2  # v2 (since v2-2026-11-28d): reward per m/s of the held object's speed towards its next waypoint
V2_PROGRESS_CAP = 1.0  # ... at most +-1 per step (1 at 0.83 m/s, i.e. 1 cm per 12 ms control step)


def path_direction(p: Tensor, points: list[Tensor], stage: Tensor) -> Tensor:
    """Unit vectors ``[N, 3]`` from ``p`` towards its next waypoint ``points[stage]`` (the direction in which
    :func:`polyline_distance` falls fastest); zero where ``p`` sits on the waypoint."""
    stacked = torch.stack(points, dim=1)  # [N, k, 3]
    index = stage.long().clamp(0, len(points) - 1)[:, None, None].expand(-1, 1, 3)
    towards = stacked.gather(1, index).squeeze(1) - p
    return towards / torch.linalg.vector_norm(towards, dim=-1, keepdim=True).clamp_min(1e-6)


def path_speed(velocity: Tensor | None, p: Tensor, points: list[Tensor], stage: Tensor) -> Tensor | None:
    """Speed ``[N]`` (m/s) of a point at ``p`` moving with ``velocity`` ``[N, 3]`` towards its next waypoint
    (:func:`path_direction`): :func:`grasp_place_reward`'s ``progress_speed``; None without a velocity."""
    return None if velocity is None else (velocity * path_direction(p, points, stage)).sum(-1)


def grasp_place_reward(action: Tensor, tcp: Tensor, left_pad: Tensor, right_pad: Tensor, gripper_open: Tensor,
                       grasp_point: Tensor, grasp_init: Tensor, init_tcp: Tensor, rise: Tensor, dist: Tensor,
                       dist0: Tensor, *, obj_radius: float, pad_success_thresh: float, object_reach_radius: float,
                       xz_thresh: float, hold_radius: float, place_radius: float,
                       progress_speed: Tensor | None = None) -> Tensor:
    """The v2 reward ``[N]`` (0..7; 0..8 with ``progress_speed``) of a grasp-and-carry task: pick_place's paper-era
    form (the one MT-PPO learns in the MT50 run) with the task's own grasp point and path to the goal, optionally
    paying the held object's speed along that path (``progress_speed``, m/s towards the next waypoint: the carry
    paid at once)::

        in_place = tolerance(dist, (0, place_radius), margin=dist0, long_tail)
        grasp    = gripper_caging(grasp_point, obj_radius, pad_success_thresh, object_reach_radius, xz_thresh,
                                  medium_density)                      # fingers around the grasp point
        r = hamacher(grasp, in_place)
        held = ‖tcp − grasp_point‖ < hold_radius and gripper_open > 0 and rise > 0.01
        if held:  r += 1 + 5·in_place
        if held and progress_speed given:  r += clip(1.2 · progress_speed, -1, 1)

    ``dist``/``dist0`` are the object's current/initial path length to the goal (e.g. :func:`polyline_distance`
    through the waypoints that clear an obstacle), ``rise`` its height above its start. The caging term shapes the
    grasp itself (pad positions and the closing effort around the grasp point, against a reach that alone pays
    little), and lifting the held object by 1 cm adds at least 1 + 5·0.1 at once: the signal that makes pick_place
    learnable, which the task's paper-era reward loses (a midpoint through a wall, a band that subtracts, a 2 cm
    hold radius on a 3 cm ball).
    """
    in_place = tolerance(dist, bounds=(0.0, place_radius), margin=dist0.clamp_min(place_radius + 1e-3),
                         sigmoid="long_tail")
    grasp = gripper_caging_reward(action, grasp_point, obj_radius, pad_success_thresh, object_reach_radius, xz_thresh,
                                  left_pad=left_pad, right_pad=right_pad, tcp_center=tcp, obj_init_pos=grasp_init,
                                  init_tcp=init_tcp, medium_density=True)
    reward = hamacher_product(grasp, in_place)
    held = ((torch.linalg.vector_norm(tcp - grasp_point, dim=-1) < hold_radius) & (gripper_open > 0)
            & (rise > V2_LIFTED))
    held_reward = reward + 1.0 + 5.0 * in_place
    if progress_speed is not None:
        held_reward = held_reward + (V2_PROGRESS_GAIN * progress_speed).clamp(-V2_PROGRESS_CAP, V2_PROGRESS_CAP)
    return torch.where(held, held_reward, reward)
