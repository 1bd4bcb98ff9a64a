"""Tests for the batched Meta-World reward helpers (mtbench.envs.metaworld.reward_utils).

The reference is the installed metaworld package: its ``metaworld/utils/reward_utils.py`` helpers, the unbound
``SawyerXYZEnv._gripper_caging_reward`` called on a minimal stand-in object, and ``SawyerDoorEnvV3._reward_pos``
for the door "floor" funnel. metaworld is imported lazily. ``import metaworld`` pulls in every Meta-World env and
through them ``gymnasium.envs.mujoco`` (which needs ``imageio``, optional for us); when that import fails the
same reference code is loaded straight from the installed metaworld source files instead (the helpers module
needs numpy only; the two methods are compiled from their source in the installed files). Tests that need the
reference skip only when metaworld is not installed at all.
"""

from __future__ import annotations

import __future__
import ast
import importlib
import importlib.util
import math
import types
from functools import lru_cache
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pytest
import torch

from mtbench.envs.metaworld.reward_utils import (
    SIGMOIDS,
    above_floor_funnel,
    check_unit_interval,
    gripper_caging_reward,
    hamacher_product,
    hamacher_product_checked,
    rect_prism_tolerance,
    sigmoids,
    tolerance,
)

ATOL = 1e-5
DTYPES = [torch.float32, torch.float64]
ZERO_OK = ("cosine", "linear", "quadratic")


# --------------------------------------------------------------------------------------------------------------
# Reference loading
# --------------------------------------------------------------------------------------------------------------
class _Reference(types.SimpleNamespace):
    reward_utils: Any
    caging: Callable[..., float]
    door_reward_pos: Callable[..., tuple[float, float]]
    source: str


def _compile_method(path: Path, class_name: str, func_name: str, namespace: dict[str, Any]) -> Callable[..., Any]:
    """Compiles one method of ``class_name`` from the source file ``path`` as a plain function."""
    tree = ast.parse(path.read_text(), filename=str(path))
    cls = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == class_name)
    func = next(n for n in cls.body if isinstance(n, ast.FunctionDef) and n.name == func_name)
    func.decorator_list = []  # drop @staticmethod: we call it as a function
    module = ast.Module(body=[func], type_ignores=[])
    code = compile(module, str(path), "exec", flags=__future__.annotations.compiler_flag, dont_inherit=True)
    exec(code, namespace)
    return namespace[func_name]


@lru_cache(maxsize=1)
def _load_reference() -> _Reference | str:
    """Returns the metaworld reference, or the reason why it is unavailable."""
    try:
        ru = importlib.import_module("metaworld.utils.reward_utils")
        from metaworld.envs.sawyer_door_v3 import SawyerDoorEnvV3
        from metaworld.sawyer_xyz_env import SawyerXYZEnv

        return _Reference(
            reward_utils=ru,
            caging=SawyerXYZEnv._gripper_caging_reward,
            door_reward_pos=SawyerDoorEnvV3._reward_pos,
            source="import",
        )
    except Exception as err:  # noqa: BLE001 - any import failure: fall back to the installed source files
        import_error = f"{type(err).__name__}: {err}"
    spec = importlib.util.find_spec("metaworld")
    if spec is None or not spec.submodule_search_locations:
        return f"metaworld cannot be imported ({import_error}) and is not installed"
    root = Path(next(iter(spec.submodule_search_locations)))
    try:
        ru_spec = importlib.util.spec_from_file_location(
            "_mtbench_ref_metaworld_reward_utils", root / "utils" / "reward_utils.py"
        )
        ru = importlib.util.module_from_spec(ru_spec)
        ru_spec.loader.exec_module(ru)
        import numpy.typing as npt

        ns = {"np": np, "npt": npt, "Any": Any, "reward_utils": ru}
        caging = _compile_method(root / "sawyer_xyz_env.py", "SawyerXYZEnv", "_gripper_caging_reward", dict(ns))
        door = _compile_method(root / "envs" / "sawyer_door_v3.py", "SawyerDoorEnvV3", "_reward_pos", dict(ns))
    except Exception as err:  # noqa: BLE001
        return f"metaworld cannot be imported ({import_error}) nor loaded from {root} ({type(err).__name__}: {err})"
    return _Reference(reward_utils=ru, caging=caging, door_reward_pos=door, source=f"files:{root}")


