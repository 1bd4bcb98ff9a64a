"""MT50 group c: pick_out_of_hole, pick_place_wall, plate_slide_back_side, plate_slide_back, plate_slide_side,
plate_slide, push_back, push_wall, reach_wall, shelf_place.

* Known answers of the paper-era MTBench rewards and success rules (no physics): hand-set states in our frame, the
  expected values written out from MTBench's formulas (the long-tail tolerance ``1 / (1 + 9 ((x − b) / m)²)`` outside
  its bounds, Hamacher products, the caging reward where it has a closed form: with the gripper effort at 0 it is
  half the reach term, caged and closing it is 1).
* Scene facts in MuJoCo C: the geometry the rewards and the scripted policies rely on.
* One batched env with all ten tasks: reset placement and scripted-policy success on randomized resets.
"""

from __future__ import annotations

import math
import types

import mujoco
import numpy as np
import pytest
import torch

from mtbench.envs.metaworld import robot
from mtbench.envs.metaworld.models import compiled_task
from mtbench.envs.metaworld.registry import TASKS
from mtbench.envs.metaworld.tasks import _plate, _wall
from mtbench.envs.metaworld.tasks import pick_out_of_hole as poh
from mtbench.envs.metaworld.tasks import pick_place_wall as ppw
from mtbench.envs.metaworld.tasks import plate_slide as ps
from mtbench.envs.metaworld.tasks import plate_slide_back as psb
from mtbench.envs.metaworld.tasks import plate_slide_back_side as psbs
from mtbench.envs.metaworld.tasks import plate_slide_side as pss
from mtbench.envs.metaworld.tasks import push_back as pb
from mtbench.envs.metaworld.tasks import push_wall as pw
from mtbench.envs.metaworld.tasks import reach_wall as rw
from mtbench.envs.metaworld.tasks import shelf_place as sp

GROUP_C = {
    "pick_out_of_hole": (30, "Pick a small object up out of a hole in the table and lift it to a goal."),
    "pick_place_wall": (32, "Pick up a puck, carry it over a wall and place it at the goal."),
    "plate_slide_back_side": (33, "Slide a plate sideways back out of the goal cabinet."),
    "plate_slide_back": (34, "Slide a plate backward out of the goal cabinet towards the robot."),
    "plate_slide_side": (35, "Slide a plate sideways into a cabinet."),
    "plate_slide": (36, "Slide a plate forward into a cabinet."),
    "push_back": (37, "Push a puck backward towards the robot to a goal position."),
    "push_wall": (39, "Push a puck around a wall to a goal position behind it."),
    "reach_wall": (41, "Reach a goal position on the other side of a short wall."),
    "shelf_place": (42, "Pick up a block and place it on a shelf."),
}
INIT_TCP = (0.0, 0.6, 0.2)
CLOSE, NO_EFFORT = 1.0, 0.0


# --------------------------------------------------------------------------------------------------------------
# helpers: independent closed forms
# --------------------------------------------------------------------------------------------------------------
def lt(x: float, upper: float, margin: float) -> float:
    """Long-tail tolerance with bounds (0, upper): 1 inside, ``1 / (1 + 9 ((x − upper) / margin)²)`` outside."""
    if x <= upper:
        return 1.0
    return 1.0 / (1.0 + 9.0 * ((x - upper) / margin) ** 2)


def ham(a: float, b: float) -> float:
    return 0.0 if a + b - a * b == 0 else a * b / (a + b - a * b)


def dist(a, b) -> float:
    return float(np.linalg.norm(np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64)))


def t(*points) -> list[torch.Tensor]:
    """``[1, k]`` float32 tensors."""
    return [torch.tensor(np.asarray([p], dtype=np.float64), dtype=torch.float32) for p in points]


def pads(tcp, half: float):
    """Left (+y) and right (-y) pad at ``half`` either side of the TCP along y, and the openness."""
    tcp = np.asarray(tcp, dtype=np.float64)
    return tcp + (0, half, 0), tcp - (0, half, 0), min(2 * half / 0.1, 1.0)


def act(effort: float) -> torch.Tensor:
    return torch.tensor([[0.0, 0.0, 0.0, effort]])


def val(x: torch.Tensor) -> float:
    return float(x.reshape(()))


APPROX = dict(abs=2e-5)


def test_group_c_tasks_are_registered_with_mtbench_ids_and_descriptions() -> None:
    for name, (mtbench_id, description) in GROUP_C.items():
        cls = TASKS[name]
        assert (cls.name, cls.mtbench_id, cls.description) == (name, mtbench_id, description)
    assert TASKS["push_back"].success_bonus == 20.0  # MTBench: 20 for push_back, 10 for the others
    assert all(TASKS[n].success_bonus == 10.0 for n in GROUP_C if n != "push_back")
    assert all(TASKS[n].dense_scale == 0.01 for n in GROUP_C)


