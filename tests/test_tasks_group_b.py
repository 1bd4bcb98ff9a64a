"""Group b Meta-World tasks (MTBench ids 19-27, 29): faucet_close, faucet_open, hammer, hand_insert,
handle_press_side, handle_press, handle_pull_side, handle_pull, lever_pull, peg_unplug_side.

* Reward parity: every task's reward and success functions are evaluated on hand-built states (tensors, no physics)
  and compared with values computed here, independently, from the paper-era MTBench formulas
  (``isaacgymenvs/tasks/franka/vec_task/task_fns/<task>.py`` at ed2e2b5, mapped to our frame), written out with
  plain-Python scalar versions of the long-tail / gaussian tolerances, the Hamacher product and MTBench's caging
  reward: the maxima at the goal, far states, each conditional branch and both sides of each success threshold.
* Scene facts in MuJoCo C: joint ranges, site offsets the rewards and resets rely on, the scene edits.
* Scripted success: the scripted policies solve every task but peg_unplug_side in >= 80% of randomized episodes
  (peg_unplug_side's MTBench layout cannot be solved by a parallel gripper: see its task file).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
import torch

from mtbench.assets import metaworld_assets_dir
from mtbench.envs.metaworld import TASKS
from mtbench.envs.metaworld.models import compiled_task
from mtbench.envs.metaworld.scene import build_scene
from mtbench.envs.metaworld.tasks import _faucet, _handle_press
from mtbench.envs.metaworld.tasks import hammer as hammer_task
from mtbench.envs.metaworld.tasks import lever_pull as lever_task
from mtbench.envs.metaworld.tasks import peg_unplug_side as plug_task
from mtbench.envs.metaworld.tasks.faucet_close import faucet_close_reward, faucet_close_success
from mtbench.envs.metaworld.tasks.faucet_open import faucet_open_reward, faucet_open_success
from mtbench.envs.metaworld.tasks.hammer import hammer_reward, hammer_success
from mtbench.envs.metaworld.tasks.hand_insert import hand_insert_reward, hand_insert_success
from mtbench.envs.metaworld.tasks.handle_press import handle_press_reward, handle_press_success
from mtbench.envs.metaworld.tasks.handle_pull import handle_pull_reward, handle_pull_success
from mtbench.envs.metaworld.tasks.handle_pull_side import handle_pull_side_reward, handle_pull_side_success
from mtbench.envs.metaworld.tasks.lever_pull import lever_pull_reward, lever_pull_success
from mtbench.envs.metaworld.tasks.peg_unplug_side import peg_unplug_side_reward, peg_unplug_side_success

GROUP_B = {"faucet_close": 19, "faucet_open": 20, "hammer": 21, "hand_insert": 22, "handle_press_side": 23,
           "handle_press": 24, "handle_pull_side": 25, "handle_pull": 26, "lever_pull": 27, "peg_unplug_side": 29}
T = torch.float64
INIT_TCP = np.array([0.0, 0.6, 0.2])


# ------------------------------------------------------------------------------------------------------------------
# independent scalar reference of the MTBench formulas (plain Python)
# ------------------------------------------------------------------------------------------------------------------
def _dist(a, b) -> float:
    return float(np.linalg.norm(np.asarray(a, dtype=float) - np.asarray(b, dtype=float)))


def long_tail(x: float, lo: float, hi: float, margin: float) -> float:
    """1 inside [lo, hi]; outside 1 / (1 + (3 d)^2) with d = distance / margin (0.1 at d = 1); binary if margin <= 0."""
    if lo <= x <= hi:
        return 1.0
    if margin <= 0:
        return 0.0
    d = ((lo - x) if x < lo else (x - hi)) / margin
    return 1.0 / (1.0 + 9.0 * d * d)


def gaussian(x: float, lo: float, hi: float, margin: float) -> float:
    """1 inside [lo, hi]; outside 0.1 ** (d^2) (exp(-d^2 ln 10 ... ) with value 0.1 at d = 1)."""
    if lo <= x <= hi:
        return 1.0
    if margin <= 0:
        return 0.0
    d = ((lo - x) if x < lo else (x - hi)) / margin
    return 0.1 ** (d * d)


def ham(a: float, b: float) -> float:
    den = a + b - a * b
    return 0.0 if den <= 0 else a * b / den


def caging(grip: float, obj, obj_init, tcp, tcp_init, left, right, *, obj_radius: float, pad: float,
           reach_radius: float, xz: float) -> float:
    """MTBench's ``_gripper_caging_reward`` (medium density) with its pad axis (its x) as our y."""
    obj, obj_init, tcp, tcp_init = (np.asarray(v, dtype=float) for v in (obj, obj_init, tcp, tcp_init))
    lr = [long_tail(abs(p[1] - obj[1]), obj_radius, pad, abs(abs(p[1] - obj_init[1]) - pad)) for p in (left, right)]
    caging_y = ham(lr[0], lr[1])
    xz_margin = _dist(obj_init[[0, 2]], tcp_init[[0, 2]]) - xz
    caging_xz = long_tail(_dist(tcp[[0, 2]], obj[[0, 2]]), 0.0, xz, xz_margin)
    closed = min(max(grip, 0.0), 1.0)
    cage = ham(caging_y, caging_xz)
    cg = ham(cage, closed if cage > 0.97 else 0.0)
    reach = long_tail(_dist(obj, tcp), 0.0, reach_radius, abs(_dist(obj_init, tcp_init) - reach_radius))
    return (cg + reach) / 2.0