@pytest.fixture(scope="module")
def ref() -> _Reference:
    r = _load_reference()
    if isinstance(r, str):
        pytest.skip(r)
    return r


def _f32(a: np.ndarray) -> np.ndarray:
    """Rounds to the float32 grid (kept as float64) so both sides see identical inputs."""
    return np.asarray(a, dtype=np.float32).astype(np.float64)


def _max_err(ours: torch.Tensor, expected: np.ndarray) -> float:
    ours_np = ours.detach().double().numpy()
    assert ours_np.shape == expected.shape
    assert np.array_equal(np.isnan(ours_np), np.isnan(expected)), "nan pattern differs"
    ok = ~np.isnan(expected)
    return float(np.max(np.abs(ours_np[ok] - expected[ok]), initial=0.0))


# --------------------------------------------------------------------------------------------------------------
# Known values and validation (no metaworld needed)
# --------------------------------------------------------------------------------------------------------------
def test_known_values() -> None:
    x = torch.tensor([1.0, 0.5, 0.25, -0.3, 0.7])
    lt = tolerance(x + 1.0, bounds=(0.0, 1.0), margin=1.0, sigmoid="long_tail")
    torch.testing.assert_close(lt, torch.tensor([0.1, 1 / (1 + 9 * 0.25), 1 / (1 + 9 / 16), 1.0, 1 / (1 + 9 * 0.49)]))
    g = tolerance(torch.tensor([0.5]), bounds=(0.0, 0.0), margin=1.0)
    torch.testing.assert_close(g, torch.tensor([10 ** (-0.25)]))  # gaussian default: 10^(-d²)
    torch.testing.assert_close(g, torch.tensor([0.562341]), atol=1e-6, rtol=0)
    for s in SIGMOIDS:  # every sigmoid is 1 at 0 and value_at_1 at ±1 (except linear's signed variant)
        v = sigmoids(torch.tensor([0.0, 1.0]), 0.25, s)
        torch.testing.assert_close(v, torch.tensor([1.0, 0.25]))
    torch.testing.assert_close(hamacher_product(torch.tensor([0.5, 1.0, 0.0]), torch.tensor([0.5, 0.3, 0.0])),
                               torch.tensor([1 / 3, 0.3, 0.0]))
    # margin 0: binary, bounds inclusive
    b = tolerance(torch.tensor([0.0, 0.1, 0.2, 0.2001, -1e-6]), bounds=(0.0, 0.2), margin=0.0)
    torch.testing.assert_close(b, torch.tensor([1.0, 1.0, 1.0, 0.0, 0.0]))