# --------------------------------------------------------------------------------------------------------------
# reach_wall
# --------------------------------------------------------------------------------------------------------------
def test_reach_wall_known_answers() -> None:
    goal, init = (0.02, 0.87, 0.15), INIT_TCP
    assert val(rw.reach_wall_reward(*t(goal, goal, init))) == pytest.approx(1.0)
    d0 = dist(init, goal)
    assert val(rw.reach_wall_reward(*t(init, goal, init))) == pytest.approx(lt(d0, 0.05, d0), **APPROX)
    mid = (0.0, 0.75, 0.2)
    assert val(rw.reach_wall_reward(*t(mid, goal, init))) == pytest.approx(lt(dist(mid, goal), 0.05, d0), **APPROX)
    for off, ok in ((0.0499, True), (0.0501, False)):  # ‖tcp − goal‖ ≤ 0.05
        tcp = (goal[0], goal[1], goal[2] + off)
        assert bool(rw.reach_wall_success(*t(tcp, goal))) is ok


# --------------------------------------------------------------------------------------------------------------
# push_wall
# --------------------------------------------------------------------------------------------------------------
def _push_wall(obj, tcp, half, effort, goal, obj_init, init_tcp=INIT_TCP) -> float:
    left, right, opened = pads(tcp, half)
    o, tc, le, ri, g, oi, it, mid = t(obj, tcp, left, right, goal, obj_init, init_tcp, pw.MIDPOINT)
    return val(pw.push_wall_reward(act(effort), o, torch.tensor([opened]), tc, le, ri, g, oi, it, mid))


def test_wall_scaling_is_mtbench_x_axis_in_our_frame() -> None:
    # MTBench's in_place_scaling (3, 1, 1) acts on its x axis = our y axis
    v = torch.tensor([[0.01, 0.02, 0.03]])
    assert val(_wall.scaled_norm(v)) == pytest.approx(math.sqrt(0.01 ** 2 + 0.06 ** 2 + 0.03 ** 2), **APPROX)
    assert pw.MIDPOINT == (-0.1, 0.77, 0.02)  # MTBench (0.17, 0.1, 1.047): x = -y_mtb, y = x_mtb + 0.6, z - 1.027


def test_push_wall_known_answers() -> None:
    goal, obj_init = (0.02, 0.87, 0.02), (0.0, 0.62, 0.02)
    # caged and closing at the goal, past the wall: grasp = 1, part2 = 1 -> 1 + 5 + 3
    assert _push_wall(goal, goal, 0.025, CLOSE, goal, obj_init) == pytest.approx(9.0, **APPROX)
    # in front of the wall line (y < 0.75), held: grasp + 1 + 4 part1 with the (1, 3, 1)-scaled midpoint distance
    obj = (-0.1, 0.70, 0.02)
    part1 = lt(3 * 0.07, 0.05, math.hypot(0.1, 3 * 0.15))
    assert _push_wall(obj, obj, 0.025, CLOSE, goal, obj_init) == pytest.approx(1.0 + 1.0 + 4.0 * part1, **APPROX)
    # no gripper effort: grasp = reach / 2 = 0.5 at the puck
    assert _push_wall(obj, obj, 0.025, NO_EFFORT, goal, obj_init) == pytest.approx(0.5 + 1.0 + 4.0 * part1, **APPROX)
    # the wall line (MTBench obj_x_mtb >= 0.15): y = 0.75 is past it, just before is not
    at_line, before = (0.05, 0.75, 0.02), (0.05, 0.7499, 0.02)
    past2 = lt(dist(at_line, goal), 0.05, dist(obj_init, goal))
    assert _push_wall(at_line, at_line, 0.025, NO_EFFORT, goal, obj_init) == pytest.approx(0.5 + 5 + 3 * past2,
                                                                                             **APPROX)
    front1 = lt(math.hypot(0.15, 3 * (0.77 - 0.7499)), 0.05, math.hypot(0.1, 3 * 0.15))
    assert _push_wall(before, before, 0.025, NO_EFFORT, goal, obj_init) == pytest.approx(0.5 + 1 + 4 * front1,
                                                                                           **APPROX)
    # hand 3 cm away (not < 0.03) or gripper fully closed: the caging term alone
    away = (obj[0], obj[1], obj[2] + 0.03)
    reach = lt(0.03, 0.01, abs(dist(obj_init, INIT_TCP) - 0.01))
    assert _push_wall(obj, away, 0.025, NO_EFFORT, goal, obj_init) == pytest.approx(reach / 2, **APPROX)
    assert _push_wall(obj, obj, 0.0, NO_EFFORT, goal, obj_init) == pytest.approx(0.5, **APPROX)
    for off, ok in ((0.0499, True), (0.05, False)):  # ‖obj − goal‖ < 0.05
        assert bool(pw.push_wall_success(*t((goal[0] + off, goal[1], goal[2]), goal))) is ok