def _t(*rows) -> torch.Tensor:
    return torch.as_tensor(np.asarray(rows, dtype=float), dtype=T)


def _one(x) -> float:
    return float(x.reshape(-1)[0])


def _pads(tcp, half_gap: float):
    tcp = np.asarray(tcp, dtype=float)
    return tcp + [0.0, half_gap, 0.0], tcp - [0.0, half_gap, 0.0]


def _action(grip: float) -> torch.Tensor:
    return _t([0.0, 0.0, 0.0, grip])


# ------------------------------------------------------------------------------------------------------------------
# registry
# ------------------------------------------------------------------------------------------------------------------
def test_group_b_tasks_are_registered_with_mtbench_ids_and_descriptions() -> None:
    for name, tid in GROUP_B.items():
        cls = TASKS[name]
        assert cls.name == name and cls.mtbench_id == tid
        assert cls.description.endswith(".") and len(cls.description.split()) >= 5
    assert TASKS["faucet_open"].dense_scale == 0.02 and TASKS["faucet_close"].dense_scale == 0.01
    assert TASKS["hammer"].success_bonus == 20.0
    assert all(TASKS[n].success_bonus == 10.0 for n in GROUP_B if n != "hammer")


# ------------------------------------------------------------------------------------------------------------------
# handle_press / handle_press_side
# ------------------------------------------------------------------------------------------------------------------
HOUSING = np.array([0.05, 0.85, 0.0])
PRESS_START = HOUSING + [0.0, -0.216, 0.172]  # handleStart at slide 0 = goalPull
PRESS_GOAL = HOUSING + [0.0, -0.216, 0.075]  # goalPress


def _press_ref(tcp, handle, goal, handle_init, init_tcp) -> float:
    in_place = long_tail(_dist(handle, goal), 0.0, 0.02, abs(_dist(goal, handle_init) - 0.02))
    reach = long_tail(_dist(handle, tcp), 0.0, 0.02, abs(_dist(handle, init_tcp) - 0.02))
    return ham(reach, in_place)


def test_handle_press_reward_known_answers() -> None:
    goal, start = _t(PRESS_GOAL), _t(PRESS_START)
    # maximum: handle pressed onto the goal, TCP on it
    assert _one(handle_press_reward(goal, goal, goal, start, _t(INIT_TCP))) == pytest.approx(1.0)
    # start: both terms exactly at their margins (0.1): hamacher(0.1, 0.1) = 0.01 / 0.19
    r = _one(handle_press_reward(_t(INIT_TCP), start, goal, start, _t(INIT_TCP)))
    assert r == pytest.approx(0.01 / 0.19)
    # half way down with the TCP on the handle: reach = 1, in_place from the formula
    half = PRESS_START + [0, 0, -0.05]
    expected = long_tail(0.047, 0.0, 0.02, 0.097 - 0.02)
    assert _one(handle_press_reward(_t(half), _t(half), goal, start, _t(INIT_TCP))) == pytest.approx(expected)
    # random states against the scalar reference (front and side housings)
    rng = np.random.default_rng(0)
    for side in (False, True):
        h_start = HOUSING + ([0.216, 0.0, 0.172] if side else [0.0, -0.216, 0.172])
        h_goal = h_start + [0.0, 0.0, -0.097]
        for _ in range(10):
            handle = h_start + [0.0, 0.0, -rng.uniform(0.0, 0.1)]
            tcp = handle + rng.normal(0.0, 0.05, 3)
            got = _one(handle_press_reward(_t(tcp), _t(handle), _t(h_goal), _t(h_start), _t(INIT_TCP)))
            assert got == pytest.approx(_press_ref(tcp, handle, h_goal, h_start, INIT_TCP), abs=1e-12)


def test_handle_press_success_threshold() -> None:
    goal = _t(PRESS_GOAL)
    heights = [0.0, 0.0199, 0.0201, 0.05]
    handles = _t(*[PRESS_GOAL + [0, 0, dz] for dz in heights])
    assert handle_press_success(handles, goal.expand(4, 3)).tolist() == [True, True, False, False]


# ------------------------------------------------------------------------------------------------------------------
# handle_pull / handle_pull_side
# ------------------------------------------------------------------------------------------------------------------
PULL_INIT = HOUSING + [0.0, -0.216, 0.072]  # handleStart pressed down (slide -0.1)
PULL_GOAL = HOUSING + [0.0, -0.216, 0.172]  # goalPull


def _pull_ref(grip, handle, goal, handle_init, tcp, left, right, init_tcp, opening, *, side: bool) -> float:
    in_place = long_tail(_dist(goal, handle), 0.0, 0.005, _dist(goal, handle_init))
    grasp = caging(grip, handle, handle_init, tcp, init_tcp, left, right,
                   obj_radius=0.032 if side else 0.022, pad=0.06 if side else 0.05, reach_radius=0.01, xz=0.01)
    r = ham(grasp, in_place)
    if side:
        lifted = handle[2] - 0.01 > handle_init[2]
    else:  # MTBench reads obj_pos[:, 0] (x_mtb = y - 0.6) against obj_init_pos[:, 2] (z_mtb = z + 1.027)
        lifted = (handle[1] - 0.6) - 0.01 > handle_init[2] + 1.027
    if _dist(handle, tcp) < 0.035 and opening > 0 and lifted:
        r += 1.0 + 5.0 * in_place
    return r


