"""Known-answer tests of the grasping tasks (push, pick_place, peg_insert_side) against the paper-era MTBench
reward formulas (``task_fns/*.py`` of Viraj-Joshi/MTBench ed2e2b5).

No physics: the tasks' pure reward and success functions run on hand-set states. The reference recomputes MTBench's
composition per state in float64 NumPy from independent parts: the tolerance, Hamacher product and caging reward
are Meta-World's own (compiled from the installed ``metaworld`` source: MTBench's ``_gripper_caging_reward`` is a
port of Meta-World's base caging, with MTBench's pad axis x_mtb being Meta-World's and our y), called with MTBench's
per-task parameters.
"""

from __future__ import annotations

import __future__
import ast
import importlib.util
import types
from functools import lru_cache
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pytest
import torch

from mtbench.envs.metaworld.tasks import peg_insert_side as peg_task
from mtbench.envs.metaworld.tasks import pick_place as pick_place_task
from mtbench.envs.metaworld.tasks import push as push_task
from mtbench.envs.metaworld.tasks.peg_insert_side import PegInsertSide


def _push_rs(action, obj, opened, tcp, left, right, goal, obj_init_pos, init_tcp):
    """(dense reward, success) of push on named state tensors."""
    return (push_task.push_reward(action, obj, opened, tcp, left, right, goal, obj_init_pos, init_tcp),
            push_task.push_success(obj, opened, tcp, goal))


def _pick_place_rs(action, obj, opened, tcp, left, right, goal, obj_init_pos, init_tcp):
    """(dense reward, success) of pick_place on named state tensors."""
    return (pick_place_task.pick_place_reward(action, obj, opened, tcp, left, right, goal, obj_init_pos, init_tcp),
            pick_place_task.pick_place_success(obj, goal))


def _peg_rs(action, obj, opened, head, tcp, left, right, goal, obj_init_pos, init_tcp, head_init, *corners):
    """(dense reward, success) of peg_insert_side on named state tensors."""
    return (peg_task.peg_insert_side_reward(action, obj, opened, head, tcp, left, right, goal, obj_init_pos, init_tcp,
                                            head_init, *corners),
            peg_task.peg_insert_side_success(head, goal))

ATOL = 2e-4  # float32 torch vs float64 numpy on rewards of scale 1..10


# --------------------------------------------------------------------------------------------------------------
# Meta-World reference (compiled from the installed source files)
# --------------------------------------------------------------------------------------------------------------
def _method(path: Path, class_name: str, name: str, namespace: dict[str, Any]) -> Callable[..., Any]:
    tree = ast.parse(path.read_text(), filename=str(path))
    cls = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == class_name)
    func = next(n for n in cls.body if isinstance(n, ast.FunctionDef) and n.name == name)
    func.decorator_list = []
    code = compile(ast.Module(body=[func], type_ignores=[]), str(path), "exec",
                   flags=__future__.annotations.compiler_flag, dont_inherit=True)
    exec(code, namespace)
    return namespace[name]


@lru_cache(maxsize=1)
def _reference() -> dict[str, Callable[..., Any]] | str:
    spec = importlib.util.find_spec("metaworld")
    if spec is None or not spec.submodule_search_locations:
        return "metaworld is not installed"
    root = Path(next(iter(spec.submodule_search_locations)))
    ru_spec = importlib.util.spec_from_file_location("_grasp_ref_reward_utils", root / "utils" / "reward_utils.py")
    ru = importlib.util.module_from_spec(ru_spec)
    ru_spec.loader.exec_module(ru)
    import numpy.typing as npt

    ns = {"np": np, "npt": npt, "Any": Any, "reward_utils": ru}
    return {
        "caging": _method(root / "sawyer_xyz_env.py", "SawyerXYZEnv", "_gripper_caging_reward", dict(ns)),
        "tolerance": ru.tolerance,
        "hamacher": ru.hamacher_product,
        "rect_prism": ru.rect_prism_tolerance,
    }


@pytest.fixture(scope="module")
def ref() -> dict[str, Callable[..., Any]]:
    r = _reference()
    if isinstance(r, str):
        pytest.skip(r)
    return r


