"""Group a of the MT50 tasks (MTBench ids 5-11, 13-15): button_press_topdown_wall, button_press, button_press_wall,
coffee_button, coffee_pull, coffee_push, dial_turn, door_close, door_lock, door_unlock.

* Known answers (no physics): each task's reward and success functions on hand-built states, against values written
  out from MTBench's formulas (paper-era ``task_fns/<task>.py``, mapped to our frame) with the sigmoids in closed
  form (long_tail ``1 / (1 + (3 d)²)``, gaussian ``0.1^(d²)``, d = distance outside the bounds / margin) or through
  ``reward_utils`` on explicitly computed distances: the maximum, a far state, every conditional branch and both
  sides of every success threshold.
* Scene facts in MuJoCo C: joint ranges, the observed points (sites) against the offsets the rewards and goals use,
  collision-free starts over the reset ranges, fixtures guided by their joints, and the geometry that makes
  coffee_button's literal TCP rule unreachable.
* Scripted success: every task's scripted policy solves >= 80% of randomized episodes.
"""

from __future__ import annotations

import copy
import itertools
import math

import mujoco
import numpy as np
import pytest
import torch

from mtbench.envs.metaworld import TASKS
from mtbench.envs.metaworld import robot
from mtbench.envs.metaworld.reward_utils import gripper_caging_reward, mtbench_gripper_openness, scaled_norm
from mtbench.envs.metaworld.tasks import _button, _coffee, _lock
from mtbench.envs.metaworld.tasks.button_press import button_press_reward, button_press_success
from mtbench.envs.metaworld.tasks.button_press_topdown_wall import (
    button_press_topdown_wall_reward,
    button_press_topdown_wall_success,
)
from mtbench.envs.metaworld.tasks.button_press_wall import button_press_wall_reward, button_press_wall_success
from mtbench.envs.metaworld.tasks.coffee_button import TCP_RADIUS, coffee_button_reward, coffee_button_success
from mtbench.envs.metaworld.tasks.coffee_pull import coffee_pull_reward, coffee_pull_success
from mtbench.envs.metaworld.tasks.coffee_push import coffee_push_reward, coffee_push_success
from mtbench.envs.metaworld.tasks.dial_turn import dial_angle_for_success, dial_turn_reward, dial_turn_success
from mtbench.envs.metaworld.tasks.door_close import door_close_reward, door_close_success
from mtbench.envs.metaworld.tasks.door_lock import door_lock_reward, door_lock_success
from mtbench.envs.metaworld.tasks.door_unlock import door_unlock_reward, door_unlock_success

GROUP_A = {
    "button_press_topdown_wall": (5, "Press a button downward from above while a short wall stands in front of it."),
    "button_press": (6, "Push a button horizontally into the wall-mounted panel."),
    "button_press_wall": (7, "Push a horizontal button on a panel that is partly hidden behind a short wall."),
    "coffee_button": (8, "Push the button on the front of the coffee machine."),
    "coffee_pull": (9, "Pull a coffee mug away from underneath the coffee machine to a goal position."),
    "coffee_push": (10, "Push a coffee mug underneath the spout of the coffee machine."),
    "dial_turn": (11, "Turn a dial on the table to the goal angle."),
    "door_close": (13, "Push an open door shut by swinging it on its hinges."),
    "door_lock": (14, "Turn the door's lock lever downward to lock the door."),
    "door_unlock": (15, "Turn the door's lock lever upward to unlock the door."),
}
INIT_TCP = np.array([0.0, 0.4, 0.2])


def _t(x) -> torch.Tensor:
    return torch.as_tensor(np.asarray(x, dtype=np.float64), dtype=torch.float64)


def _pts(*points) -> torch.Tensor:
    """``[n, 3]`` float64 tensor of points."""
    return _t(np.stack([np.asarray(p, dtype=np.float64) for p in points]))


def long_tail(d: float) -> float:
    return 1.0 / (1.0 + (3.0 * d) ** 2)


def gauss(d: float) -> float:
    return 0.1 ** (d * d)


def tol(x: float, upper: float, margin: float, sigmoid=long_tail) -> float:
    """Meta-World's ``tolerance`` for bounds (0, upper), written out."""
    if x <= upper:
        return 1.0
    return sigmoid((x - upper) / margin) if margin > 0 else 0.0


def ham(a: float, b: float) -> float:
    den = a + b - a * b
    return a * b / den if den > 0 else 0.0


def _close(value: torch.Tensor, expected: list[float] | float) -> None:
    expected = [expected] if isinstance(expected, float) else expected
    np.testing.assert_allclose(value.numpy(), expected, rtol=0, atol=1e-12)


# ------------------------------------------------------------------------------------------------ registry
def test_group_a_tasks_registered_with_mtbench_ids_and_descriptions() -> None:
    for name, (mtbench_id, description) in GROUP_A.items():
        cls = TASKS[name]
        assert cls.mtbench_id == mtbench_id and cls.description == description and cls.name == name