@pytest.mark.parametrize("side", [False, True])
def test_handle_pull_rewards_match_the_formula(side: bool) -> None:
    fn = handle_pull_side_reward if side else handle_pull_reward
    rng = np.random.default_rng(1 + side)
    for _ in range(20):
        lift = rng.uniform(0.0, 0.1)
        handle = PULL_INIT + [0.0, 0.0, lift]
        tcp = handle + rng.normal(0.0, 0.01, 3)
        left, right = _pads(tcp, rng.uniform(0.015, 0.05))
        grip, opening = rng.uniform(-1, 1), rng.uniform(-0.1, 1.0)
        got = _one(fn(_action(grip), _t(handle), _t(PULL_GOAL), _t(PULL_INIT), _t(tcp), _t(left), _t(right),
                      _t(INIT_TCP), _t(opening)))
        want = _pull_ref(grip, handle, PULL_GOAL, PULL_INIT, tcp, left, right, INIT_TCP, opening, side=side)
        assert got == pytest.approx(want, abs=1e-12)


def test_handle_pull_branches() -> None:
    goal, init = _t(PULL_GOAL), _t(PULL_INIT)
    # handle at the top, TCP on it, pads at the grip's radius (2.2 cm), fingers closing: caging = 1 -> grasp = 1
    left, right = _pads(PULL_GOAL, 0.022)
    args = (goal, goal, init, goal, _t(left), _t(right), _t(INIT_TCP), _t(0.5))
    top = _one(handle_pull_reward(_action(1.0), *args))
    assert top == pytest.approx(1.0)  # hamacher(1, 1): the paper-era bonus never fires on the front handle
    # the front task's lift test is MTBench's literal x-vs-z comparison: only a handle more than 1.637 m further
    # forward than its initial height would pass it; then the bonus 1 + 5 in_place is paid
    far = PULL_GOAL + [0.0, 2.0, 0.0]
    lf, rt = _pads(far, 0.022)
    r = _one(handle_pull_reward(_action(1.0), _t(far), _t(far), init, _t(far), _t(lf), _t(rt), _t(INIT_TCP),
                                _t(0.5)))
    assert r == pytest.approx(1.0 + 1.0 + 5.0)
    # side task: lifted + near + open -> bonus; each condition false -> no bonus
    side = _one(handle_pull_side_reward(_action(1.0), *args))
    grasp = caging(1.0, PULL_GOAL, PULL_INIT, PULL_GOAL, INIT_TCP, left, right, obj_radius=0.032, pad=0.06,
                   reach_radius=0.01, xz=0.01)
    assert side == pytest.approx(grasp + 1.0 + 5.0)
    closed = _one(handle_pull_side_reward(_action(1.0), *args[:-1], _t(0.0)))
    assert closed == pytest.approx(grasp)
    away = PULL_GOAL + [0.0, 0.0, 0.036]
    no_reach = _one(handle_pull_side_reward(_action(1.0), goal, goal, init, _t(away), _t(left), _t(right),
                                            _t(INIT_TCP), _t(0.5)))
    assert no_reach < 1.0
    low = PULL_INIT + [0.0, 0.0, 0.0099]
    not_lifted = _one(handle_pull_side_reward(_action(1.0), _t(low), goal, init, _t(low), _t(left), _t(right),
                                              _t(INIT_TCP), _t(0.5)))
    assert not_lifted < 1.0


def test_handle_pull_success_threshold() -> None:
    handles = _t(*[PULL_GOAL + [0, 0, -dz] for dz in (0.0, 0.0049, 0.0051, 0.05)])
    goal = _t(PULL_GOAL).expand(4, 3)
    assert handle_pull_success(handles, goal).tolist() == [True, True, False, False]
    assert handle_pull_side_success(handles, goal).tolist() == [True, True, False, False]


# ------------------------------------------------------------------------------------------------------------------
# faucet_close / faucet_open
# ------------------------------------------------------------------------------------------------------------------
FAUCET = np.array([0.02, 0.82, 0.0])


def _faucet_site(angle: float, side: float) -> np.ndarray:
    """Handle site (side +0.015: handleStartClose, -0.015: handleStartOpen) at hinge ``angle``."""
    c, s = math.cos(angle), math.sin(angle)
    x, y = side, -0.175
    return FAUCET + [c * x - s * y, s * x + c * y, 0.124]