# --------------------------------------------------------------------------------------------------------------
# pick_place_wall
# --------------------------------------------------------------------------------------------------------------
def _ppw_state(obj, tcp, half, goal, obj_init):
    left, right, opened = pads(tcp, half)
    return types.SimpleNamespace(obj_pos=t(obj)[0], tcp=t(tcp)[0], left_pad=t(left)[0], right_pad=t(right)[0],
                                 goal=t(goal)[0], obj_init_pos=t(obj_init)[0], init_tcp=t(INIT_TCP)[0],
                                 gripper_open=torch.tensor([opened]), n=1)


def _ppw(obj, tcp, half, effort, goal, obj_init) -> float:
    s = _ppw_state(obj, tcp, half, goal, obj_init)
    return val(ppw.pick_place_wall_reward(act(effort), s.obj_pos, s.gripper_open, s.tcp, s.left_pad, s.right_pad,
                                          s.goal, s.obj_init_pos, s.init_tcp))


def test_pick_place_wall_midpoint() -> None:
    mid = ppw.pick_place_wall_midpoint(*t((0.04, 0.62, 0.02), (-0.02, 0.88, 0.2)))
    torch.testing.assert_close(mid, torch.tensor([[0.01, 0.77, 0.2]]))


def test_pick_place_wall_known_answers() -> None:
    goal, obj_init = (-0.02, 0.88, 0.2), (0.04, 0.62, 0.02)
    mid = (0.01, 0.77, 0.2)
    # lifted past the midpoint line (y >= 0.77), at the goal: 6 + 3 part2 = 9 (no caging term)
    assert _ppw(goal, goal, 0.025, NO_EFFORT, goal, obj_init) == pytest.approx(9.0, **APPROX)
    # lifted in front of it: hamacher(grasp, part1) + 1 + 4 part1, part1 on the unscaled midpoint distance
    obj = (0.01, 0.70, 0.2)
    part1 = lt(0.07, 0.05, dist(obj_init, mid))
    assert _ppw(obj, obj, 0.025, NO_EFFORT, goal, obj_init) == pytest.approx(ham(0.5, part1) + 1 + 4 * part1,
                                                                               **APPROX)
    # not lifted (obj_z − 0.015 > obj_init_z fails): hamacher(grasp, part1) only
    low = (0.01, 0.70, 0.035)
    part1_low = lt(dist(low, mid), 0.05, dist(obj_init, mid))
    assert _ppw(low, low, 0.025, NO_EFFORT, goal, obj_init) == pytest.approx(ham(0.5, part1_low), **APPROX)
    # past the line but the hand 2.1 cm away (not < 0.02): no bonus
    far = (goal[0], goal[1], goal[2] + 0.021)
    reach = lt(0.021, 0.01, abs(dist(obj_init, INIT_TCP) - 0.01))
    part1_goal = lt(dist(goal, mid), 0.05, dist(obj_init, mid))
    assert _ppw(goal, far, 0.025, NO_EFFORT, goal, obj_init) == pytest.approx(ham(reach / 2, part1_goal), **APPROX)


def test_pick_place_wall_success_and_success_reward() -> None:
    goal, obj_init = (0.0, 0.87, 0.15), (0.0, 0.62, 0.02)
    # MTBench: success at the (1, 3, 1)-scaled distance < 0.08 ...
    for off, ok in (((0.0, 0.026, 0.0), True), ((0.0, 0.027, 0.0), False), ((0.079, 0.0, 0.0), True),
                    ((0.0, 0.0, -0.081), False)):
        obj = tuple(g + o for g, o in zip(goal, off))
        assert bool(ppw.pick_place_wall_success(*t(obj, goal))) is ok, off
    # ... but the 10 is paid only within a scaled 0.05; between, the dense reward × 0.01, unscaled
    task = object.__new__(TASKS["pick_place_wall"])  # methods only: no model needed
    for off, paid_bonus in ((0.016, True), (0.02, False)):
        obj = (goal[0], goal[1] + off, goal[2])
        s = _ppw_state(obj, obj, 0.025, goal, obj_init)
        dense = _ppw(obj, obj, 0.025, NO_EFFORT, goal, obj_init)
        assert bool(task.success(s, act(NO_EFFORT)))
        expected = 10.0 if paid_bonus else 0.01 * dense
        assert val(task.success_reward(s, act(NO_EFFORT))) == pytest.approx(expected, **APPROX)


# --------------------------------------------------------------------------------------------------------------
# push_back
# --------------------------------------------------------------------------------------------------------------
def _push_back(obj, tcp, half, effort, goal, obj_init) -> float:
    left, right, opened = pads(tcp, half)
    o, tc, le, ri, g, oi, it = t(obj, tcp, left, right, goal, obj_init, INIT_TCP)
    return val(pb.push_back_reward(act(effort), o, torch.tensor([opened]), tc, le, ri, g, oi, it))