class _FakeEnv:
    """What Meta-World's ``compute_reward`` reads from ``self``, for one hand-set state."""

    reward_function_version = "v2"

    def __init__(self, caging: Callable[..., Any], *, tcp, left_pad, right_pad, goal, obj_init_pos, init_tcp,
                 init_left_pad=None, init_right_pad=None, sites=None, target_radius=None,
                 peg_head_pos_init=None) -> None:
        self.tcp_center = np.asarray(tcp, dtype=np.float64)
        self._pads = {"leftpad": np.asarray(left_pad, np.float64), "rightpad": np.asarray(right_pad, np.float64)}
        self._target_pos = np.asarray(goal, np.float64)
        self.obj_init_pos = np.asarray(obj_init_pos, np.float64)
        self.init_tcp = np.asarray(init_tcp, np.float64)
        self.init_left_pad = None if init_left_pad is None else np.asarray(init_left_pad, np.float64)
        self.init_right_pad = None if init_right_pad is None else np.asarray(init_right_pad, np.float64)
        self._sites = {k: np.asarray(v, np.float64) for k, v in (sites or {}).items()}
        self.peg_head_pos_init = None if peg_head_pos_init is None else np.asarray(peg_head_pos_init, np.float64)
        if target_radius is not None:
            self.TARGET_RADIUS = target_radius
        self._gripper_caging_reward = types.MethodType(caging, self)

    def get_body_com(self, name: str) -> np.ndarray:
        return self._pads[name]

    def _get_site_pos(self, name: str) -> np.ndarray:
        return self._sites[name]


def _f32(x) -> np.ndarray:
    """The float32 grid (as float64) so that numpy and torch see identical inputs."""
    return np.asarray(x, dtype=np.float32).astype(np.float64)


def _t(x) -> torch.Tensor:
    return torch.as_tensor(np.asarray(x), dtype=torch.float32)


def _obs(tcp, opened, obj) -> np.ndarray:
    obs = np.zeros(39)
    obs[0:3], obs[3], obs[4:7] = tcp, opened, obj
    return obs


def _random_grasp_states(rng: np.random.Generator, n: int, goal_far: float) -> list[dict[str, np.ndarray]]:
    """States around a puck/peg: hand near or far, pads around it or not, gripper efforts in [-1, 1]."""
    states = []
    for i in range(n):
        obj_init = np.array([rng.uniform(-0.1, 0.1), rng.uniform(0.6, 0.7), 0.02])
        obj = obj_init + rng.normal(0, [0.03, 0.03, 0.02]) * (i % 3 != 0)
        # goal at least goal_far away from the object: no Meta-World success override
        direction = rng.normal(size=3)
        goal = obj + direction / np.linalg.norm(direction) * rng.uniform(goal_far, 0.3)
        near = i % 2 == 0
        tcp = obj + (rng.normal(0, 0.004, 3) if near else rng.normal(0, 0.08, 3))
        half = rng.uniform(0.005, 0.045)
        left, right = tcp + [0, half, 0], tcp - [0, half, 0]
        init_tcp = np.array([0.0, 0.6, 0.2]) + rng.normal(0, 0.01, 3)
        states.append({k: _f32(v) for k, v in dict(
            obj=obj, obj_init=obj_init, goal=goal, tcp=tcp, left=left, right=right, init_tcp=init_tcp,
            init_left=init_tcp + [0, 0.045, 0], init_right=init_tcp - [0, 0.045, 0],
            opened=np.clip(2 * half / 0.1, 0, 1), action=np.array([0, 0, 0, rng.uniform(-1, 1)]),
        ).items()})
    return states


def _stack(states: list[dict[str, np.ndarray]], key: str) -> torch.Tensor:
    return _t(np.stack([s[key] for s in states]))


# --------------------------------------------------------------------------------------------------------------
# push
# --------------------------------------------------------------------------------------------------------------
def _push(states):
    return _push_rs(
        _stack(states, "action"), _stack(states, "obj"), _stack(states, "opened"), _stack(states, "tcp"),
        _stack(states, "left"), _stack(states, "right"), _stack(states, "goal"), _stack(states, "obj_init"),
        _stack(states, "init_tcp"))


def _caging(ref, s, **params) -> float:
    """Meta-World's base caging reward (= MTBench's ``_gripper_caging_reward``) for one state."""
    env = _FakeEnv(ref["caging"], tcp=s["tcp"], left_pad=s["left"], right_pad=s["right"], goal=s["goal"],
                   obj_init_pos=s["obj_init"], init_tcp=s["init_tcp"])
    return float(env._gripper_caging_reward(s["action"], s["obj"], **params))


def _in_place(ref, dist: float, margin: float, radius: float) -> float:
    return float(ref["tolerance"](dist, bounds=(0.0, radius), margin=margin, sigmoid="long_tail"))