# ------------------------------------------------------------------------------------------------ buttons
BOX = np.array([0.03, 0.85, 0.12])
B_INIT = BOX + [0.0, -0.1935, 0.0]  # MTBench's buttonStart, unpressed
B_GOAL = B_INIT + [0.0, 0.06, 0.0]  # end of the travel


def test_button_press_reward_known_answers() -> None:
    # (a) button fully pressed, TCP on the button, gripper closed: near = 1, tcp_closed = 1 -> 2 H(1, 1) = 2
    d, pressed, t2o = button_press_reward(_pts(B_GOAL), _pts(B_GOAL), _pts(INIT_TCP), _pts(B_GOAL), _t([1.0]))
    _close(d, 2.0), _close(pressed, 1.0), _close(t2o, 0.0)
    # (b) far: the TCP at its start, button unpressed, half-closed gripper
    dist = float(np.linalg.norm(B_INIT - INIT_TCP))
    d, pressed, _ = button_press_reward(_pts(INIT_TCP), _pts(B_INIT), _pts(INIT_TCP), _pts(B_GOAL), _t([0.5]))
    _close(d, 2.0 * ham(0.5, long_tail((dist - 0.05) / dist)))
    _close(pressed, long_tail((0.06 - 0.005) / 0.06))
    # (c) near margin from the *current* button point (MTBench button_press): pressed 3 cm, TCP 8 cm behind it
    obj = B_INIT + [0.0, 0.03, 0.0]
    tcp = obj + [0.0, -0.08, 0.0]
    d, pressed, _ = button_press_reward(_pts(tcp), _pts(obj), _pts(INIT_TCP), _pts(B_GOAL), _t([0.8]))
    margin = float(np.linalg.norm(obj - INIT_TCP))
    _close(d, 2.0 * ham(0.8, long_tail(0.03 / margin)))
    _close(pressed, long_tail(0.025 / 0.06))


def test_button_press_success_and_success_reward() -> None:
    objs = [B_GOAL - [0, 0.0101, 0], B_GOAL - [0, 0.0099, 0], B_GOAL, B_GOAL + [0, 0.003, 0]]
    assert button_press_success(_pts(*objs), _pts(*[B_GOAL] * 4)).tolist() == [False, True, True, True]
    # success steps: 0.01 * dense + 16 * button_pressed while ||tcp - obj|| < 0.07
    dense, pressed = _t([2.0, 0.4, 0.4]), _t([1.0, 1.0, 0.5])
    got = _button.button_success_reward(dense, pressed, _t([0.0, 0.0699, 0.0701]), 0.01)
    _close(got, [0.02 + 16.0, 0.004 + 16.0, 0.004])


def test_button_press_wall_reward_known_answers() -> None:
    # near bound 0.01 and the margin from the *initial* button point (MTBench button_press_wall)
    obj = B_INIT + [0.0, 0.02, 0.0]
    tcp = obj + [0.0, -0.03, 0.0]
    d, pressed, t2o = button_press_wall_reward(_pts(tcp), _pts(obj), _pts(B_INIT), _pts(INIT_TCP), _pts(B_GOAL),
                                               _t([0.9]))
    margin = float(np.linalg.norm(B_INIT - INIT_TCP))
    _close(d, 2.0 * ham(0.9, long_tail(0.02 / margin)))
    _close(pressed, long_tail(0.035 / 0.06)), _close(t2o, 0.03)
    d, _, _ = button_press_wall_reward(_pts(obj + [0, 0, 0.01]), _pts(obj), _pts(B_INIT), _pts(INIT_TCP),
                                       _pts(B_GOAL), _t([1.0]))
    _close(d, 2.0)  # within 1 cm, closed
    objs = [B_GOAL - [0, 0.0101, 0], B_GOAL - [0, 0.0099, 0]]
    assert button_press_wall_success(_pts(*objs), _pts(B_GOAL, B_GOAL)).tolist() == [False, True]


def test_button_press_topdown_wall_reward_known_answers() -> None:
    top_init = BOX + [0.0, 0.0, 0.1935]
    goal = top_init - [0.0, 0.0, 0.06]
    # pressed 5.5 cm with the closed fingertips on it: near = 1, button_pressed = 1 (|dz| = 0.005)
    obj = top_init - [0.0, 0.0, 0.055]
    d, pressed, t2o = button_press_topdown_wall_reward(_pts(obj + [0, 0, 0.0094]), _pts(obj), _pts(top_init),
                                                       _pts(INIT_TCP), _pts(goal), _t([1.0]))
    _close(d, 2.0), _close(pressed, 1.0), _close(t2o, 0.0094)
    # far: margin from the initial button point and the TCP's start
    dist = float(np.linalg.norm(top_init - INIT_TCP))
    tcp = top_init + [0.1, -0.2, 0.1]
    d, pressed, _ = button_press_topdown_wall_reward(_pts(tcp), _pts(top_init), _pts(top_init), _pts(INIT_TCP),
                                                     _pts(goal), _t([0.3]))
    _close(d, 2.0 * ham(0.3, long_tail((math.sqrt(0.06) - 0.05) / dist)))
    _close(pressed, long_tail(0.055 / 0.06))
    objs = [goal + [0, 0, 0.0101], goal + [0, 0, 0.0099], goal - [0, 0, 0.005]]
    assert button_press_topdown_wall_success(_pts(*objs), _pts(goal, goal, goal)).tolist() == [False, True, True]