def test_push_back_known_answers() -> None:
    goal, obj_init = (0.05, 0.65, 0.02), (-0.02, 0.82, 0.02)
    # caged, closing, at the goal: hamacher(1, 1) + 1 + 10
    assert _push_back(goal, goal, 0.025, CLOSE, goal, obj_init) == pytest.approx(12.0, **APPROX)
    # at the start, hand at the block without effort: grasp = 0.5 (reach radius 0)
    d0 = dist(obj_init, goal)
    ip0 = lt(d0, 0.05, d0)
    assert _push_back(obj_init, obj_init, 0.025, NO_EFFORT, goal, obj_init) == pytest.approx(
        ham(0.5, ip0) + 1 + 10 * ip0, **APPROX)
    # hand 2 cm off (not < 0.02): no bonus; the reach term with radius 0 and margin ‖obj_init − init_tcp‖
    off = (obj_init[0], obj_init[1], obj_init[2] + 0.02)
    reach = lt(0.02, 0.0, dist(obj_init, INIT_TCP))
    assert _push_back(obj_init, off, 0.025, NO_EFFORT, goal, obj_init) == pytest.approx(ham(reach / 2, ip0), **APPROX)
    for d, ok in ((0.0499, True), (0.05, False)):
        assert bool(pb.push_back_success(*t((goal[0], goal[1] + d, goal[2]), goal))) is ok
    task = object.__new__(TASKS["push_back"])
    s = types.SimpleNamespace(tcp=torch.zeros(3, 3), n=3)
    torch.testing.assert_close(task.success_reward(s, torch.zeros(3, 4)), torch.full((3,), 20.0))


# --------------------------------------------------------------------------------------------------------------
# pick_out_of_hole
# --------------------------------------------------------------------------------------------------------------
def _poh(obj, tcp, half, effort, goal, obj_init=(0.0, 0.75, 0.02)) -> float:
    left, right, _ = pads(tcp, half)
    o, tc, le, ri, g, oi, it = t(obj, tcp, left, right, goal, obj_init, INIT_TCP)
    return val(poh.pick_out_of_hole_reward(act(effort), o, tc, le, ri, g, oi, it))


def test_pick_out_of_hole_above_floor_funnel() -> None:
    init = (0.0, 0.75, 0.02)

    def floor_term(tcp):
        return val(poh.above_floor(*t(tcp, init)))

    # within 3 cm (x-y) the funnel is flat at MTBench's table-top estimate, 3.25 cm above the hole's floor
    assert floor_term((0.0, 0.76, 0.0326)) == 1.0
    assert floor_term((0.0, 0.76, 0.0205)) == pytest.approx(lt(0.012, 0.01, 0.02), **APPROX)
    # 50 cm away it rises as 0.015 ln(r − 0.03 + 1e-6) + 0.0325
    floor = 0.015 * math.log(0.5 - 0.03 + 1e-6) + 0.0325
    assert floor_term((0.5, 0.75, 0.0)) == pytest.approx(lt(floor, 0.01, 0.02), **APPROX)
    assert floor_term((0.5, 0.75, floor + 0.001)) == 1.0


def test_pick_out_of_hole_known_answers() -> None:
    goal, init = (0.05, 0.65, 0.25), (0.0, 0.75, 0.02)
    # held at the goal (near, lifted, pads 4 cm apart), no effort: hamacher(0.5, 1) + 1 + 5 hamacher(1, 1)
    assert _poh(goal, goal, 0.02, NO_EFFORT, goal) == pytest.approx(6.5, **APPROX)
    # "pinched without object": pads closer than 0.33 × 9.5 cm (MTBench's openness scale)
    assert _poh(goal, goal, 0.0155, NO_EFFORT, goal) == pytest.approx(0.5, **APPROX)
    assert _poh(goal, goal, 0.0160, NO_EFFORT, goal) == pytest.approx(6.5, **APPROX)
    # lifted just 2 cm (obj_z − 0.02 > init_z is strict) or not: the bonus and in_place's (0, 0.02) bounds
    margin = dist(init, goal)
    for dz, bonus in ((0.0201, True), (0.0199, False)):
        obj = (0.0, 0.75, 0.02 + dz)
        ip = lt(dist(obj, goal), 0.02, margin)
        expected = ham(0.5, ip) + (1 + 5 * ham(ip, 1.0) if bonus else 0.0)
        assert _poh(obj, obj, 0.02, NO_EFFORT, goal) == pytest.approx(expected, **APPROX)
    # held low, the TCP 2 cm under the object and below the funnel: above_floor < 1
    obj, tcp = (0.0, 0.75, 0.0405), (0.0, 0.75, 0.0205)
    ip = lt(dist(obj, goal), 0.02, margin)
    grasp = lt(0.02, 0.0, dist(init, INIT_TCP)) / 2
    expected = ham(grasp, ip) + 1 + 5 * ham(ip, lt(0.012, 0.01, 0.02))
    assert _poh(obj, tcp, 0.02, NO_EFFORT, goal) == pytest.approx(expected, **APPROX)
    # hand 4.1 cm away (not < 0.04): no bonus
    reach = lt(0.041, 0.0, dist(init, INIT_TCP))
    assert _poh(goal, (goal[0], goal[1], goal[2] + 0.041), 0.02, NO_EFFORT, goal) == pytest.approx(ham(reach / 2, 1.0),
                                                                                                     **APPROX)
    for d, ok in ((0.0499, True), (0.05, False)):
        assert bool(poh.pick_out_of_hole_success(*t((goal[0] + d, goal[1], goal[2]), goal))) is ok