def test_validation_errors() -> None:
    x = torch.zeros(3)
    with pytest.raises(ValueError, match="Lower bound"):
        tolerance(x, bounds=(1.0, 0.0))
    with pytest.raises(ValueError, match="non-negative"):
        tolerance(x, margin=-0.1)
    with pytest.raises(ValueError, match="valid choices"):
        tolerance(x, margin=1.0, sigmoid="sigmoid")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="strictly between"):
        tolerance(x, margin=1.0, sigmoid="long_tail", value_at_margin=0.0)
    with pytest.raises(ValueError, match="nonnegative"):
        tolerance(x, margin=1.0, sigmoid="linear", value_at_margin=1.0)
    with pytest.raises(ValueError, match="strictly between"):  # a tensor margin always validates
        tolerance(x, margin=torch.zeros(3), sigmoid="gaussian", value_at_margin=1.0)
    # Like Meta-World: value_at_margin is ignored when margin is (the number) 0.
    torch.testing.assert_close(tolerance(x, margin=0.0, value_at_margin=2.0), torch.ones(3))
    with pytest.raises(ValueError, match="high_density or medium_density"):
        _caging_from_numpy(_caging_batch(np.random.default_rng(0), 4), (0.015, 0.05, 0.01, 0.005), torch.float32,
                           high_density=True, medium_density=True)
    with pytest.raises(ValueError, match="pad_axis"):
        _caging_from_numpy(_caging_batch(np.random.default_rng(0), 4), (0.015, 0.05, 0.01, 0.005), torch.float32,
                           pad_axis=3)
    check_unit_interval(torch.tensor([0.0, 1.0, 0.5]))
    with pytest.raises(ValueError, match="between 0 and 1"):
        hamacher_product_checked(torch.tensor([0.5, 1.2]), torch.tensor([0.5, 0.5]))
    with pytest.raises(ValueError, match="between 0 and 1"):
        hamacher_product_checked(torch.tensor([0.5]), torch.tensor([float("nan")]))


def test_no_host_sync_on_meta_device() -> None:
    """Meta tensors have no values: any .item()/bool() on a tensor value inside the helpers would raise here."""
    n = 5
    m = dict(device="meta")
    v, p = torch.empty(n, **m), torch.empty(n, 3, **m)
    for s in SIGMOIDS:
        assert tolerance(v, bounds=(0.0, 0.1), margin=0.3, sigmoid=s).shape == (n,)
        assert tolerance(v, bounds=(v, v), margin=v, sigmoid=s).shape == (n,)
    assert hamacher_product(v, v).shape == (n,)
    assert rect_prism_tolerance(p, p, p).shape == (n,)
    for dens in ({}, {"high_density": True}, {"medium_density": True}):
        out = gripper_caging_reward(torch.empty(n, 4, **m), p, v, v, v, v, left_pad=p, right_pad=p, tcp_center=p,
                                    obj_init_pos=p, init_tcp=p, desired_gripper_effort=v, **dens)
        assert out.shape == (n,)
    assert above_floor_funnel(p, p, 0.12).shape == (n,)


def test_dtype_and_broadcasting() -> None:
    for dtype in DTYPES:
        x = torch.rand(7, dtype=dtype)
        assert tolerance(x, bounds=(0.2, 0.4), margin=0.5).dtype == dtype
        assert tolerance(x, bounds=(0.2, 0.4), margin=torch.full((7,), 0.5, dtype=dtype)).dtype == dtype
        assert hamacher_product(x, 0.5).dtype == dtype
        assert hamacher_product(0.5, x).dtype == dtype
    pts = torch.rand(6, 3)
    assert rect_prism_tolerance(pts, torch.zeros(3), torch.ones(3)).shape == (6,)  # corners broadcast


# --------------------------------------------------------------------------------------------------------------
# Comparison with metaworld: sigmoids, tolerance, hamacher, rect prism
# --------------------------------------------------------------------------------------------------------------
def _values_at_1(sigmoid: str) -> list[float]:
    return [0.1, 0.37, 0.0] if sigmoid in ZERO_OK else [0.1, 0.37, 0.93]


@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("sigmoid", SIGMOIDS)
def test_sigmoids_match_metaworld(ref: _Reference, sigmoid: str, dtype: torch.dtype) -> None:
    x = _f32(np.concatenate([np.linspace(-3.0, 3.0, 601), np.random.default_rng(1).uniform(-20, 20, 400)]))
    for v in _values_at_1(sigmoid):
        expected = np.asarray(ref.reward_utils._sigmoids(x, v, sigmoid), dtype=np.float64)
        err = _max_err(sigmoids(torch.tensor(x, dtype=dtype), v, sigmoid), expected)
        assert err <= ATOL, (sigmoid, v, err)