# ------------------------------------------------------------------------------------------------ coffee button
MACHINE = np.array([0.02, 0.82, 0.0])
C_INIT = MACHINE + [0.0, -0.22, 0.3]
C_GOAL = C_INIT + [0.0, 0.03, 0.0]


def test_coffee_button_reward_branches() -> None:
    pressed_obj = C_GOAL - [0.0, 0.004, 0.0]
    bp = 1.0  # 4 mm from the end of the travel: inside button_pressed's 5 mm bound
    near_tcp = pressed_obj + [0.0, -0.0145, 0.035]  # the scripted pose: 3.8 cm from the button point
    # pressing branch: ||tcp - obj|| <= 0.05 and closedness >= 0.95: 2 H(1, 1) + 8 * button_pressed
    r = coffee_button_reward(_pts(near_tcp), _pts(pressed_obj), _pts(INIT_TCP), _pts(C_GOAL), _t([1.0]))
    _close(r, 2.0 + 8.0 * bp)
    # closedness 0.94 < 0.95: no pressing term
    r = coffee_button_reward(_pts(near_tcp), _pts(pressed_obj), _pts(INIT_TCP), _pts(C_GOAL), _t([0.94]))
    _close(r, 2.0 * 0.94)
    # TCP 6 cm away: outside the 0.05 gate; near from the current button point's margin
    tcp = pressed_obj + [0.0, -0.06, 0.0]
    margin = float(np.linalg.norm(pressed_obj - INIT_TCP))
    r = coffee_button_reward(_pts(tcp), _pts(pressed_obj), _pts(INIT_TCP), _pts(C_GOAL), _t([1.0]))
    _close(r, 2.0 * long_tail(0.01 / margin))
    # unpressed, TCP at the button: button_pressed = long_tail((0.03 - 0.005) / 0.03)
    r = coffee_button_reward(_pts(C_INIT), _pts(C_INIT), _pts(INIT_TCP), _pts(C_GOAL), _t([1.0]))
    _close(r, 2.0 + 8.0 * long_tail(0.025 / 0.03))


def test_coffee_button_success_boundaries() -> None:
    obj = [C_GOAL - [0, 0.0101, 0], C_GOAL - [0, 0.0099, 0], C_GOAL, C_GOAL]
    tcp = [obj[0], obj[1], C_GOAL + [0, 0, 0.0499], C_GOAL + [0, 0, 0.0501]]
    assert coffee_button_success(_pts(*tcp), _pts(*obj), _pts(*[C_GOAL] * 4)).tolist() == [False, True, True, False]


def test_coffee_button_literal_tcp_rule_is_out_of_reach() -> None:
    """MTBench's ``||tcp - button|| < 0.02`` cannot hold while the button is pressed: the palm (hand box) must pass
    above the machine's highest geom in front of the button, which puts the TCP above the button point by more than
    2 cm (with 3.5 cm the distance stays inside the 0.05 radius used instead)."""
    from mtbench.envs.metaworld.models import compiled_task

    _, m = compiled_task("coffee_button")
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, 0)
    mujoco.mj_forward(m, d)
    machine = m.body("coffee_machine").id
    button_point = d.site("buttonStart").xpos.copy()
    top = max(d.geom_xpos[g][2] + m.geom_size[g][2] for g in range(m.ngeom)
              if m.geom_bodyid[g] == m.body("cm_link").id and m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX
              and m.geom_contype[g])
    assert top == pytest.approx(d.xpos[machine][2] + 0.37, abs=1e-6)
    ((pos, half, _),) = robot.HAND_BOXES.values()
    palm_above_tcp = robot.TCP_OFFSET - (pos[2] + half[2])  # hand z points down from the hand origin
    min_tcp_height = top - palm_above_tcp - button_point[2]
    assert min_tcp_height > 0.02
    # pressing with the closed fingertips (front face 1.45 cm ahead of the TCP) keeps the TCP inside the 0.05 used
    assert math.hypot(min_tcp_height, 0.0145) < TCP_RADIUS


# ------------------------------------------------------------------------------------------------ coffee pull/push
def _grasp_pose(obj: np.ndarray, half_gap: float = 0.03) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """TCP at ``obj`` with the pads ``half_gap`` either side along y."""
    return _pts(obj), _pts(obj + [0, half_gap, 0]), _pts(obj - [0, half_gap, 0])