# --------------------------------------------------------------------------------------------------------------
# shelf_place
# --------------------------------------------------------------------------------------------------------------
def _shelf(obj, tcp, effort, goal, obj_init) -> float:
    left, right, opened = pads(tcp, 0.025)
    o, tc, le, ri, g, oi, it = t(obj, tcp, left, right, goal, obj_init, INIT_TCP)
    return val(sp.shelf_place_reward(act(effort), o, torch.tensor([opened]), tc, le, ri, g, oi, it))


def test_shelf_place_known_answers() -> None:
    goal, init = (0.05, 0.85, 0.3), (-0.05, 0.55, 0.02)
    margin = dist(init, goal)
    # held at the goal (z = 0.3 is outside MTBench's band [0, 0.3)): hamacher(0.5, 1) + 1 + 5
    assert _shelf(goal, goal, NO_EFFORT, goal, init) == pytest.approx(6.5, **APPROX)
    # held 5 cm in front of the goal and 2 cm low: in_place minus hamacher(y_scaling, z_scaling), with MTBench's
    # z_scaling divided by the absolute height 1.327 of its frame
    obj = (0.05, 0.80, 0.28)
    raw = lt(math.hypot(0.05, 0.02), 0.05, margin)
    ys, zs = (0.80 - (0.85 - 0.15)) / 0.15, (0.3 - 0.28) / 1.327
    ip = min(max(raw - ham(ys, zs), 0.0), 1.0)
    assert _shelf(obj, obj, NO_EFFORT, goal, init) == pytest.approx(ham(0.5, raw) + 1 + 5 * ip, **APPROX)
    # behind the goal (obj_y >= goal_y) inside the band: in_place = 0 in the bonus
    obj = (0.05, 0.86, 0.28)
    raw = lt(math.hypot(0.01, 0.02), 0.05, margin)
    assert _shelf(obj, obj, NO_EFFORT, goal, init) == pytest.approx(ham(0.5, raw) + 1, **APPROX)
    # outside the lateral band (|dx| < 0.15 fails): unmodified
    obj = (0.2, 0.80, 0.28)
    raw = lt(dist(obj, goal), 0.05, margin)
    assert _shelf(obj, obj, NO_EFFORT, goal, init) == pytest.approx(ham(0.5, raw) + 1 + 5 * raw, **APPROX)
    # not lifted (obj_z − 0.01 > obj_init_z is strict): no bonus
    obj = (-0.05, 0.55, 0.03)
    assert _shelf(obj, obj, NO_EFFORT, goal, init) == pytest.approx(ham(0.5, lt(dist(obj, goal), 0.05, margin)),
                                                                     **APPROX)
    for d, ok in ((0.0499, True), (0.05, False)):
        assert bool(sp.shelf_place_success(*t((goal[0], goal[1] - d, goal[2]), goal))) is ok


# --------------------------------------------------------------------------------------------------------------
# plate slides
# --------------------------------------------------------------------------------------------------------------
def test_plate_slide_known_answers() -> None:
    plate0, target = (0.0, 0.6, 0.015), (0.05, 0.85, 0.0)
    # at the start both tolerances sit exactly at their margins (MTBench shortened them by the 5 cm radius): 0.1
    expected = 8 * ham(0.1, 0.1)
    assert val(ps.plate_slide_reward(*t(plate0, INIT_TCP, target, plate0, INIT_TCP))) == pytest.approx(expected)
    at_goal = (0.05, 0.85, 0.015)
    assert val(ps.plate_slide_reward(*t(at_goal, at_goal, target, plate0, INIT_TCP))) == pytest.approx(8.0)
    # success is 3-D: the target is at the table, 1.5 cm below the plate's centre
    for dxy, ok in ((0.047, True), (0.048, False)):
        assert bool(ps.plate_slide_success(*t((0.05, 0.85 - dxy, 0.015), target))) is ok