def test_push_dense_matches_mtbench(ref) -> None:
    """MTBench push: r = 2·caging(obj_radius=0, pad .05, reach .01, xz .005, medium); + 1 + 5·in_place when the
    TCP is within 2 cm of the puck and the gripper is not fully closed."""
    states = _random_grasp_states(np.random.default_rng(0), 48, goal_far=0.06)
    reward, success = _push(states)
    expected = []
    for s in states:
        r = 2.0 * _caging(ref, s, obj_radius=0.0, pad_success_thresh=0.05, object_reach_radius=0.01,
                          xz_thresh=0.005, medium_density=True)
        if np.linalg.norm(s["tcp"] - s["obj"]) < 0.02 and s["opened"] > 0:
            r += 1.0 + 5.0 * _in_place(ref, np.linalg.norm(s["obj"] - s["goal"]),
                                       np.linalg.norm(s["obj_init"] - s["goal"]), 0.05)
        expected.append(r)
    np.testing.assert_allclose(reward.numpy(), np.array(expected), atol=ATOL, rtol=0)
    assert not success.any()  # every goal is > 5 cm away
    # both branches are exercised: hand at the puck (reward > 1) and away from it
    assert (reward > 1.0).any() and (reward < 1.0).any()


def test_push_success_and_maximum_at_goal() -> None:
    obj = torch.tensor([[0.0, 0.65, 0.02]])
    goal = obj.clone()
    tcp = obj + torch.tensor([0.0, 0.0, 0.004])
    left, right = tcp + torch.tensor([0.0, 0.024, 0.0]), tcp - torch.tensor([0.0, 0.024, 0.0])
    args = dict(goal=goal, obj_init_pos=torch.tensor([[0.0, 0.65, 0.02]]) - torch.tensor([0.0, 0.2, 0.0]),
                init_tcp=torch.tensor([[0.0, 0.6, 0.2]]))
    action = torch.tensor([[0.0, 0.0, 0.0, 1.0]])
    reward, success = _push_rs(action, obj, torch.tensor([0.48]), tcp, left, right, **args)
    assert success.item()
    # caged, gripping and within the reach radius: grasp = 1, in_place = 1 -> 2 * 1 + 1 + 5 * 1
    torch.testing.assert_close(reward, torch.tensor([8.0]), atol=1e-4, rtol=0)
    # MTBench's extra conditions: the hand must be within 2 cm of the puck and the gripper not fully closed
    far_tcp = obj + torch.tensor([0.0, 0.0, 0.025])
    _, success = _push_rs(action, obj, torch.tensor([0.48]), far_tcp, left, right, **args)
    assert not success.item()
    _, success = _push_rs(action, obj, torch.tensor([0.0]), tcp, left, right, **args)
    assert not success.item()
    # 4.9 cm from the goal succeeds, 5.1 cm does not (strict <)
    for d, ok in ((0.049, True), (0.051, False)):
        moved = obj + torch.tensor([d, 0.0, 0.0])
        _, success = _push_rs(action, moved, torch.tensor([0.48]), moved, left, right, **args)
        assert success.item() is ok


def test_push_far_state_small_reward() -> None:
    obj = torch.tensor([[0.0, 0.65, 0.02]])
    reward, success = _push_rs(
        torch.tensor([[0.0, 0.0, 0.0, -1.0]]), obj, torch.tensor([1.0]), torch.tensor([[0.0, 0.6, 0.2]]),
        torch.tensor([[0.0, 0.645, 0.2]]), torch.tensor([[0.0, 0.555, 0.2]]), torch.tensor([[0.1, 0.85, 0.02]]),
        obj, torch.tensor([[0.0, 0.6, 0.2]]))
    assert not success.item() and 0.0 < reward.item() < 0.2


# --------------------------------------------------------------------------------------------------------------
# pick_place
# --------------------------------------------------------------------------------------------------------------
def _pick_place(states):
    return _pick_place_rs(
        _stack(states, "action"), _stack(states, "obj"), _stack(states, "opened"), _stack(states, "tcp"),
        _stack(states, "left"), _stack(states, "right"), _stack(states, "goal"), _stack(states, "obj_init"),
        _stack(states, "init_tcp"))