@pytest.mark.parametrize("task, reward_fn, effort", [("coffee_pull", coffee_pull_reward, 0.7),
                                                      ("coffee_push", coffee_push_reward, 1.0)])
def test_mug_reward_known_answers(task: str, reward_fn, effort: float) -> None:
    goal = np.array([0.03, 0.56, 0.0])
    obj_init = np.array([-0.02, 0.68, 0.0])
    at_goal = goal + [0.0, 0.0, 0.035]  # the mug's centre resting on the goal: ||(0, 0, 0.035)|| < 0.05
    tcp, lp, rp = _grasp_pose(at_goal)
    # caged (pads 3 cm from the centre, inside [0.02, 0.05]; TCP at the centre) and held: caging = 1, gripping =
    # min(a, effort) / effort, medium density averages with reach = 1; in_place = 1 and the near bonus 1 + 5
    for grip in (1.0, 0.35):
        r = reward_fn(_t([[0, 0, 0, grip]]), _pts(at_goal), _pts(obj_init), _pts(goal), tcp, _pts(INIT_TCP), lp, rp)
        grasped = (ham(1.0, min(grip, effort) / effort) + 1.0) / 2.0
        _close(r, ham(grasped, 1.0) + 1.0 + 5.0)
    # far: the mug at its start, the hand at its start (no bonus); in_place from the (2, 2, 1)-scaled distances
    start = obj_init + [0.0, 0.0, 0.035]
    tcp, lp, rp = _grasp_pose(INIT_TCP, 0.05)
    action = _t([[0, 0, 0, -1.0]])
    r = reward_fn(action, _pts(start), _pts(obj_init), _pts(goal), tcp, _pts(INIT_TCP), lp, rp)
    d = math.sqrt((2 * 0.05) ** 2 + (2 * 0.12) ** 2 + 0.035**2)
    d0 = math.sqrt((2 * 0.05) ** 2 + (2 * 0.12) ** 2)
    in_place = long_tail((d - 0.05) / d0)
    grasped = gripper_caging_reward(action, _pts(start), 0.02, 0.05, 0.04, 0.05, left_pad=lp, right_pad=rp,
                                    tcp_center=tcp, obj_init_pos=_pts(obj_init), init_tcp=_pts(INIT_TCP),
                                    desired_gripper_effort=effort, medium_density=True)
    assert 0.0 < float(grasped) < 0.2
    _close(r, ham(float(grasped), in_place))
    np.testing.assert_allclose(float(scaled_norm(_pts(start - goal), (2.0, 2.0, 1.0))), d, rtol=1e-12)


@pytest.mark.parametrize("success_fn", [coffee_pull_success, coffee_push_success])
def test_mug_success_boundaries(success_fn) -> None:
    goal = np.array([0.0, 0.73, 0.0])
    xy = math.sqrt(0.05**2 - 0.035**2)  # the observed centre is 3.5 cm above the goal on the table
    objs = [goal + [xy - 1e-4, 0, 0.035], goal + [xy + 1e-4, 0, 0.035], goal + [0, 0, 0.035], goal + [0, 0, 0.035],
            goal + [0, 0, 0.035]]
    tcps = [objs[0], objs[1], objs[2] + [0, 0, 0.0399], objs[3] + [0, 0, 0.0401], objs[4]]
    half_gap = [0.03, 0.03, 0.03, 0.03, 0.0]  # last: pads together, openness 0 (MTBench: tcp_opened > 0)
    lp = _pts(*[t + np.array([0, h, 0]) for t, h in zip(tcps, half_gap)])
    rp = _pts(*[t - np.array([0, h, 0]) for t, h in zip(tcps, half_gap)])
    got = success_fn(_pts(*objs), _pts(*[goal] * 5), _pts(*tcps), lp, rp).tolist()
    assert got == [True, False, True, False, False]


# ------------------------------------------------------------------------------------------------ dial
DIAL = np.array([0.04, 0.75, 0.0])
DIAL_GOAL = DIAL + [0.0, -0.03, 0.03]


def _dial_tip(turn: float) -> np.ndarray:
    """The observed point after turning clockwise by ``turn`` from the start (joint at 3.14)."""
    q = 3.14 - turn
    return DIAL + 0.05 * np.array([math.sin(q), -math.cos(q), 0.0])


def test_dial_success_angle() -> None:
    start = dial_angle_for_success()
    assert start == pytest.approx(1.8063, abs=1e-4)  # cos(pi - turn) = (0.05² + 2 0.03² - 0.06²) / (2 0.03 0.05)
    turns = [0.0, start - 0.01, start + 0.01, math.pi, 2 * math.pi - start - 0.01, 2 * math.pi - start + 0.01]
    tips = _pts(*[_dial_tip(a - 0.0016) for a in turns])  # the joint starts 1.6 mrad short of pi
    assert dial_turn_success(tips, _pts(*[DIAL_GOAL] * 6)).tolist() == [False, False, True, True, True, False]