@pytest.mark.parametrize("module, reward, point", [
    (pss, "plate_slide_side_reward", (0.0, 0.0, 0.0)),
    (psb, "plate_slide_back_reward", (0.0, 0.05, 0.0)),  # MTBench (0.05, 0, 0): the plate's far edge
    (psbs, "plate_slide_back_side_reward", (-0.05, 0.0, 0.0)),  # MTBench (0, 0.05, 0): the cabinet-side edge
])
def test_plate_slide_staged_rewards(module, reward, point) -> None:
    fn = getattr(module, reward)
    plate0, target = (0.0, 0.7, 0.015), (0.2, 0.6, 0.02)
    plate = (0.1, 0.65, 0.015)
    p = tuple(a + b for a, b in zip(plate, point))
    near_margin = max(dist(INIT_TCP, plate0) - 0.05, 0.0)
    ip = lt(dist(plate, target), 0.05, max(dist(plate0, target) - 0.05, 0.0))

    def r(tcp, pl=plate):
        return val(fn(*t(pl, tcp, target, plate0, INIT_TCP)))

    # the TCP at the reward point, low: 2 + 7 in_place (9 at the goal)
    assert r((p[0], p[1], 0.05)) == pytest.approx(2 + 7 * ip, **APPROX)
    at_goal = tuple(a + b for a, b in zip(target[:2] + (0.015,), point))
    assert r((at_goal[0], at_goal[1], 0.03), pl=target[:2] + (0.015,)) == pytest.approx(2 + 7 * lt(0.005, 0.05, 1.0),
                                                                                      **APPROX)
    # z boundary (tcp_z <= 0.05) and distance boundary (< 0.07 from the point): 1.5 near(‖tcp − point‖)
    assert r((p[0], p[1], 0.0501)) == pytest.approx(1.5 * lt(0.0501 - 0.015, 0.05, near_margin), **APPROX)
    assert r((p[0] + 0.0699, p[1], 0.015)) == pytest.approx(2 + 7 * ip, **APPROX)
    assert r((p[0] + 0.0701, p[1], 0.015)) == pytest.approx(1.5 * lt(0.0701, 0.05, near_margin), **APPROX)


def test_plate_slide_side_and_back_success() -> None:
    for fn, target in ((pss.plate_slide_side_success, (-0.25, 0.6, 0.015)),
                       (psb.plate_slide_back_success, (0.05, 0.6, 0.02)),
                       (psbs.plate_slide_back_side_success, (0.15, 0.6, 0.02))):
        dz = 0.015 - target[2]
        for dx, ok in ((math.sqrt(0.0499 ** 2 - dz ** 2), True), (math.sqrt(0.0501 ** 2 - dz ** 2), False)):
            assert bool(fn(*t((target[0] + dx, target[1], 0.015), target))) is ok


# --------------------------------------------------------------------------------------------------------------
# scene facts (MuJoCo C)
# --------------------------------------------------------------------------------------------------------------
def _data(name: str) -> tuple[mujoco.MjModel, mujoco.MjData]:
    _, m = compiled_task(name)
    m = m.__copy__()
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("home").id)
    mujoco.mj_forward(m, d)
    return m, d


def _robot_contacts(m: mujoco.MjModel, d: mujoco.MjData, fixture: str | None = None) -> list[tuple[str, str]]:
    """(robot body, other body's top-level body) of the contacts between the robot and anything else (or the
    subtree of body ``fixture``)."""
    out = []
    for c in d.contact[:d.ncon]:
        b1, b2 = (int(m.geom_bodyid[g]) for g in (c.geom1, c.geom2))
        is_robot = [m.body(b).name.startswith(robot.PREFIX) for b in (b1, b2)]
        if is_robot[0] == is_robot[1]:
            continue
        mine, other = (b1, b2) if is_robot[0] else (b2, b1)
        root = m.body(int(m.body_rootid[other])).name
        if fixture is None or root == fixture:
            out.append((m.body(mine).name, root))
    return out


def test_wall_geometry_matches_the_xml() -> None:
    from mtbench.envs.metaworld.policies import _wall as policy_wall

    for name in ("reach_wall", "push_wall", "pick_place_wall"):
        m, d = _data(name)
        geoms = [g for g in range(m.ngeom) if m.geom_bodyid[g] == m.body("wall").id and m.geom_conaffinity[g]]
        assert geoms  # (Meta-World's visual and collision boxes both collide; they are the same box)
        for g in geoms:
            np.testing.assert_allclose(d.geom_xpos[g], _wall.WALL_XML_CENTRE, atol=1e-9)
            np.testing.assert_allclose(m.geom_size[g], _wall.WALL_HALF_SIZE, atol=1e-9)
    lo = np.subtract(_wall.WALL_XML_CENTRE, _wall.WALL_HALF_SIZE)
    hi = np.add(_wall.WALL_XML_CENTRE, _wall.WALL_HALF_SIZE)
    assert (policy_wall.WALL_LEFT_X, policy_wall.WALL_FRONT_Y, policy_wall.WALL_BACK_Y) == pytest.approx(
        (lo[0], lo[1], hi[1]))
    assert policy_wall.WALL_TOP_Z == pytest.approx(hi[2])