@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("sigmoid", SIGMOIDS)
def test_tolerance_float_args_match_metaworld(ref: _Reference, sigmoid: str, dtype: torch.dtype) -> None:
    """Python-number bounds and margins (including margin 0 and infinite bounds), vectorised x."""
    x = _f32(np.random.default_rng(2).uniform(-2.0, 2.0, 2000))
    x[:5] = [0.1, 0.4, -0.25, 0.0, 1.0]  # exactly on bounds used below
    bounds_list = [(0.0, 0.0), (0.1, 0.4), (-0.25, 1.0), (-math.inf, 0.1), (0.4, math.inf), (-math.inf, math.inf)]
    for bounds in bounds_list:
        for margin in (0.0, 0.05, 0.3, 1.7):
            for v in _values_at_1(sigmoid)[:2]:
                with np.errstate(invalid="ignore"):  # cos(inf) in metaworld's masked branch (infinite bounds)
                    expected = np.asarray(ref.reward_utils.tolerance(x, bounds=bounds, margin=margin, sigmoid=sigmoid,
                                                                     value_at_margin=v), dtype=np.float64)
                ours = tolerance(torch.tensor(x, dtype=dtype), bounds=bounds, margin=margin, sigmoid=sigmoid,
                                 value_at_margin=v)
                assert ours.dtype == dtype
                err = _max_err(ours, expected)
                assert err <= ATOL, (sigmoid, bounds, margin, v, err)


@lru_cache(maxsize=None)
def _tolerance_tensor_case(sigmoid: str) -> tuple[dict[str, np.ndarray], np.ndarray, float]:
    r = _load_reference()
    assert not isinstance(r, str)
    rng = np.random.default_rng(3)
    n = 2000
    lower = rng.uniform(-1.0, 1.0, n)
    width = np.where(rng.random(n) < 0.2, 0.0, rng.uniform(0.0, 1.0, n))
    upper = lower + width
    margin = np.where(rng.random(n) < 0.25, 0.0, np.exp(rng.uniform(np.log(0.01), np.log(2.0), n)))
    # x: inside the bounds, just outside (within ~2 margins) on either side, far outside, and on the bounds
    kind = rng.integers(0, 5, n)
    span = np.maximum(margin, 0.05) * rng.uniform(0.0, 2.0, n)
    x = np.select(
        [kind == 0, kind == 1, kind == 2, kind == 3],
        [lower + width * rng.random(n), upper + span, lower - span, rng.uniform(-4.0, 4.0, n)],
        default=np.where(rng.random(n) < 0.5, lower, upper),
    )
    data = {k: _f32(a) for k, a in dict(x=x, lower=lower, upper=upper, margin=margin).items()}
    data["upper"] = np.maximum(data["upper"], data["lower"])  # keep lower <= upper after rounding
    v = _values_at_1(sigmoid)[1]
    expected = np.array([
        r.reward_utils.tolerance(float(data["x"][i]), bounds=(float(data["lower"][i]), float(data["upper"][i])),
                                 margin=float(data["margin"][i]), sigmoid=sigmoid, value_at_margin=v)
        for i in range(n)
    ], dtype=np.float64)
    return data, expected, v


@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("sigmoid", SIGMOIDS)
def test_tolerance_tensor_args_match_metaworld(ref: _Reference, sigmoid: str, dtype: torch.dtype) -> None:
    """Per-element tensor bounds and margins (a quarter of them 0), compared sample by sample."""
    data, expected, v = _tolerance_tensor_case(sigmoid)
    t = {k: torch.tensor(a, dtype=dtype) for k, a in data.items()}
    ours = tolerance(t["x"], bounds=(t["lower"], t["upper"]), margin=t["margin"], sigmoid=sigmoid, value_at_margin=v)
    err = _max_err(ours, expected)
    assert err <= ATOL, (sigmoid, err)
    assert ((expected > 0) & (expected < 1)).mean() > 0.1  # the sigmoid branch is exercised