def test_dial_reward_known_answers() -> None:
    start = _dial_tip(0.0)
    turned = _dial_tip(2.4)
    push = turned + [0.05, 0.02, 0.09]
    # maximum: TCP at the push point, closed, the point within 6 cm of the goal: H(H(1, 1), 1) = 1
    _close(dial_turn_reward(_pts(push), _pts(turned), _pts(DIAL_GOAL), _pts(start), _pts(INIT_TCP), _t([1.0])), 1.0)
    # open gripper: the reach term is multiplied (Hamacher) by closedness 0 -> 0
    _close(dial_turn_reward(_pts(push), _pts(turned), _pts(DIAL_GOAL), _pts(start), _pts(INIT_TCP), _t([0.0])), 0.0)
    # the start state, TCP at its start, closedness 0.6: margins from MTBench's dial_push_position_init = the start
    # point without the push offset
    in_dist = float(np.linalg.norm(start - DIAL_GOAL))
    reach_dist = float(np.linalg.norm(start + [0.05, 0.02, 0.09] - INIT_TCP))
    reach_margin = abs(float(np.linalg.norm(start - INIT_TCP)) - 0.005)
    in_place = long_tail((in_dist - 0.06) / abs(in_dist - 0.06))
    reach = ham(gauss((reach_dist - 0.005) / reach_margin), 0.6)
    got = dial_turn_reward(_pts(INIT_TCP), _pts(start), _pts(DIAL_GOAL), _pts(start), _pts(INIT_TCP), _t([0.6]))
    _close(got, ham(reach, in_place))
    assert in_place == pytest.approx(0.1)  # at the start the in-place distance is exactly its margin away


# ------------------------------------------------------------------------------------------------ door close
SAFE = np.array([0.05, 1.0, 0.15])
HINGE = SAFE + [-0.185, -0.1, 0.0]
D_GOAL = SAFE + [0.15, -0.16, 0.0]


def _handle(theta: float) -> np.ndarray:
    c, s = math.cos(theta), math.sin(theta)
    return HINGE + [0.325 * c + 0.062 * s, 0.325 * s - 0.062 * c, 0.0]


def test_door_close_reward_known_answers() -> None:
    init_tcp = np.array([-0.5, 0.6, 0.2])
    open_handle = _handle(-1.5708)
    # closed, hand on the goal: 3 * 1 + 6 * 1
    _close(door_close_reward(_pts(D_GOAL), _pts(D_GOAL), _pts(open_handle), _pts(D_GOAL), _pts(init_tcp)), 9.0)
    # start: in_place has a zero margin (the handle has not moved) -> 0 outside its ball; hand term from the start
    x = float(np.linalg.norm(init_tcp - D_GOAL))
    margin = float(np.linalg.norm(init_tcp - open_handle))
    got = door_close_reward(_pts(init_tcp), _pts(open_handle), _pts(open_handle), _pts(D_GOAL), _pts(init_tcp))
    _close(got, 3.0 * gauss((x - 0.0125) / margin))
    # half closed, hand 5 cm from the goal
    half = _handle(-0.7)
    tcp = D_GOAL + [0.0, -0.05, 0.0]
    obj_to_goal = float(np.linalg.norm(half - D_GOAL))
    got = door_close_reward(_pts(tcp), _pts(half), _pts(open_handle), _pts(D_GOAL), _pts(init_tcp))
    expected = (3.0 * gauss((0.05 - 0.0125) / float(np.linalg.norm(init_tcp - half)))
                + 6.0 * gauss((obj_to_goal - 0.05) / float(np.linalg.norm(half - open_handle))))
    _close(got, expected)


def test_door_close_success_boundaries() -> None:
    objs = [D_GOAL + [0.0499, 0, 0], D_GOAL + [0.0501, 0, 0], _handle(0.0), _handle(-0.1), _handle(-0.2)]
    assert door_close_success(_pts(*objs), _pts(*[D_GOAL] * 5)).tolist() == [True, False, True, True, False]


# ------------------------------------------------------------------------------------------------ lock
L_SAFE = np.array([-0.03, 0.82, 0.15])
L_HINGE = L_SAFE + [0.0, -0.118, 0.061]


def _lever(theta: float, point: tuple[float, float, float]) -> np.ndarray:
    x, y, z = point
    c, s = math.cos(theta), math.sin(theta)
    return L_HINGE + [x * c + z * s, y, -x * s + z * c]