def test_faucet_close_reward_and_success() -> None:
    goal = FAUCET + [-0.175, 0.0, 0.125]
    init_tcp = np.array([0.0, 0.4, 0.2])
    # maximum: handle site on the goal and TCP on the site: 2 + 3
    assert _one(faucet_close_reward(_t(goal), _t(goal), _t(goal), _t(FAUCET), _t(init_tcp))) == pytest.approx(5.0)
    rng = np.random.default_rng(3)
    for _ in range(20):
        handle = _faucet_site(rng.uniform(-1.57, 0.0), 0.015)
        tcp = handle + rng.normal(0.0, 0.04, 3)
        in_place = long_tail(_dist(handle, goal), 0.0, 0.02, abs(_dist(goal, FAUCET) - 0.02))
        reach = gaussian(_dist(handle, tcp), 0.0, 0.01, abs(_dist(handle, init_tcp) - 0.01))
        got = _one(faucet_close_reward(_t(tcp), _t(handle), _t(goal), _t(FAUCET), _t(init_tcp)))
        assert got == pytest.approx(2 * reach + 3 * in_place, abs=1e-12)
    # success: handle within 2 cm of the goal *and* TCP within 7 cm of it
    near = goal + [0.0, -0.0199, 0.0]
    cases = [(near, goal + [0.069, 0, 0]), (goal + [0, -0.0201, 0], goal), (near, goal + [0.071, 0, 0])]
    got = [bool(faucet_close_success(_t(tcp), _t(h), _t(goal))) for h, tcp in cases]
    assert got == [True, False, False]
    # the handle turned to -1.543 rad is within 2 cm of the goal, -1.53 rad is not; the limit (-1.57) is at 1.5 cm
    assert _dist(_faucet_site(-1.544, 0.015), goal) <= 0.02 < _dist(_faucet_site(-1.53, 0.015), goal)
    assert _dist(_faucet_site(-1.57, 0.015), goal) == pytest.approx(0.0152, abs=2e-4)


def test_faucet_open_reward_and_success() -> None:
    goal = FAUCET + [0.175, 0.0, 0.125]
    shift = np.array([-0.04, 0.0, 0.03])
    init_tcp = np.array([0.0, 0.4, 0.2])
    at_goal = goal - shift  # observed handle site whose shifted point is the goal
    r = faucet_open_reward(_t(goal), _t(at_goal), _t(goal), _t(FAUCET), _t(init_tcp))
    assert _one(r) == pytest.approx(5.0)
    rng = np.random.default_rng(4)
    for _ in range(20):
        handle = _faucet_site(rng.uniform(0.0, 1.57), -0.015)
        obj = handle + shift
        tcp = obj + rng.normal(0.0, 0.04, 3)
        in_place = long_tail(_dist(obj, goal), 0.0, 0.07, abs(_dist(goal, FAUCET) - 0.07))
        reach = gaussian(_dist(obj, tcp), 0.0, 0.01, abs(_dist(obj, init_tcp) - 0.01))
        got = _one(faucet_open_reward(_t(tcp), _t(handle), _t(goal), _t(FAUCET), _t(init_tcp)))
        assert got == pytest.approx(2 * reach + 3 * in_place, abs=1e-12)
    assert bool(faucet_open_success(_t(at_goal + [0, 0.0699, 0]), _t(goal)))
    assert not bool(faucet_open_success(_t(at_goal + [0, 0.0701, 0]), _t(goal)))
    # in hinge angles: open within 10 degrees of the +1.57 limit
    assert bool(faucet_open_success(_t(_faucet_site(1.40, -0.015)), _t(goal)))
    assert not bool(faucet_open_success(_t(_faucet_site(1.39, -0.015)), _t(goal)))


# ------------------------------------------------------------------------------------------------------------------
# lever_pull
# ------------------------------------------------------------------------------------------------------------------
def test_lever_pull_reward_and_success() -> None:
    base = np.array([0.03, 0.75, 0.0])
    hinge = base + [0.12, 0.0, 0.25]
    goal = base + [0.12, 0.0, 0.45]
    lever_init = hinge + [0.0, -0.2, 0.0]
    init_tcp = np.array([0.0, 0.4, 0.2])
    scale = np.array([4.0, 1.0, 4.0])
    # maximum: lever upright, TCP 7 cm below the ball
    assert _one(lever_pull_reward(_t(goal - [0, 0, 0.07]), _t(goal), _t(goal), _t(lever_init), _t(init_tcp))) \
        == pytest.approx(1.0)
    # start: MTBench's margins are the full initial distances (not minus the radius)
    r = lever_pull_reward(_t(init_tcp), _t(lever_init), _t(goal), _t(lever_init), _t(init_tcp))
    s0 = float(np.linalg.norm((init_tcp + [0, 0, 0.07] - lever_init) * scale))
    d0 = _dist(lever_init, goal)
    assert d0 == pytest.approx(0.2 * math.sqrt(2))
    assert _one(r) == pytest.approx(ham(1 / (1 + 9 * ((s0 - 0.02) / s0) ** 2), 1 / (1 + 9 * ((d0 - 0.04) / d0) ** 2)))
    rng = np.random.default_rng(5)
    for _ in range(20):
        phi = rng.uniform(0.0, math.pi / 2)
        lever = hinge + 0.2 * np.array([0.0, -math.cos(phi), math.sin(phi)])
        tcp = lever - [0, 0, 0.07] + rng.normal(0.0, 0.05, 3)
        ready = long_tail(float(np.linalg.norm((tcp + [0, 0, 0.07] - lever) * scale)), 0.0, 0.02,
                          float(np.linalg.norm((init_tcp + [0, 0, 0.07] - lever_init) * scale)))
        in_place = long_tail(_dist(lever, goal), 0.0, 0.04, _dist(lever_init, goal))
        got = _one(lever_pull_reward(_t(tcp), _t(lever), _t(goal), _t(lever_init), _t(init_tcp)))
        assert got == pytest.approx(ham(ready, in_place), abs=1e-12)
    tol = math.pi / 24
    angles = _t(-math.pi / 2, -math.pi / 2 + tol - 1e-6, -math.pi / 2 + tol + 1e-6, 0.0)
    assert lever_pull_success(angles).tolist() == [True, True, False, False]