def test_pick_place_dense_matches_mtbench(ref) -> None:
    """MTBench pick_place: r = H(caging(obj_radius .015, pad .05, reach .01, xz .005, medium), in_place); + 1 +
    5·in_place when held (TCP within 2 cm, gripper not fully closed) and lifted by more than 1 cm."""
    states = _random_grasp_states(np.random.default_rng(1), 48, goal_far=0.075)
    for s in states[::4]:  # some lifted puck states (the +1 + 5 in_place branch)
        s["obj"] = _f32(s["obj_init"] + [0.0, 0.0, 0.05])
        s["tcp"] = _f32(s["obj"] + [0.0, 0.0, 0.005])
    reward, success = _pick_place(states)
    expected = []
    for s in states:
        in_place = _in_place(ref, np.linalg.norm(s["obj"] - s["goal"]), np.linalg.norm(s["obj_init"] - s["goal"]),
                             0.05)
        grasp = _caging(ref, s, obj_radius=0.015, pad_success_thresh=0.05, object_reach_radius=0.01,
                        xz_thresh=0.005, medium_density=True)
        r = float(ref["hamacher"](grasp, in_place))
        if (np.linalg.norm(s["tcp"] - s["obj"]) < 0.02 and s["opened"] > 0
                and s["obj"][2] - 0.01 > s["obj_init"][2]):
            r += 1.0 + 5.0 * in_place
        expected.append(r)
    np.testing.assert_allclose(reward.numpy(), np.array(expected), atol=ATOL, rtol=0)
    assert not success.any()
    assert (reward > 1.0).any() and (reward < 1.0).any()


def test_pick_place_success_threshold() -> None:
    goal = torch.tensor([[0.0, 0.85, 0.2]])
    obj_init = torch.tensor([[0.0, 0.65, 0.02]])
    for d, ok in ((0.0, True), (0.049, True), (0.051, False), (0.069, False)):  # MTBench < 0.05 (Meta-World 0.07)
        obj = goal + torch.tensor([0.0, 0.0, -d])
        tcp = obj.clone()
        reward, success = _pick_place_rs(
            torch.tensor([[0.0, 0.0, 0.0, 1.0]]), obj, torch.tensor([0.48]), tcp, tcp + torch.tensor([0, 0.024, 0]),
            tcp - torch.tensor([0, 0.024, 0]), goal, obj_init, torch.tensor([[0.0, 0.6, 0.2]]))
        assert success.item() is ok
        assert reward.item() > 1.0  # held and lifted
    # at the goal, held: hamacher(grasp, 1) + 1 + 5 = grasp + 6 with grasp in [0, 1]
    assert 6.0 <= _pick_place_rs(
        torch.tensor([[0.0, 0.0, 0.0, 1.0]]), goal, torch.tensor([0.48]), goal, goal + torch.tensor([0, 0.024, 0]),
        goal - torch.tensor([0, 0.024, 0]), goal, obj_init, torch.tensor([[0.0, 0.6, 0.2]]))[0].item() <= 7.0


# --------------------------------------------------------------------------------------------------------------
# peg_insert_side
# --------------------------------------------------------------------------------------------------------------
# collision-box corners of a block at (-0.3, 0.6, 0) (Meta-World's sites, block rotated by 90 deg about z)
_BOX = np.array([-0.3, 0.6, 0.0])
_CORNERS = {
    "bottom_right_corner_collision_box_1": _BOX + [0.11, 0.1, 0.01],
    "top_left_corner_collision_box_1": _BOX + [0.15, -0.1, 0.096],
    "bottom_right_corner_collision_box_2": _BOX + [0.11, 0.1, 0.16],
    "top_left_corner_collision_box_2": _BOX + [0.17, -0.1, 0.19],
}


def _peg(states):
    corners = [_t(np.repeat(_f32(v)[None], len(states), 0)) for v in _CORNERS.values()]
    return _peg_rs(
        _stack(states, "action"), _stack(states, "obj"), _stack(states, "opened"), _stack(states, "head"),
        _stack(states, "tcp"), _stack(states, "left"), _stack(states, "right"), _stack(states, "goal"),
        _stack(states, "obj_init"), _stack(states, "init_tcp"), _stack(states, "head_init"), *corners)


def _peg_states(rng: np.random.Generator, n: int) -> list[dict[str, np.ndarray]]:
    goal = _BOX + np.array(PegInsertSide.GOAL_OFFSET)
    states = _random_grasp_states(rng, n, goal_far=0.1)
    for i, s in enumerate(states):
        s["goal"] = _f32(goal)
        s["obj_init"] = _f32([rng.uniform(0, 0.2), rng.uniform(0.5, 0.7), 0.02])
        s["head_init"] = _f32(s["obj_init"] + [-0.1, 0.0, 0.0])
        if i % 3 == 0:  # carried towards the hole: head in front of the block, some in the collision boxes
            s["obj"] = _f32(goal + [0.13 + rng.uniform(0.075, 0.3), rng.normal(0, 0.02), rng.uniform(-0.13, 0.02)])
            s["tcp"] = _f32(s["obj"] + rng.normal(0, 0.01, 3))
        s["head"] = _f32(s["obj"] + [-0.13, 0.0, -0.01])
    return states