def test_door_lock_reward_and_success() -> None:
    goal = L_HINGE + [0.0, -0.04, -0.1]
    locked = _lever(1.57, (0.09, -0.04, 0.01))
    # fully locked with the open hand at the lever point: 2 H(1, 1) + 8 lock_pressed, where the lever point's lowest
    # position is 1 cm above MTBench's goal (hinge - 0.1): lock_pressed = long_tail((dz - 0.005) / 0.1), dz ~ 0.01
    dz = abs(goal[2] - locked[2])
    assert dz == pytest.approx(0.01, abs=1e-5)
    _close(door_lock_reward(_pts(locked), _pts(locked), _pts(INIT_TCP), _pts(goal), _t([1.0])),
           2.0 + 8.0 * long_tail((dz - 0.005) / 0.1))
    # the formula's maximum, a point at the goal's height: 10
    _close(door_lock_reward(_pts(goal), _pts(goal), _pts(INIT_TCP), _pts(goal), _t([1.0])), 10.0)
    # start: lever horizontal; near term scaled by (0.25, 1, 0.5) with the current point's margin
    start = _lever(0.0, (0.09, -0.04, 0.01))
    tcp = start + [0.04, -0.02, 0.06]
    near_d = math.sqrt((0.25 * 0.04) ** 2 + 0.02**2 + (0.5 * 0.06) ** 2)
    margin = float(np.linalg.norm((start - INIT_TCP) * [0.25, 1.0, 0.5]))
    got = door_lock_reward(_pts(tcp), _pts(start), _pts(INIT_TCP), _pts(goal), _t([0.7]))
    _close(got, 2.0 * ham(0.7, long_tail((near_d - 0.01) / margin)) + 8.0 * long_tail((0.11 - 0.005) / 0.1))
    # success: |goal_z - obj_z| <= 0.02, i.e. the lever turned down by more than about 1.195 rad
    objs = [_lever(a, (0.09, -0.04, 0.01)) for a in (0.0, 1.19, 1.2, 1.57)]
    assert door_lock_success(_pts(*objs), _pts(*[goal] * 4)).tolist() == [False, False, True, True]
    assert door_lock_success(_pts(goal + [0, 0, 0.0199], goal - [0, 0, 0.0201]), _pts(goal, goal)).tolist() == [
        True, False]


def test_door_unlock_reward_and_success() -> None:
    goal = L_HINGE + [0.1, -0.04, 0.0]
    unlocked = _lever(0.0, (0.09, -0.04, -0.01))
    # unlocked (|dx| = 1 cm) with the TCP at the lever point: 2 * 1 + 8 * long_tail((0.01 - 0.005) / 0.1)
    got = door_unlock_reward(_pts(unlocked), _pts(unlocked), _pts(INIT_TCP), _pts(L_HINGE), _pts(goal))
    _close(got, 2.0 + 8.0 * long_tail(0.05))
    # start: hanging lever, TCP at its start; ready margin from the hinge (MTBench's obj_init_pos)
    start = _lever(1.57, (0.09, -0.04, -0.01))
    x = float(np.linalg.norm(INIT_TCP - start))
    margin = float(np.linalg.norm(INIT_TCP - L_HINGE))
    got = door_unlock_reward(_pts(INIT_TCP), _pts(start), _pts(INIT_TCP), _pts(L_HINGE), _pts(goal))
    _close(got, 2.0 * long_tail((x - 0.02) / margin) + 8.0 * long_tail((abs(goal[0] - start[0]) - 0.005) / 0.1))
    objs = [_lever(a, (0.09, -0.04, -0.01)) for a in (1.57, 0.39, 0.36, 0.0)]
    assert door_unlock_success(_pts(*objs), _pts(*[goal] * 4)).tolist() == [False, False, True, True]


def test_reward_functions_make_no_host_copies() -> None:
    """The pure functions run on the meta device (no data, so no host sync or host-to-device copy is possible)."""
    p = torch.zeros(4, 3, device="meta")
    s = torch.zeros(4, device="meta")
    a = torch.zeros(4, 4, device="meta")
    outs = [button_press_reward(p, p, p, p, s)[0], button_press_wall_reward(p, p, p, p, p, s)[0],
            button_press_topdown_wall_reward(p, p, p, p, p, s)[0], coffee_button_reward(p, p, p, p, s),
            coffee_pull_reward(a, p, p, p, p, p, p, p), coffee_push_reward(a, p, p, p, p, p, p, p),
            dial_turn_reward(p, p, p, p, p, s), door_close_reward(p, p, p, p, p), door_lock_reward(p, p, p, p, s),
            door_unlock_reward(p, p, p, p, p), coffee_pull_success(p, p, p, p, p), coffee_button_success(p, p, p),
            _button.button_success_reward(s, s, s, 0.01), mtbench_gripper_openness(p, p)]
    assert all(o.shape == (4,) and o.device.type == "meta" for o in outs)


# ------------------------------------------------------------------------------------------------ scene facts
def _model(task: str) -> mujoco.MjModel:
    """A copy of the task's compiled model (the tests move bodies; the cached model is shared with the envs)."""
    from mtbench.envs.metaworld.models import compiled_task

    return copy.deepcopy(compiled_task(task)[1])


def _data(m: mujoco.MjModel, bodies: dict[str, np.ndarray], joints: dict[str, float]) -> mujoco.MjData:
    """The home keyframe with world-fixed bodies moved and joints set, kinematics done."""
    for name, pos in bodies.items():
        m.body_pos[m.body(name).id] = pos
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, 0)
    for name, q in joints.items():
        d.qpos[m.joint(name).qposadr[0]] = q
    mujoco.mj_forward(m, d)
    return d