# ------------------------------------------------------------------------------------------------------------------
# hammer
# ------------------------------------------------------------------------------------------------------------------
HAMMER_GOAL = np.array([0.24, 0.74, 0.11])


def _hammer_ref(grip, hammer, goal, hammer_init, tcp, left, right, init_tcp) -> float:
    head = hammer + [0.16, 0.07, 0.0]
    threshed = hammer.copy()
    if abs(hammer[0] - tcp[0]) < 0.07:
        threshed[0] = tcp[0]
    grab = caging(grip, threshed, hammer_init, tcp, init_tcp, left, right, obj_radius=0.015, pad=0.02,
                  reach_radius=0.01, xz=0.01)
    in_place = 0.1 * (head[2] > 0.04) + 0.9 * long_tail(_dist(goal, head), 0.0, 0.02, 0.2)
    return 2 * grab + 6 * in_place


def test_hammer_reward_and_success() -> None:
    init = np.array([0.0, 0.45, 0.05])
    init_tcp = np.array([0.0, 0.4, 0.2])
    # head on the target, lifted, hammer caged and gripped: 2 + 6
    hammer = HAMMER_GOAL - [0.16, 0.07, 0.0]
    tcp = hammer.copy()
    left, right = _pads(tcp, 0.0175)
    r = _one(hammer_reward(_action(1.0), _t(hammer), _t(HAMMER_GOAL), _t(init), _t(tcp), _t(left), _t(right),
                           _t(init_tcp)))
    want = _hammer_ref(1.0, hammer, HAMMER_GOAL, init, tcp, left, right, init_tcp)
    assert r == pytest.approx(want) and want == pytest.approx(8.0)
    # the lifted flag (head above 4 cm) and the handle threshold (|x - tcp_x| < 0.07) on both sides
    rng = np.random.default_rng(6)
    for head_z in (0.039, 0.041):
        for dx in (0.069, 0.071, 0.0):
            hammer = np.array([0.0, 0.55, head_z])
            tcp = hammer + [dx, 0.0, 0.0] + rng.normal(0.0, 0.003, 3)
            left, right = _pads(tcp, rng.uniform(0.01, 0.04))
            got = _one(hammer_reward(_action(0.7), _t(hammer), _t(HAMMER_GOAL), _t(init), _t(tcp), _t(left),
                                     _t(right), _t(init_tcp)))
            assert got == pytest.approx(_hammer_ref(0.7, hammer, HAMMER_GOAL, init, tcp, left, right, init_tcp),
                                        abs=1e-12)
    # success: nail beyond 9 cm and dense term above 5
    nails = _t(0.095, 0.089, 0.095, 0.1)
    dense = _t(5.01, 7.0, 4.99, 5.0)
    assert hammer_success(nails, dense).tolist() == [True, False, False, False]


# ------------------------------------------------------------------------------------------------------------------
# hand_insert
# ------------------------------------------------------------------------------------------------------------------
def test_hand_insert_reward_and_success() -> None:
    obj_init = np.array([0.05, 0.65, 0.07])
    goal = np.array([0.0, 0.84, 0.0125])
    init_tcp = INIT_TCP

    def ref(grip, obj, tcp, left, right):
        in_place = long_tail(_dist(obj, goal), 0.0, 0.05, _dist(obj_init, goal))
        grasp = caging(grip, obj, obj_init, tcp, init_tcp, left, right, obj_radius=0.02, pad=0.05,
                       reach_radius=0.0, xz=0.005)
        r = ham(grasp, in_place)
        openness = min(max(_dist(left, right) / 0.095, 0.0), 1.0)
        if _dist(obj, tcp) < 0.02 and openness > 0 and _dist(goal, tcp) < 0.05:
            r += 1.0 + 7.0 * in_place
        return r

    def got(grip, obj, tcp, left, right):
        return _one(hand_insert_reward(_action(grip), _t(obj), _t(goal), _t(obj_init), _t(tcp), _t(left), _t(right),
                                       _t(init_tcp)))

    # block on the goal, held: hamacher(grasp, 1) + 1 + 7 (bonus: TCP on the block and within 5 cm of the goal)
    left, right = _pads(goal, 0.024)
    top = got(1.0, goal, goal, left, right)
    assert top == pytest.approx(ref(1.0, goal, goal, left, right)) and top > 8.0
    # bonus off: TCP 5 cm from the goal (block with it), or 2 cm from the block
    away = goal + [0.0, 0.0, 0.0501]
    la, ra = _pads(away, 0.024)
    r = got(1.0, away, away, la, ra)
    assert r == pytest.approx(ref(1.0, away, away, la, ra)) and r < 1.0
    off = goal + [0.0, 0.0, 0.0201]
    lo, ro = _pads(off, 0.024)
    r = got(1.0, goal, off, lo, ro)
    assert r == pytest.approx(ref(1.0, goal, off, lo, ro)) and r < 1.0
    rng = np.random.default_rng(7)
    for _ in range(20):
        obj = goal + rng.normal(0.0, 0.05, 3)
        tcp = obj + rng.normal(0.0, 0.015, 3)
        left, right = _pads(tcp, rng.uniform(0.0, 0.045))
        grip = rng.uniform(-1, 1)
        assert got(grip, obj, tcp, left, right) == pytest.approx(ref(grip, obj, tcp, left, right), abs=1e-12)
    blocks = _t(goal + [0, 0, 0.0499], goal + [0, 0.0501, 0])
    assert hand_insert_success(blocks, _t(goal).expand(2, 3)).tolist() == [True, False]