def test_peg_dense_matches_mtbench(ref) -> None:
    """MTBench peg_insert_side: d = ‖(head − goal)·(1, 2, 2)‖ (its (2, 1, 2) in MTBench's frame); in_place =
    H(tol(d, (0, .05), margin d_init), H(box 2, box 1)); grasp = caging(obj_radius .02, pad .05, reach 0, xz .005,
    medium), 1 when held and lifted (TCP within 8 cm); r = H(grasp, in_place) (+ 1 + 5·in_place when held)."""
    states = _peg_states(np.random.default_rng(3), 60)
    reward, success = _peg(states)
    scale = np.array([1.0, 2.0, 2.0])
    c = _CORNERS
    expected = []
    for s in states:
        d = np.linalg.norm((s["head"] - s["goal"]) * scale)
        in_place = _in_place(ref, d, np.linalg.norm((s["head_init"] - s["goal"]) * scale), 0.05)
        boxes = ref["hamacher"](
            ref["rect_prism"](s["head"], c["bottom_right_corner_collision_box_2"],
                              c["top_left_corner_collision_box_2"]),
            ref["rect_prism"](s["head"], c["bottom_right_corner_collision_box_1"],
                              c["top_left_corner_collision_box_1"]))
        in_place = float(ref["hamacher"](in_place, boxes))
        grasp = _caging(ref, s, obj_radius=0.02, pad_success_thresh=0.05, object_reach_radius=0.0,
                        xz_thresh=0.005, medium_density=True)
        held = (np.linalg.norm(s["tcp"] - s["obj"]) < 0.08 and s["opened"] > 0
                and s["obj"][2] - 0.01 > s["obj_init"][2])
        r = float(ref["hamacher"](1.0 if held else grasp, in_place))
        expected.append(r + (1.0 + 5.0 * in_place if held else 0.0))
    np.testing.assert_allclose(reward.numpy(), np.array(expected), atol=ATOL, rtol=0)
    assert not success.any()
    assert (reward > 1.0).any() and (reward < 1.0).any()


def test_peg_success_uses_scaled_distance() -> None:
    goal = torch.tensor([(_BOX + np.array(PegInsertSide.GOAL_OFFSET)).tolist()], dtype=torch.float32)
    corners = [_t(v[None]) for v in _CORNERS.values()]
    cases = (((0.0, 0.0, 0.0), True), ((0.049, 0.0, 0.0), True), ((0.0, 0.024, 0.0), True),
             ((0.0, 0.026, 0.0), False),  # 2.6 cm sideways is 5.2 cm scaled
             ((0.06, 0.0, 0.0), False))  # Meta-World (<= 0.07) would count this
    for offset, ok in cases:
        head = goal + torch.tensor([offset])
        obj = head + torch.tensor([[0.13, 0.0, 0.01]])
        reward, success = _peg_rs(
            torch.tensor([[0.0, 0.0, 0.0, 1.0]]), obj, torch.tensor([0.38]), head, obj,
            obj + torch.tensor([0, 0.019, 0]), obj - torch.tensor([0, 0.019, 0]), goal,
            torch.tensor([[0.1, 0.6, 0.02]]), torch.tensor([[0.0, 0.6, 0.2]]), torch.tensor([[0.0, 0.6, 0.02]]),
            *corners)
        assert success.item() is ok, offset
        assert reward.item() > 1.0  # lifted and held
    # inserted (in_place = 1, lifted: grasp forced to 1) gives the maximal dense reward 1 + 1 + 5
    torch.testing.assert_close(reward.new_tensor(7.0), _peg_rs(
        torch.tensor([[0.0, 0.0, 0.0, 1.0]]), goal + torch.tensor([[0.13, 0.0, 0.01]]), torch.tensor([0.38]), goal,
        goal + torch.tensor([[0.13, 0.0, 0.01]]), goal, goal, goal, torch.tensor([[0.1, 0.6, 0.02]]),
        torch.tensor([[0.0, 0.6, 0.2]]), torch.tensor([[0.0, 0.6, 0.02]]), *corners)[0][0])


# --------------------------------------------------------------------------------------------------------------
# finger-damping stopgap (a two-finger stand-in model, no simulation)
# --------------------------------------------------------------------------------------------------------------