@pytest.mark.parametrize("task, joint, lo, hi", [
    ("button_press", "btnbox_joint", -0.06, 0.0), ("button_press_topdown_wall", "btnbox_joint", -0.06, 0.0),
    ("coffee_button", "goal_slidey", 0.0, 0.03), ("dial_turn", "knob_Joint_1", -3.14, 3.14),
    ("door_close", "doorjoint", -2.0, 0.0), ("door_lock", "lock_joint", 0.0, 1.57),
])
def test_joint_ranges(task: str, joint: str, lo: float, hi: float) -> None:
    np.testing.assert_allclose(_model(task).joint(joint).range, [lo, hi])


def test_button_points_and_goals_match_the_models() -> None:
    m = _model("button_press")
    box = BOX.copy()
    d = _data(m, {"box": box}, {"btnbox_joint": 0.0})
    np.testing.assert_allclose(d.site("button_start").xpos, box + [0, -0.1935, 0], atol=1e-9)
    d = _data(m, {"box": box}, {"btnbox_joint": -0.06})  # the end of the travel is MTBench's target
    np.testing.assert_allclose(d.site("button_start").xpos, box + [0, -0.1935 + 0.06, 0], atol=1e-9)
    m = _model("button_press_topdown_wall")
    d = _data(m, {"box": box}, {"btnbox_joint": 0.0})
    np.testing.assert_allclose(d.site("button_start").xpos, box + [0, 0, 0.1935], atol=2e-4)  # euler -1.57, not pi/2
    d = _data(m, {"box": box}, {"btnbox_joint": -0.06})
    np.testing.assert_allclose(d.site("button_start").xpos, box + [0, 0, 0.1335], atol=2e-4)


def test_coffee_points_match_the_model() -> None:
    m = _model("coffee_pull")
    machine, mug = np.array([0.05, 0.95, 0.0]), np.array([0.05, 0.65, 0.0])
    d = _data(m, {"coffee_machine": machine}, {"goal_slidey": 0.0})
    np.testing.assert_allclose(d.site("buttonStart").xpos, machine + _coffee.BUTTON_FROM_MACHINE, atol=1e-9)
    d = _data(m, {"coffee_machine": machine}, {"goal_slidey": 0.03})
    np.testing.assert_allclose(d.site("buttonStart").xpos, machine + [0, -0.19, 0.3], atol=1e-9)
    adr = m.joint(_coffee.MUG_JOINT).qposadr[0]
    d.qpos[adr:adr + 7] = [*mug, 0, 0, 0, 1]
    mujoco.mj_forward(m, d)
    np.testing.assert_allclose(d.site(_coffee.MUG_SITE).xpos, mug + [0, 0, 0.035], atol=1e-9)
    # the mug's collision cylinder is centred there; the handle points to -x (MTBench's spawn orientation)
    cyl = [g for g in range(m.ngeom) if m.geom_bodyid[g] == m.body("mug").id
           and m.geom_type[g] == mujoco.mjtGeom.mjGEOM_CYLINDER and m.geom_contype[g]]
    centre = min(cyl, key=lambda g: np.linalg.norm(d.geom_xpos[g] - d.site(_coffee.MUG_SITE).xpos))
    handle = max(cyl, key=lambda g: np.linalg.norm(d.geom_xpos[g] - d.site(_coffee.MUG_SITE).xpos))
    np.testing.assert_allclose(d.geom_xpos[centre], mug + [0, 0, 0.035], atol=1e-9)
    assert d.geom_xpos[handle][0] < mug[0] - 0.03


def test_dial_point_matches_the_model() -> None:
    m = _model("dial_turn")
    for q in (3.14, 1.0, -2.0):
        d = _data(m, {"dial": DIAL}, {"knob_Joint_1": q})
        np.testing.assert_allclose(d.site("dial_tip").xpos, DIAL + 0.05 * np.array([math.sin(q), -math.cos(q), 0]),
                                   atol=1e-9)


def test_door_handle_point_matches_the_model_and_mtbench_offsets() -> None:
    m = _model("door_close")
    d = _data(m, {"door": SAFE}, {"doorjoint": 0.0})
    np.testing.assert_allclose(d.site("handle_point").xpos, _handle(0.0), atol=1e-9)
    assert np.linalg.norm(d.site("handle_point").xpos - D_GOAL) < 0.011  # MTBench's goal is at the closed handle
    d = _data(m, {"door": SAFE}, {"doorjoint": -1.5708})
    np.testing.assert_allclose(d.site("handle_point").xpos, SAFE + [-0.25, -0.425, 0.0], atol=4e-3)  # MTBench's init