# ------------------------------------------------------------------------------------------------------------------
# peg_unplug_side
# ------------------------------------------------------------------------------------------------------------------
def test_peg_unplug_side_reward_and_success() -> None:
    wall = np.array([-0.2, 0.85, 0.0])
    goal = wall + [0.0, -0.02, 0.131]
    head_init = wall + [0.0, -0.11, 0.045]

    def ref(grip, head, tcp, left, right, opening):
        in_place = long_tail(_dist(head, goal), 0.0, 0.05, _dist(head_init, goal))
        grasp = caging(grip, head, head_init, tcp, INIT_TCP, left, right, obj_radius=0.02, pad=0.05,
                       reach_radius=0.0, xz=0.005)
        r = ham(grasp, in_place)
        if _dist(head + [0.0, -0.06, 0.0], tcp) < 0.02 and opening > 0 and head[2] - 0.01 > head_init[2]:
            r += 1.0 + 5.0 * in_place
        return r

    def got(grip, head, tcp, left, right, opening):
        return _one(peg_unplug_side_reward(_action(grip), _t(head), _t(goal), _t(head_init), _t(tcp), _t(left),
                                           _t(right), _t(INIT_TCP), _t(opening)))

    # head at the hole, held 6 cm behind it, lifted: the bonus branch
    tcp = goal + [0.0, -0.06, 0.0]
    left, right = _pads(tcp, 0.03)
    r = got(1.0, goal, tcp, left, right, 0.5)
    assert r == pytest.approx(ref(1.0, goal, tcp, left, right, 0.5)) and r > 6.0
    # each bonus condition false
    r = got(1.0, goal, tcp, left, right, 0.0)
    assert r == pytest.approx(ref(1.0, goal, tcp, left, right, 0.0)) and r < 1.0
    far = tcp + [0.0, 0.0201, 0.0]
    lf, rf = _pads(far, 0.03)
    assert got(1.0, goal, far, lf, rf, 0.5) < 1.0
    low = head_init + [0.0, 0.0, 0.0099]
    lt_, rt_ = _pads(low + [0.0, -0.06, 0.0], 0.03)
    assert got(1.0, low, low + [0.0, -0.06, 0.0], lt_, rt_, 0.5) < 1.0
    rng = np.random.default_rng(8)
    for _ in range(20):
        head = head_init + rng.normal(0.0, 0.05, 3)
        tcp = head + [0.0, -0.06, 0.0] + rng.normal(0.0, 0.015, 3)
        left, right = _pads(tcp, rng.uniform(0.0, 0.045))
        grip, opening = rng.uniform(-1, 1), rng.uniform(-0.1, 1.0)
        assert got(grip, head, tcp, left, right, opening) == \
            pytest.approx(ref(grip, head, tcp, left, right, opening), abs=1e-12)
    heads = _t(goal + [0, -0.0499, 0], goal + [0, 0, -0.0501])
    assert peg_unplug_side_success(heads, _t(goal).expand(2, 3)).tolist() == [True, False]


# ------------------------------------------------------------------------------------------------------------------
# scene facts (MuJoCo C)
# ------------------------------------------------------------------------------------------------------------------
def _mw_model(xml: str) -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(metaworld_assets_dir() / "sawyer_xyz" / xml))


@pytest.mark.parametrize("task", ["handle_press", "handle_press_side"])
def test_handle_scene_sites_match_mtbench_offsets(task: str) -> None:
    cls = TASKS[task]
    m = build_scene(cls.scene, edit_spec=cls.edit_spec)
    d = mujoco.MjData(m)
    jid = m.joint(_handle_press.HANDLE_JOINT).id
    assert tuple(m.jnt_range[jid]) == (_handle_press.SLIDE_LOW, _handle_press.SLIDE_HIGH)
    assert m.dof_armature[m.jnt_dofadr[jid]] == _handle_press.HANDLE_ARMATURE
    m.body("box").pos = HOUSING
    side = task.endswith("side")
    # MTBench offsets mapped to our frame: obj_init = housing + (0, -.216, .172) (front) or (.216, 0, .172) (side),
    # press target 9.7 cm below, pull target = the handle at the top; the slide moves the handle point straight down
    start = HOUSING + ([0.216, 0.0, 0.172] if side else [0.0, -0.216, 0.172])
    for q in (0.0, -0.1):
        d.qpos[m.jnt_qposadr[jid]] = q
        mujoco.mj_kinematics(m, d)
        np.testing.assert_allclose(d.site("handleStart").xpos, start + [0, 0, q], atol=3e-4)
    np.testing.assert_allclose(d.site("goalPress").xpos, start + [0, 0, -0.097], atol=3e-4)
    np.testing.assert_allclose(d.site("goalPull").xpos, start, atol=3e-4)


