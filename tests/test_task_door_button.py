"""Known-answer tests of the door_open and button_press_topdown task definitions (no physics, no env), against the
paper-era MTBench formulas (``task_fns/door_open.py``, ``task_fns/button_press_topdown.py`` of Viraj-Joshi/MTBench
ed2e2b5) recomputed per state in float64 NumPy with Meta-World's own ``tolerance`` and ``hamacher_product``
(compiled from the installed metaworld source), and the fixture guidance in MuJoCo C.
"""

from __future__ import annotations

import importlib.util
import math
import types
from functools import lru_cache
from pathlib import Path

import mujoco
import numpy as np
import pytest
import torch

from mtbench.envs.metaworld.policies.door_open import HANDLE_AT_ZERO, door_angle
from mtbench.envs.metaworld.tasks import door_open as door_task
from mtbench.envs.metaworld.tasks._button import TRAVEL
from mtbench.envs.metaworld.tasks._door import HANDLE_ON_DOOR
from mtbench.envs.metaworld.tasks.button_press_topdown import (
    button_press_topdown_reward,
    button_press_topdown_success,
)
from mtbench.envs.metaworld.tasks.door_open import door_open_reward, door_open_success

# door placed at MTBench's range centre (0.05, 1.0, 0.15): hinge, goal
DOOR = np.array([0.05, 1.0, 0.15])
HINGE = DOOR[:2] + np.array([-0.185, -0.1])
GOAL = DOOR + np.array(door_task.GOAL_OFFSET)


@lru_cache(maxsize=1)
def _reference() -> types.SimpleNamespace | str:
    spec = importlib.util.find_spec("metaworld")
    if spec is None or not spec.submodule_search_locations:
        return "metaworld is not installed"
    root = Path(next(iter(spec.submodule_search_locations)))
    ru_spec = importlib.util.spec_from_file_location("_door_button_ref_reward_utils", root / "utils" / "reward_utils.py")
    ru = importlib.util.module_from_spec(ru_spec)
    ru_spec.loader.exec_module(ru)
    return types.SimpleNamespace(tolerance=ru.tolerance, hamacher=ru.hamacher_product)


@pytest.fixture(scope="module")
def ref() -> types.SimpleNamespace:
    r = _reference()
    if isinstance(r, str):
        pytest.skip(r)
    return r


def _door_ref(ref, tcp, handle, theta, opened_gripper) -> float:
    """MTBench door_open compute_reward (before ``* .01``) in our frame (table top at z = 0)."""
    door = handle + np.array([0.075, -0.15, 0.0])
    radius = np.linalg.norm(tcp[:2] - door[:2])
    floor = 0.0 if radius <= 0.12 else 0.04 * np.log(radius - 0.12) + 0.25
    above = 1.0 if tcp[2] >= floor else ref.tolerance(floor - tcp[2], bounds=(0.0, 0.01), margin=0.1,
                                                      sigmoid="long_tail")
    in_place = ref.tolerance(np.linalg.norm(tcp - door + [0.0, 0.0, 0.01]), bounds=(0.0, 0.06), margin=0.5,
                             sigmoid="long_tail")
    ready = ref.hamacher(above, in_place)
    angle = -theta
    opened = 0.2 * float(theta < -math.pi / 90) + 0.8 * ref.tolerance(
        math.pi / 2 + math.pi / 6 - angle, bounds=(0.0, 0.5), margin=math.pi / 3, sigmoid="long_tail")
    opened = 1.0 if angle > 1.5 else opened
    return float(2 * ref.hamacher(ready, opened_gripper) + 8 * opened)


def _t(x) -> torch.Tensor:
    return torch.as_tensor(np.asarray(x, dtype=np.float64), dtype=torch.float64)


def _handle_at(theta: float) -> np.ndarray:
    c, s = math.cos(theta), math.sin(theta)
    hx, hy = HANDLE_AT_ZERO
    return np.array([HINGE[0] + c * hx - s * hy, HINGE[1] + s * hx + c * hy, 0.15])


# ------------------------------------------------------------------------------------------------ door
def test_policy_handle_point_is_the_task_s() -> None:
    assert tuple(HANDLE_AT_ZERO) == HANDLE_ON_DOOR[:2]