def test_lock_points_match_the_model() -> None:
    m = _model("door_unlock")
    for q in (0.0, 0.8, 1.57):
        d = _data(m, {"door": L_SAFE}, {"lock_joint": q})
        np.testing.assert_allclose(d.body("lock_link").xpos, L_SAFE + _lock.LOCK_FROM_SAFE, atol=1e-9)
        np.testing.assert_allclose(d.site("lockStartLock").xpos, _lever(q, (0.09, -0.04, 0.01)), atol=1e-9)
        np.testing.assert_allclose(d.site("lockStartUnlock").xpos, _lever(q, (0.09, -0.04, -0.01)), atol=1e-9)


# every task's world-fixed placement as its reset does it (corners of the reset ranges) and the joint's start
def _placements(task: str, corner: np.ndarray) -> tuple[dict[str, np.ndarray], dict[str, float]]:
    if task.startswith("button"):
        bodies = {"box": corner}
        cls = TASKS[task]
        if cls.WALL_OFFSET is not None:
            bodies["wall"] = np.array([corner[0] + cls.WALL_OFFSET[0], corner[1] + cls.WALL_OFFSET[1], 0.0])
        return bodies, {"btnbox_joint": 0.0}
    if task == "coffee_button":
        return {"coffee_machine": corner}, {"goal_slidey": 0.0}
    if task.startswith("coffee"):
        return {"coffee_machine": corner + [0.0, _coffee.MACHINE_BEHIND_MUG, 0.0]}, {"goal_slidey": 0.0}
    if task == "dial_turn":
        return {"dial": corner}, {"knob_Joint_1": 3.14}
    if task == "door_close":
        return {"door": corner}, {"doorjoint": -1.5708}
    return {"door": corner}, {"lock_joint": 0.0 if task == "door_lock" else 1.57}


@pytest.mark.parametrize("task", sorted(GROUP_A))
def test_start_poses_are_collision_free_over_the_reset_range(task: str) -> None:
    """At every corner of the reset range the robot's start pose touches nothing (the mug of the coffee tasks is
    placed at its own spawn point, checked for the table only)."""
    m = _model(task)
    cls = TASKS[task]
    lo, hi = np.array(cls.reset_low[:3]), np.array(cls.reset_high[:3])
    robot_bodies = {b for b in range(m.nbody) if m.body(b).name.startswith(robot.PREFIX)}
    for corner in {tuple(c) for c in itertools.product(*zip(lo, hi))}:
        bodies, joints = _placements(task, np.array(corner))
        d = _data(m, bodies, joints)
        if task.startswith("coffee"):
            mug = np.array(corner) + ([0, -0.37, 0] if task == "coffee_button" else 0.0)
            adr = m.joint(_coffee.MUG_JOINT).qposadr[0]
            d.qpos[adr:adr + 7] = [*mug, 0, 0, 0, 1]
            mujoco.mj_forward(m, d)
        touching = [(m.body(m.geom_bodyid[c.geom1]).name, m.body(m.geom_bodyid[c.geom2]).name)
                    for c in d.contact[: d.ncon]
                    if {int(m.geom_bodyid[c.geom1]), int(m.geom_bodyid[c.geom2])} & robot_bodies]
        assert not touching, (task, corner, touching)


@pytest.mark.parametrize("task, part, joint, frame", [
    ("button_press", "button", "btnbox_joint", ("buttonbox", "RetainingWall")),
    ("coffee_button", "cmbutton", "goal_slidey", ("cm_link",)),
    ("door_close", "door_link", "doorjoint", ("doorlockB", "RetainingWall")),
    ("door_lock", "lock_link", "lock_joint", ("door_link", "doorlockA")),
])
def test_fixture_parts_are_guided_by_their_joint_alone(task: str, part: str, joint: str, frame: tuple) -> None:
    """Shoved towards either end of its travel, the part touches none of its frame bodies and stops within 1 mm of
    its joint range (``guide_by_joint``)."""
    from mtbench.envs.metaworld.scene import STIFF_LIMIT_SOLREF

    m = _model(task)
    j = m.joint(joint)
    np.testing.assert_allclose(j.solref, STIFF_LIMIT_SOLREF)
    part_id, frame_ids = m.body(part).id, {m.body(b).id for b in frame}
    lo, hi = m.jnt_range[j.id]
    for push, end in ((-20.0, lo), (20.0, hi)):
        d = mujoco.MjData(m)
        mujoco.mj_resetDataKeyframe(m, d, 0)
        d.qpos[j.qposadr[0]] = 0.5 * (lo + hi)
        for _ in range(int(0.6 / m.opt.timestep)):
            d.qfrc_applied[j.dofadr[0]] = push
            mujoco.mj_step(m, d)
            for c in d.contact[: d.ncon]:
                pair = {int(m.geom_bodyid[c.geom1]), int(m.geom_bodyid[c.geom2])}
                assert not (part_id in pair and pair & frame_ids), f"{part} touches its frame"
        if task == "door_close" and push < 0:  # the door swings open into the arm before reaching -2 rad
            continue
        assert abs(float(d.qpos[j.qposadr[0]]) - end) < 1e-3, (task, push)