def test_tolerance_validation_matches_metaworld(ref: _Reference) -> None:
    def raises(fn: Callable[[], Any]) -> bool:
        try:
            fn()
        except ValueError:
            return True
        return False

    x_np, x_t = np.array([0.3, 2.0]), torch.tensor([0.3, 2.0])
    for sigmoid in SIGMOIDS:
        for v in (-0.5, 0.0, 1e-3, 0.5, 0.999, 1.0, 1.5):
            for margin in (0.0, 0.7):
                kw = dict(bounds=(0.0, 0.5), margin=margin, sigmoid=sigmoid, value_at_margin=v)
                theirs = raises(lambda: ref.reward_utils.tolerance(x_np, **kw))
                ours = raises(lambda: tolerance(x_t, **kw))
                assert ours == theirs, (sigmoid, v, margin, theirs)
    for kw in (dict(bounds=(0.5, 0.4), margin=0.1), dict(bounds=(0.0, 0.4), margin=-1e-3)):
        assert raises(lambda: ref.reward_utils.tolerance(x_np, **kw))
        assert raises(lambda: tolerance(x_t, **kw))


@pytest.mark.parametrize("dtype", DTYPES)
def test_hamacher_product_matches_metaworld(ref: _Reference, dtype: torch.dtype) -> None:
    rng = np.random.default_rng(4)
    n = 3000
    a, b = rng.random(n), rng.random(n)
    a[rng.random(n) < 0.1] = 0.0
    b[rng.random(n) < 0.1] = 0.0
    a[rng.random(n) < 0.05] = 1.0
    b[rng.random(n) < 0.05] = 1.0
    a[:4], b[:4] = [0.0, 0.0, 1.0, 1e-30], [0.0, 1.0, 1.0, 1e-30]
    a, b = _f32(a), _f32(b)
    expected = np.array([ref.reward_utils.hamacher_product(float(a[i]), float(b[i])) for i in range(n)])
    ours = hamacher_product(torch.tensor(a, dtype=dtype), torch.tensor(b, dtype=dtype))
    assert _max_err(ours, expected) <= ATOL
    for bad in ((1.2, 0.5), (0.5, -0.1)):  # same domain errors as metaworld, in the debug helper only
        with pytest.raises(ValueError):
            ref.reward_utils.hamacher_product(*bad)
        with pytest.raises(ValueError):
            hamacher_product_checked(torch.tensor([bad[0]]), torch.tensor([bad[1]]))


@pytest.mark.parametrize("dtype", DTYPES)
def test_rect_prism_tolerance_matches_metaworld(ref: _Reference, dtype: torch.dtype) -> None:
    rng = np.random.default_rng(5)
    n = 3000
    zero = rng.uniform(-1.0, 1.0, (n, 3))
    one = zero + rng.uniform(-0.5, 0.5, (n, 3))
    frac = rng.uniform(-0.3, 1.3, (n, 3))  # ~40% of the points inside the prism
    curr = zero + frac * (one - zero)
    curr[:3], zero[:3], one[:3] = zero[:3], zero[:3], one[:3]  # exactly on the corners
    curr[3:6] = one[3:6]
    zero[6, 2] = one[6, 2] = curr[6, 2]  # flat box: 0/0 -> nan in both
    curr, zero, one = _f32(curr), _f32(zero), _f32(one)
    with np.errstate(invalid="ignore", divide="ignore"):
        expected = np.array([ref.reward_utils.rect_prism_tolerance(curr[i], zero[i], one[i]) for i in range(n)],
                            dtype=np.float64)
    ours = rect_prism_tolerance(*(torch.tensor(a, dtype=dtype) for a in (curr, zero, one)))
    assert _max_err(ours, expected) <= ATOL
    assert np.isnan(expected[6])
    inside = ~np.isnan(expected) & (expected != 1.0)
    assert inside.mean() > 0.2


# --------------------------------------------------------------------------------------------------------------
# Comparison with metaworld: gripper caging reward
# --------------------------------------------------------------------------------------------------------------
PUSH = (0.015, 0.05, 0.01, 0.005)  # obj_radius, pad_success_thresh, object_reach_radius, xz_thresh (push-v3)
PEG = (0.0075, 0.03, 0.01, 0.005)  # peg-insert-side-v3