def test_faucet_scene_facts() -> None:
    cls = TASKS["faucet_close"]
    m = build_scene(cls.scene, edit_spec=cls.edit_spec)
    d = mujoco.MjData(m)
    jid = m.joint(_faucet.HINGE).id
    assert tuple(np.round(m.jnt_range[jid], 3)) == (-1.57, 1.57)
    m.body(_faucet.BASE_BODY).pos = FAUCET
    for angle in (0.0, -1.2, 1.4):
        d.qpos[m.jnt_qposadr[jid]] = angle
        mujoco.mj_kinematics(m, d)
        np.testing.assert_allclose(d.site("handleStartClose").xpos, _faucet_site(angle, 0.015), atol=1e-9)
        np.testing.assert_allclose(d.site("handleStartOpen").xpos, _faucet_site(angle, -0.015), atol=1e-9)


def test_lever_scene_edit_and_goal() -> None:
    cls = TASKS["lever_pull"]
    raw = _mw_model(cls.scene.xml)
    assert tuple(raw.jnt_range[raw.joint(lever_task.HINGE).id]) == (0.0, 1.57)  # Meta-World swings the lever down
    m = build_scene(cls.scene, edit_spec=cls.edit_spec)
    d = mujoco.MjData(m)
    jid = m.joint(lever_task.HINGE).id
    assert tuple(m.jnt_range[jid]) == lever_task.HINGE_RANGE
    assert m.dof_armature[m.jnt_dofadr[jid]] == lever_task.HINGE_ARMATURE
    base = np.array([0.05, 0.75, 0.0])
    m.body("lever").pos = base
    d.qpos[m.jnt_qposadr[jid]] = -math.pi / 2  # MTBench: lever_angle = -q = 90 degrees: upright
    mujoco.mj_kinematics(m, d)
    np.testing.assert_allclose(d.site("leverStart").xpos, base + lever_task.GOAL_OFFSET, atol=1e-9)
    d.qpos[m.jnt_qposadr[jid]] = 0.0
    mujoco.mj_kinematics(m, d)
    np.testing.assert_allclose(d.site("leverStart").xpos, base + [0.12, -0.2, 0.25], atol=1e-9)


def test_hammer_scene_facts() -> None:
    m = _mw_model(TASKS["hammer"].scene.xml)
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    np.testing.assert_allclose(d.site("goal").xpos, HAMMER_GOAL, atol=1e-9)  # MTBench's target body, mapped
    assert tuple(m.jnt_range[m.joint("NailSlideJoint").id]) == (0.0, 0.1)
    np.testing.assert_allclose(m.jnt_axis[m.joint("NailSlideJoint").id], [0, 1, 0])
    # the head point (hammer + (0.16, 0.07, 0)) is the centre of the head's +y striking face (disc at y 0.056, 1.6 cm)
    body = m.body("hammer").id
    faces = [m.geom_pos[g][1] + m.geom_size[g][1] for g in range(m.ngeom)
             if m.geom_bodyid[g] == body and m.geom_contype[g] and m.geom_type[g] == mujoco.mjtGeom.mjGEOM_CYLINDER]
    assert max(faces) == pytest.approx(0.072) and abs(max(faces) - hammer_task.HEAD_OFFSET[1]) < 0.0021
    # MTBench's reset height: the hammer at 5 cm falls onto the table; it rests on the head's large discs (3.8 cm)
    task_model = build_scene(TASKS["hammer"].scene)
    d = mujoco.MjData(task_model)
    mujoco.mj_resetDataKeyframe(task_model, d, 0)
    adr = int(task_model.jnt_qposadr[int(task_model.body("hammerbody").jntadr[0])])
    d.qpos[adr:adr + 7] = [0.0, 0.45, hammer_task.HAMMER_Z, 1, 0, 0, 0]
    for _ in range(250):
        mujoco.mj_step(task_model, d)
    assert 0.02 < d.qpos[adr + 2] < 0.04


def test_hand_insert_hole_geometry() -> None:
    m = _mw_model(TASKS["hand_insert"].scene.xml)
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    table = m.body("tablelink").id
    boxes = [g for g in range(m.ngeom) if m.geom_bodyid[g] == table and m.geom_conaffinity[g]]
    tops = sorted({round(float(d.geom_xpos[g][2] + m.geom_size[g][2]), 4) for g in boxes})
    assert tops == [-0.053, 0.0, 0.05]  # hole floor at 0, table top at 0.05 (MTBench: 1.0 and 1.05 m)
    # the goal range lies inside the hole (x in [-0.08, 0.08], y in [0.76, 0.92]) with room for the 4 cm block
    lo, hi = TASKS["hand_insert"].reset_low[3:], TASKS["hand_insert"].reset_high[3:]
    assert -0.08 + 0.02 <= lo[0] and hi[0] <= 0.08 - 0.02 and 0.76 + 0.02 <= lo[1] and hi[1] <= 0.92 - 0.02
    assert lo[2] == hi[2] == pytest.approx(1.0125 - 1.0)