def test_door_open_state_gives_success_and_maximal_reward() -> None:
    theta = -1.65  # opened 95 degrees: "fully open" for the reward and inside the success band
    handle = _handle_at(theta)
    tcp = handle + np.array([0.075, -0.15, -0.01])  # at MTBench's in-place point, above the funnel floor
    dense = door_open_reward(_t([tcp]), _t([handle]), _t([theta]), _t([1.0]))
    torch.testing.assert_close(dense, _t([10.0]))
    assert door_open_success(_t([handle]), _t([GOAL])).tolist() == [True]


def test_door_success_band() -> None:
    # |handle_x - goal_x| <= 0.08 with MTBench's handle point holds for hinge angles in [-2, -1.49]
    thetas = [0.0, -0.7, -1.45, -1.52, -1.7, -1.95, -2.0]
    handles = _t(np.stack([_handle_at(t) for t in thetas]))
    got = door_open_success(handles, _t(np.tile(GOAL, (len(thetas), 1)))).tolist()
    assert got == [False, False, False, True, True, True, True]


@pytest.mark.parametrize("theta", [0.0, -0.02, -0.3, -0.9, -1.2, -1.6])
@pytest.mark.parametrize("opened_gripper", [0.0, 0.3, 1.0])
def test_door_reward_matches_mtbench(ref, theta: float, opened_gripper: float) -> None:
    rng = np.random.default_rng(int(1000 * -theta) + int(10 * opened_gripper))
    handle = _handle_at(theta)
    door = handle + np.array([0.075, -0.15, 0.0])
    tcps = door + rng.uniform([-0.3, -0.3, -0.05], [0.3, 0.3, 0.3], size=(16, 3))
    tcps[0] = door + np.array([0.0, 0.0, -0.01])  # inside the in-place ball and the funnel
    tcps[1] = door + np.array([0.2, -0.2, 0.02])  # outside the funnel, below its floor
    n = len(tcps)
    ours = door_open_reward(_t(tcps), _t(np.tile(handle, (n, 1))), _t([theta] * n), _t([opened_gripper] * n))
    expected = [_door_ref(ref, t, handle, theta, opened_gripper) for t in tcps]
    np.testing.assert_allclose(ours.numpy(), expected, rtol=0, atol=1e-9)


def test_policy_door_angle_from_handle_and_goal() -> None:
    thetas = np.array([0.0, -0.4, -1.0, -1.5])
    handles = _t(np.stack([_handle_at(t) for t in thetas]))
    hinge, est = door_angle(handles, _t(np.tile(GOAL, (4, 1))))
    np.testing.assert_allclose(est.numpy(), thetas, atol=1e-9)
    np.testing.assert_allclose(hinge.numpy(), np.tile(HINGE, (4, 1)), atol=1e-9)


# ------------------------------------------------------------------------------------------------ button
BOX = np.array([0.05, 0.85, 0.12])
OBJ0 = BOX + np.array([0.0, 0.0, 0.1935])  # MTBench's buttonStart point, unpressed
GOAL_Z = OBJ0[2] - TRAVEL  # the end of the travel
INIT_TCP = np.array([0.0, 0.4, 0.2])


def _button_ref(ref, tcp, obj, openness) -> tuple[float, float]:
    """MTBench button_press_topdown: (dense before * .01, button_pressed)."""
    near = ref.tolerance(np.linalg.norm(obj - tcp), bounds=(0.0, 0.05), margin=np.linalg.norm(OBJ0 - INIT_TCP),
                         sigmoid="long_tail")
    pressed = ref.tolerance(abs(GOAL_Z - obj[2]), bounds=(0.0, 0.005), margin=TRAVEL, sigmoid="long_tail")
    return float(2 * ref.hamacher(1.0 - openness, near)), float(pressed)


def test_button_success_is_mtbench_rule() -> None:
    press = np.array([0.0, 0.03, 0.049, 0.051, 0.06, 0.069, 0.071])
    obj = np.tile(OBJ0, (len(press), 1))
    obj[:, 2] -= press
    goal = np.tile(OBJ0 - [0.0, 0.0, TRAVEL], (len(press), 1))
    got = button_press_topdown_success(_t(obj), _t(goal)).tolist()
    assert got == [False, False, False, True, True, True, False]