def test_hand_box_extent_used_by_the_policies() -> None:
    from mtbench.envs.metaworld.policies import _wall as policy_wall

    (pos, size, _), = robot.HAND_BOXES.values()
    assert (policy_wall.HAND_HALF_WIDTH, policy_wall.HAND_HALF_LENGTH) == pytest.approx(size[:2])
    assert policy_wall.HAND_ABOVE_TCP == pytest.approx(robot.TCP_OFFSET - (pos[2] + size[2]), abs=1e-3)


def test_plate_scene_joints_targets_and_no_table_contact() -> None:
    for name, module, target_from_goal in (("plate_slide", ps, ps.TARGET_FROM_GOAL),
                                           ("plate_slide_side", pss, pss.TARGET_FROM_GOAL),
                                           ("plate_slide_back", psb, (0.0, 0.0, 0.0)),
                                           ("plate_slide_back_side", psbs, (0.0, 0.0, 0.0))):
        m, d = _data(name)
        jx, jy = m.joint(_plate.SLIDE_X), m.joint(_plate.SLIDE_Y)
        assert tuple(m.jnt_range[jx.id]) == _plate.SLIDE_X_RANGE and tuple(m.jnt_range[jy.id]) == _plate.SLIDE_Y_RANGE
        # the observed plate point is the channel plus the slides
        d.qpos[jx.qposadr[0]], d.qpos[jy.qposadr[0]] = 0.07, -0.03
        mujoco.mj_forward(m, d)
        np.testing.assert_allclose(d.body(_plate.PLATE_BODY).xpos, np.add(_plate.CHANNEL, (0.07, -0.03, 0)), atol=1e-9)
        np.testing.assert_allclose(d.geom("puck").xpos, d.body(_plate.PLATE_BODY).xpos, atol=1e-9)
        assert not [c for c in d.contact[:d.ncon]]  # resting on the table without contacts, robot clear
        # every target of the reset range is reachable by the slides
        cls = TASKS[name]
        for corner in (cls.reset_low[3:], cls.reset_high[3:]):
            target = np.add(corner, target_from_goal)
            for k, rng in ((0, _plate.SLIDE_X_RANGE), (1, _plate.SLIDE_Y_RANGE)):
                assert _plate.CHANNEL[k] + rng[0] <= target[k] <= _plate.CHANNEL[k] + rng[1], (name, target)


@pytest.mark.parametrize("name, policy_module, axis, sign", [
    ("plate_slide", "plate_slide", 1, -1.0), ("plate_slide_side", "plate_slide_side", 0, 1.0)])
def test_plate_cabinet_crossbar_stops_the_arm_where_the_policy_stops(name, policy_module, axis, sign) -> None:
    """The Panda's last link hits the cabinet's front crossbar unless the TCP stays the policy's STOP_FROM_CABINET
    out from the cabinet (at the policy's pushing height; first contact 4 to 8 mm further in)."""
    import importlib

    pol = importlib.import_module(f"mtbench.envs.metaworld.policies.{policy_module}")
    from mtbench.envs.metaworld.policies import _plate as policy_plate

    touched = {}
    for extra in (0.0, 0.02):
        m, d = _data(name)
        cabinet = np.array([0.0, 0.85, -0.015]) if axis == 1 else np.array([-0.28, 0.6, -0.015])
        m.body(_plate.CABINET_BODY).pos = cabinet
        d.qpos[m.joint(_plate.SLIDE_X).qposadr[0]] = -0.25 if axis == 1 else 0.25  # the plate out of the way
        d.ctrl[m.actuator(robot.PREFIX + "gripper").id] = 1.0 if name == "plate_slide" else -1.0  # open / closed
        tcp = cabinet.copy()
        tcp[axis] += sign * (pol.STOP_FROM_CABINET - extra)
        tcp[2] = policy_plate.PUSH_Z
        for waypoint in (tcp + (0, 0, 0.25), tcp):
            d.mocap_pos[0] = waypoint + (0, 0, robot.TCP_OFFSET)
            for _ in range(400):
                mujoco.mj_step(m, d)
        touched[extra] = sorted({mine for mine, _ in _robot_contacts(m, d, _plate.CABINET_BODY)})
    assert touched == {0.0: [], 0.02: [robot.PREFIX + "link7"]}


def test_shelf_collisions_and_goal_site() -> None:
    m, d = _data("shelf_place")
    shelf = m.body("shelf").id
    colliding = sorted(tuple(np.round(m.geom_pos[g], 3)) for g in range(m.ngeom)
                       if m.body_rootid[m.geom_bodyid[g]] == shelf and (m.geom_contype[g] or m.geom_conaffinity[g]))
    # side walls, top and middle board (MTBench removed the bottom board, back wall and bottom block)
    assert colliding == sorted([(-0.11, 0.0, 0.32), (0.11, 0.0, 0.32), (0.0, 0.0, 0.65), (0.0, -0.015, 0.24)])
    np.testing.assert_allclose(d.site("goal").xpos - d.body("shelf").xpos, (0, 0, sp.GOAL_ABOVE_SHELF), atol=1e-9)
    # the hand at its start pose is clear of the nearest shelf position the reset can sample
    for x in (-0.1, 0.1):
        m.body("shelf").pos = (x, 0.8, 0.0)
        mujoco.mj_forward(m, d)
        assert not _robot_contacts(m, d)