def test_peg_unplug_side_layout() -> None:
    cls = TASKS["peg_unplug_side"]
    m = build_scene(cls.scene, edit_spec=cls.edit_spec)
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, 0)
    wall = np.array([-0.2, 0.85, 0.0])
    m.body("box").pos = wall
    adr = int(m.jnt_qposadr[int(m.body("plug1").jntadr[0])])
    plug = wall + [0.0, -0.15, plug_task.PLUG_REST_Z]
    d.qpos[adr:adr + 7] = [*plug, *plug_task.PLUG_QUAT]
    mujoco.mj_forward(m, d)
    # the outlet faces the robot: its hole is 2 cm in front of the outlet body, 12.9 cm up (MTBench target: 13.1 cm)
    np.testing.assert_allclose(d.site("hole").xpos, wall + [0.0, -0.02, 0.129], atol=1e-3)
    # the plug lies along y with its head towards the outlet: pegHead 4 cm in front of the plug's origin
    np.testing.assert_allclose(d.site("pegHead").xpos, plug + [0.0, 0.04, 0.0], atol=1e-9)
    np.testing.assert_allclose(d.site("pegEnd").xpos, plug + [0.0, -0.04, 0.0], atol=1e-9)
    for _ in range(250):  # it rests where it is put
        mujoco.mj_step(m, d)
    np.testing.assert_allclose(d.site("pegHead").xpos, plug + [0.0, 0.04, 0.0], atol=3e-3)
    # its end spheres alone span more along y (the fingers' opening axis) than the open gripper's 8 cm
    body = m.body("plug").id
    ys = []
    for g in range(m.ngeom):
        if m.geom_bodyid[g] == body and m.geom_contype[g] and m.geom_type[g] == mujoco.mjtGeom.mjGEOM_SPHERE:
            ys += [d.geom_xpos[g][1] - m.geom_size[g][0], d.geom_xpos[g][1] + m.geom_size[g][0]]
    assert max(ys) - min(ys) == pytest.approx(0.165, abs=3e-3)


def test_goals_of_the_reset_ranges_lie_in_the_hand_workspace() -> None:
    """Every corner of each reset box gives goals (and fixture handles) inside the TCP workspace."""
    from itertools import product

    from mtbench.envs.metaworld.task import HAND_HIGH, HAND_LOW

    offsets = {  # goal relative to the sampled position (tasks whose goal is not sampled itself)
        "faucet_close": [(-0.175, 0.0, 0.125)], "faucet_open": [(0.175, 0.0, 0.125)],
        "handle_press": [(0.0, -0.216, 0.075), (0.0, -0.216, 0.172)],
        "handle_pull": [(0.0, -0.216, 0.172), (0.0, -0.216, 0.072)],
        "handle_press_side": [(0.216, 0.0, 0.075), (0.216, 0.0, 0.172)],
        "handle_pull_side": [(0.216, 0.0, 0.172), (0.216, 0.0, 0.072)],
        "lever_pull": [lever_task.GOAL_OFFSET, (0.12, -0.2, 0.25)],
        "peg_unplug_side": [plug_task.GOAL_FROM_WALL, (0.0, -0.11, plug_task.PLUG_REST_Z)],
        "hammer": [(0.0, 0.0, 0.0)], "hand_insert": [(0.0, 0.0, 0.0)],
    }
    low, high = np.array(HAND_LOW), np.array(HAND_HIGH)
    for name in GROUP_B:
        cls = TASKS[name]
        lo, hi = np.array(cls.reset_low), np.array(cls.reset_high)
        for corner in product(*zip(lo, hi)):
            corner = np.array(corner)
            points = [corner[:3] + off for off in offsets[name]]
            if name == "hand_insert":
                points.append(corner[3:6])
            if name == "hammer":
                points.append(HAMMER_GOAL)
            for p in points:
                assert np.all(p >= low) and np.all(p <= high), (name, p)


# ------------------------------------------------------------------------------------------------------------------
# scripted success
# ------------------------------------------------------------------------------------------------------------------
def _scene_builds(task: str) -> bool:
    try:
        compiled_task(task)
    except (AttributeError, RuntimeError):
        return False
    return True


HAND_INSERT_NEEDS = ("hand_insert's scene (Meta-World's table with a hole: no retaining wall, a table top of several "
                     "boxes) needs scene.py to skip the missing wall and keep those boxes")


def test_hand_insert_scene_builds() -> None:
    if not _scene_builds("hand_insert"):
        pytest.skip(HAND_INSERT_NEEDS)
    _, m = compiled_task("hand_insert")
    table = m.body("tablelink").id
    tops = {round(float(m.geom_pos[g][2] + m.geom_size[g][2]), 4) for g in range(m.ngeom)
            if m.geom_bodyid[g] == table and m.geom_conaffinity[g]}
    assert 0.05 in tops and 0.0 in tops  # the top around the hole and the hole's floor still collide