def _caging_batch(rng: np.random.Generator, n: int, params: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Random states: a third cages the object exactly, a third is near that, a third is far away."""
    if params is None:
        params = np.tile(np.array(PUSH), (n, 1))
    obj_r, pad_t, _, xz_t = params.T
    obj = rng.uniform(-0.3, 0.3, (n, 3))
    obj_init = obj + rng.normal(0.0, 0.05, (n, 3)) * (rng.random((n, 1)) < 0.5)
    off = rng.uniform(-0.4, 0.4, (n, 3))
    off_xz = np.linalg.norm(off[:, [0, 2]], axis=1, keepdims=True)
    off[:, [0, 2]] *= np.maximum(off_xz, 2.0 * xz_t[:, None] + 0.01) / off_xz  # metaworld needs a >= 0 xz margin
    init_tcp = obj_init + off
    left, right, tcp = obj.copy(), obj.copy(), obj.copy()
    left[:, 1] += rng.uniform(obj_r, pad_t)  # Meta-World pads straddle the object along y
    right[:, 1] -= rng.uniform(obj_r, pad_t)
    tcp[:, [0, 2]] += rng.uniform(-1.0, 1.0, (n, 2)) * xz_t[:, None] / 1.5
    kind = rng.integers(0, 3, n)[:, None]
    scale = np.where(kind == 1, 0.01, np.where(kind == 2, 0.2, 0.0))
    for p in (left, right, tcp):
        p += rng.normal(size=(n, 3)) * scale
    action = rng.uniform(-1.0, 1.0, (n, 4))
    action[:, 3] = rng.uniform(-1.5, 1.5, n)  # gripper effort, incl. values clipped by the reward
    out = dict(action=action, obj_pos=obj, left_pad=left, right_pad=right, tcp_center=tcp, obj_init_pos=obj_init,
               init_tcp=init_tcp)
    return {k: _f32(v) for k, v in out.items()}


def _caging_reference(ref: _Reference, s: dict[str, np.ndarray], params: np.ndarray, effort: np.ndarray,
                      **density: bool) -> np.ndarray:
    out = np.empty(len(s["action"]))
    for i in range(len(out)):
        pads = {"leftpad": s["left_pad"][i].copy(), "rightpad": s["right_pad"][i].copy()}

        def get_body_com(name: str, _pads: dict[str, np.ndarray] = pads) -> np.ndarray:
            return _pads[name]  # KeyError for anything but the two pads

        # exactly the state the method reads: two body COMs, tcp_center, init_tcp, obj_init_pos
        env = types.SimpleNamespace(get_body_com=get_body_com, tcp_center=s["tcp_center"][i].copy(),
                                    init_tcp=s["init_tcp"][i].copy(), obj_init_pos=s["obj_init_pos"][i].copy())
        obj_r, pad_t, reach_r, xz_t = (float(p) for p in params[i])
        out[i] = ref.caging(env, s["action"][i].copy(), s["obj_pos"][i].copy(), obj_r, pad_t, reach_r, xz_t,
                            desired_gripper_effort=float(effort[i]), **density)
    return out


def _caging_from_numpy(s: dict[str, np.ndarray], params: Any, dtype: torch.dtype, effort: Any = 1.0,
                       **kw: Any) -> torch.Tensor:
    t = {k: torch.tensor(v, dtype=dtype) for k, v in s.items()}
    if isinstance(params, np.ndarray):
        params = tuple(torch.tensor(p, dtype=dtype) for p in params.T)
    if isinstance(effort, np.ndarray):
        effort = torch.tensor(effort, dtype=dtype)
    return gripper_caging_reward(t.pop("action"), t.pop("obj_pos"), *params, **t, desired_gripper_effort=effort, **kw)


DENSITIES = {"plain": {}, "high": {"high_density": True}, "medium": {"medium_density": True}}


@lru_cache(maxsize=None)
def _caging_case(case: str, density: str) -> tuple[dict[str, np.ndarray], Any, Any, np.ndarray]:
    r = _load_reference()
    assert not isinstance(r, str)
    rng = np.random.default_rng(6 if case == "floats" else 7)
    n = 1500
    if case == "floats":  # Python-float parameters, push-v3 values
        params_np = np.tile(np.array(PUSH), (n, 1))
        effort_np = np.ones(n)
        params, effort = PUSH, 1.0
    else:  # per-env tensor parameters: push, peg-insert or random values; desired effort 1 or 0.6
        choice = rng.integers(0, 3, n)[:, None]
        rand = np.stack([rng.uniform(0.0, 0.02, n), rng.uniform(0.025, 0.06, n), rng.uniform(0.005, 0.05, n),
                         rng.uniform(0.002, 0.02, n)], axis=1)
        params_np = _f32(np.where(choice == 0, np.array(PUSH), np.where(choice == 1, np.array(PEG), rand)))
        effort_np = _f32(np.where(rng.random(n) < 0.5, 1.0, 0.6))
        params, effort = params_np, effort_np
    s = _caging_batch(rng, n, params_np)
    expected = _caging_reference(r, s, params_np, effort_np, **DENSITIES[density])
    return s, params, effort, expected


@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("density", list(DENSITIES))
@pytest.mark.parametrize("case", ["floats", "tensors"])
def test_gripper_caging_reward_matches_metaworld(ref: _Reference, case: str, density: str, dtype: torch.dtype) -> None:
    s, params, effort, expected = _caging_case(case, density)
    ours = _caging_from_numpy(s, params, dtype, effort, **DENSITIES[density])
    assert ours.shape == expected.shape and ours.dtype == dtype
    err = _max_err(ours, expected)
    assert err <= ATOL, (case, density, dtype, err)
    if density == "plain":  # non-zero only when caging > 0.97 and the gripper closes: that branch is exercised
        assert (expected > 0.5).mean() > 0.05


def test_gripper_caging_negative_xz_margin(ref: _Reference) -> None:
    """init_tcp within xz_thresh of the object at reset: metaworld raises, we use a binary x-z term (margin 0)."""
    s = _caging_batch(np.random.default_rng(8), 64)
    s["init_tcp"] = s["obj_init_pos"] + np.array([0.001, 0.3, -0.001])
    with pytest.raises(ValueError, match="non-negative"):
        _caging_reference(ref, s, np.tile(np.array(PUSH), (64, 1)), np.ones(64))
    ours = _caging_from_numpy(s, PUSH, torch.float32)
    assert torch.isfinite(ours).all() and (ours >= 0).all() and (ours <= 1).all()


def test_gripper_caging_pad_axis() -> None:
    """pad_axis=0 on inputs with x and y swapped equals the Meta-World (pad_axis=1) result."""
    s = _caging_batch(np.random.default_rng(9), 500)
    swapped = {k: (v[:, [1, 0, 2]] if k != "action" else v) for k, v in s.items()}
    a = _caging_from_numpy(s, PUSH, torch.float64, high_density=True)
    b = _caging_from_numpy(swapped, PUSH, torch.float64, high_density=True, pad_axis=0)
    torch.testing.assert_close(a, b, rtol=0, atol=1e-12)


# --------------------------------------------------------------------------------------------------------------
# Comparison with metaworld: the door "floor" funnel (SawyerDoorEnvV3._reward_pos ready_to_open term)
# --------------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("dtype", DTYPES)
def test_above_floor_funnel_matches_metaworld_door(ref: _Reference, dtype: torch.dtype) -> None:
    rng = np.random.default_rng(10)
    n = 3000
    handle = np.stack([rng.uniform(-0.2, 0.2, n), rng.uniform(0.6, 0.9, n), rng.uniform(0.1, 0.2, n)], axis=1)
    radius = np.where(rng.random(n) < 0.3, rng.uniform(0.0, 0.12, n), rng.uniform(0.12, 0.6, n))
    ang = rng.uniform(0.0, 2 * np.pi, n)
    hand = handle + np.array([-0.05, 0.0, 0.0])  # funnel centre
    hand[:, 0] += radius * np.cos(ang)
    hand[:, 1] += radius * np.sin(ang)
    hand[:, 2] = rng.uniform(0.0, 0.45, n)  # above and below the floor (0.2..0.4 outside the flat part)
    obs = np.zeros((n, 39))
    obs[:, :3], obs[:, 4:7] = _f32(hand), _f32(handle)
    hand, handle = obs[:, :3], obs[:, 4:7]
    expected = np.array([ref.door_reward_pos(obs[i], -0.3)[0] for i in range(n)], dtype=np.float64)

    h, d = torch.tensor(hand, dtype=dtype), torch.tensor(handle, dtype=dtype)
    center = d + torch.tensor([-0.05, 0.0, 0.0], dtype=dtype)
    above = above_floor_funnel(h, center, 0.12)
    in_place = tolerance(torch.linalg.vector_norm(h - center - torch.tensor([0.05, 0.03, -0.01], dtype=dtype), dim=-1),
                         bounds=(0.0, 0.06), margin=0.5, sigmoid="long_tail")
    err = _max_err(hamacher_product(above, in_place), expected)
    assert err <= ATOL, err
    assert ((above > 0) & (above < 1)).double().mean() > 0.2  # below-the-floor branch exercised
    assert (above == 1).double().mean() > 0.2


def test_mtbench_tolerance_reproduces_the_originals_semantics() -> None:
    """The original MTBench ``tolerance`` (used by the paper's rewards) returns 0 inside the bounds when the margin
    is positive and 0 everywhere for a zero margin; outside the bounds with a positive margin it is Meta-World's."""
    from mtbench.envs.metaworld.reward_utils import mtbench_tolerance

    x = torch.tensor([0.0, 0.03, 0.05, 0.06, 0.1, 0.3], dtype=torch.float64)
    correct = tolerance(x, bounds=(0.0, 0.05), margin=0.1, sigmoid="long_tail")
    assert correct[:3].eq(1.0).all()
    with mtbench_tolerance():
        paper = tolerance(x, bounds=(0.0, 0.05), margin=0.1, sigmoid="long_tail")
        zero_margin = tolerance(x, bounds=(0.0, 0.05), margin=0.0, sigmoid="long_tail")
        mixed = tolerance(x, bounds=(0.0, 0.05), margin=torch.tensor([0.1, 0.0, 0.1, 0.0, 0.1, 0.1],
                                                                       dtype=torch.float64), sigmoid="gaussian")
        with mtbench_tolerance(False):  # nested: the correct semantics again
            torch.testing.assert_close(tolerance(x, bounds=(0.0, 0.05), margin=0.1, sigmoid="long_tail"), correct)
    # known answers: long_tail(d) = 1 / (1 + (3 d)^2), d = (x - 0.05) / 0.1 outside
    expected = torch.tensor([0.0, 0.0, 0.0, 1 / (1 + 0.3**2), 1 / (1 + 1.5**2), 1 / (1 + 7.5**2)], dtype=torch.float64)
    torch.testing.assert_close(paper, expected)
    assert zero_margin.eq(0.0).all()
    gauss = lambda d: 10.0 ** (-(d**2))  # noqa: E731  (gaussian with value 0.1 at the margin)
    torch.testing.assert_close(mixed, torch.tensor([0.0, 0.0, 0.0, 0.0, gauss(0.5), gauss(2.5)], dtype=torch.float64))
    # the context is left: back to Meta-World's behaviour
    torch.testing.assert_close(tolerance(x, bounds=(0.0, 0.05), margin=0.1, sigmoid="long_tail"), correct)