def test_button_reward_matches_mtbench(ref) -> None:
    rng = np.random.default_rng(1)
    n = 24
    obj = np.tile(OBJ0, (n, 1))
    obj[:, 2] -= rng.uniform(0.0, 0.07, size=n)
    tcp = obj + rng.uniform([-0.06, -0.06, -0.01], [0.06, 0.06, 0.08], size=(n, 3))
    tcp[1] = INIT_TCP
    openness = rng.uniform(0.0, 1.0, size=n)
    goal = np.tile(OBJ0 - [0.0, 0.0, TRAVEL], (n, 1))
    dense, pressed, tcp_to_obj = button_press_topdown_reward(_t(tcp), _t(obj), _t(np.tile(OBJ0, (n, 1))),
                                                             _t(np.tile(INIT_TCP, (n, 1))), _t(goal), _t(1 - openness))
    expected = np.array([_button_ref(ref, tcp[i], obj[i], openness[i]) for i in range(n)])
    np.testing.assert_allclose(dense.numpy(), expected[:, 0], rtol=0, atol=1e-9)
    np.testing.assert_allclose(pressed.numpy(), expected[:, 1], rtol=0, atol=1e-9)
    np.testing.assert_allclose(tcp_to_obj.numpy(), np.linalg.norm(obj - tcp, axis=-1), rtol=0, atol=1e-12)


# ------------------------------------------------------------------------------------------------ fixtures
@pytest.mark.parametrize("task, part, joint, frame", [
    ("button_press_topdown", "button", "btnbox_joint", ("buttonbox", "RetainingWall")),
    ("door_open", "door_link", "doorjoint", ("doorlockB", "RetainingWall")),
    ("drawer_close", "drawer_link", "goal_slidey", ("drawercase_link", "RetainingWall")),
    ("window_open", "windowb_a", "window_slide", ("window_frame", "windowb_b", "RetainingWall")),
])
def test_fixture_parts_are_guided_by_their_joint_alone(task: str, part: str, joint: str, frame: tuple) -> None:
    """``guide_by_joint`` (MuJoCo C): a part shoved against either end of its travel makes no contact with its
    frame and stops within 1 mm of its joint range (the stiff limit)."""
    from mtbench.envs.metaworld.models import compiled_task
    from mtbench.envs.metaworld.scene import STIFF_LIMIT_SOLREF

    _, m = compiled_task(task)
    j = m.joint(joint)
    np.testing.assert_allclose(j.solref, STIFF_LIMIT_SOLREF)
    part_id, frame_ids = m.body(part).id, {m.body(b).id for b in frame}
    excluded = {tuple(sorted(int(x) for x in divmod(sig, 1 << 16))) for sig in m.exclude_signature}
    assert {tuple(sorted((part_id, b))) for b in frame_ids} <= excluded
    lo, hi = m.jnt_range[j.id]
    for push in (-20.0, 20.0):
        d = mujoco.MjData(m)
        mujoco.mj_resetDataKeyframe(m, d, 0)
        for _ in range(int(1.0 / m.opt.timestep)):
            d.qfrc_applied[j.dofadr[0]] = push
            mujoco.mj_step(m, d)
            for c in d.contact[: d.ncon]:
                pair = {int(m.geom_bodyid[c.geom1]), int(m.geom_bodyid[c.geom2])}
                assert not (part_id in pair and pair & frame_ids), f"{part} touches its frame"
        q = float(d.qpos[j.qposadr[0]])
        end = lo if push < 0 else hi
        if task == "door_open" and push < 0:  # the door swings open until it meets the arm, short of -2 rad
            assert q < -0.2
            continue
        assert abs(q - end) < 1e-3, (task, push, q)
    with pytest.raises(ValueError, match="no body 'nope'"):
        from mtbench.envs.metaworld.scene import guide_by_joint

        guide_by_joint(mujoco.MjSpec(), "nope", joint, frame)