def test_hole_geometry_and_resting_object() -> None:
    m, d = _data("pick_out_of_hole")
    rim = [g for g in range(m.ngeom) if m.geom_conaffinity[g] and m.body(m.geom_bodyid[g]).name == ""
           and m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX]
    top = {round(float(d.geom_xpos[g][2] + m.geom_size[g][2]), 4) for g in rim}
    assert top == {0.054}
    adr = m.joint("objjoint").qposadr[0]
    d.qpos[adr:adr + 3] = TASKS["pick_out_of_hole"].reset_low[:3]
    mujoco.mj_forward(m, d)
    others = {m.body(m.geom_bodyid[g]).name for c in d.contact[:d.ncon] for g in (c.geom1, c.geom2)} - {"obj"}
    assert others == {"tablelink"}  # the cylinder stands on the hole's floor, clear of the rim


# --------------------------------------------------------------------------------------------------------------
# one env with all ten tasks: reset placement and scripted success
# --------------------------------------------------------------------------------------------------------------
WORLDS = 10


@pytest.fixture(scope="module")
def rollout():
    from mtbench.envs import make_env
    from mtbench.envs.metaworld.policies import scripted_policy

    names = list(GROUP_C)
    env = make_env(names, num_envs=[WORLDS] * len(names), device="cpu", seed=0, rand=True,
                   random_start_progress=False)
    td = env.reset()
    at_reset = {task.name: (task, types.SimpleNamespace(
        goal=s.goal.clone(), obj_init=s.obj_init_pos.clone(), obj=s.obj_pos.clone(), xpos=s.sim.xpos.clone()))
        for task, s in env.blocks}
    policies = [scripted_policy(n) for n in env.task_names]
    for _ in range(env.max_episode_steps):
        obs = td["observation"][:, :env.state_dim]
        td["action"] = torch.cat([p(obs[sl]) for p, sl in zip(policies, env.slices)])
        _, td = env.step_and_maybe_reset(td)
    stats = env.pop_episode_stats()
    rates = dict(zip(env.task_names, (stats["success"] / stats["episodes"].clamp_min(1)).tolist()))
    return at_reset, rates, stats


@pytest.mark.slow
def test_reset_places_objects_fixtures_and_goals(rollout) -> None:
    at_reset, _, _ = rollout
    for name, (task, r) in at_reset.items():
        lo, hi = torch.tensor(task.reset_low), torch.tensor(task.reset_high)
        torch.testing.assert_close(r.obj, r.obj_init, atol=2e-3, rtol=0)  # observed object = its initial point
        if name.startswith("plate_slide"):
            plate = r.xpos[:, task.plate_body]
            torch.testing.assert_close(plate, r.obj_init, atol=1e-5, rtol=0)
            cabinet = r.xpos[:, task.cabinet_body]
            if name == "plate_slide_back_side":
                torch.testing.assert_close(cabinet, lo[:3].expand_as(cabinet))
                torch.testing.assert_close(plate, cabinet + torch.tensor([0.25, 0.0, 0.015]))
            else:
                g = (cabinet - torch.tensor({"plate_slide": ps.CABINET_FROM_GOAL, "plate_slide_side":
                                             pss.CABINET_FROM_GOAL, "plate_slide_back": psb.CABINET_FROM_GOAL}[name]))
                assert ((g >= lo[3:] - 1e-6) & (g <= hi[3:] + 1e-6)).all(), name
        else:
            assert ((r.obj_init >= lo[:3] - 1e-6) & (r.obj_init <= hi[:3] + 1e-6)).all(), name
            assert ((r.goal >= lo[3:] - 1e-6) & (r.goal <= hi[3:] + 1e-6)).all(), name
        if name == "shelf_place":
            torch.testing.assert_close(r.xpos[:, task.shelf_body], r.goal - torch.tensor([0.0, 0.0, 0.3]))
    # plate goals: MTBench's targets in front of the cabinet
    _, r = at_reset["plate_slide"]
    torch.testing.assert_close(r.goal, r.xpos[:, at_reset["plate_slide"][0].cabinet_body] + torch.tensor(
        [0.0, -0.025, 0.015]))


@pytest.mark.slow
def test_scripted_policies_solve_group_c(rollout) -> None:
    _, rates, stats = rollout
    print({t: f"{r:.0%}" for t, r in rates.items()})
    assert stats["episodes"].min() == WORLDS
    assert stats["unhealthy"].sum() == 0
    failing = {t: r for t, r in rates.items() if r < 0.8}
    assert not failing, f"scripted success below 80%: {failing}"
