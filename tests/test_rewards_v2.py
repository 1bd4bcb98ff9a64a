"""Known-answer tests of the ``reward_version="v2"`` rewards of our design (docs/metaworld.md, "reward_version v2"),
evaluated on states the tests construct (no physics), and of the v2 hooks of the task interface."""

from __future__ import annotations

import math
from types import SimpleNamespace

import pytest
import torch

from mtbench.envs.metaworld.registry import TASKS
from mtbench.envs.metaworld.reward_utils import grasp_carry_reward, polyline_distance, progress
from mtbench.envs.metaworld.tasks import (basketball, box_close, dial_turn, disassemble, peg_insert_side, pick_place_wall,
                                          push_wall, shelf_place)

V2_TASKS = {"basketball", "box_close", "dial_turn", "disassemble", "peg_insert_side", "pick_place_wall", "push_wall",
            "shelf_place"}
GRIP = torch.tensor([[0.0, 0.0, 0.0, 1.0]])
OPEN = torch.tensor([[0.0, 0.0, 0.0, -1.0]])


def p(*xyz: float) -> torch.Tensor:
    """One point ``[1, 3]``."""
    return torch.tensor([xyz])


def close(value: torch.Tensor, expected: float) -> None:
    torch.testing.assert_close(value, torch.tensor([expected]), atol=1e-5, rtol=0.0)


def test_the_tasks_with_a_v2_reward() -> None:
    assert {n for n, cls in TASKS.items() if cls.has_v2_reward()} == V2_TASKS


def test_progress_and_polyline_distance() -> None:
    d0 = torch.tensor([0.3])
    close(progress(torch.tensor([0.3]), d0, 0.05), 0.0)
    close(progress(torch.tensor([0.5]), d0, 0.05), 0.0)  # farther than at the start: 0, not negative
    close(progress(torch.tensor([0.175]), d0, 0.05), 0.5)
    close(progress(torch.tensor([0.01]), d0, 0.05), 1.0)
    points = [p(0.0, 0.0, 1.0), p(1.0, 0.0, 1.0)]
    here = p(0.0, 0.0, 0.0)
    close(polyline_distance(here, points, torch.tensor([0])), 2.0)  # up 1, across 1
    close(polyline_distance(here, points, torch.tensor([1])), math.sqrt(2.0))  # straight to the goal


def test_grasp_carry_reward_stages() -> None:
    obj, init_tcp = p(0.0, 0.6, 0.02), p(0.0, 0.6, 0.2)
    kw = dict(hold_radius=0.02, lift_height=0.1, place_radius=0.05)
    far, far0 = torch.tensor([0.3]), torch.tensor([0.3])
    # hand at its start: the long-tail reach is 0.1 at the start distance (its margin), nothing else pays
    close(grasp_carry_reward(OPEN, init_tcp, obj, obj, init_tcp, torch.zeros(1), far, far0, **kw), 0.1)
    # at the object, open, object not moved: reach only
    close(grasp_carry_reward(OPEN, obj, obj, obj, init_tcp, torch.zeros(1), far, far0, **kw), 1.0)
    # closing: + grip
    close(grasp_carry_reward(GRIP, obj, obj, obj, init_tcp, torch.zeros(1), far, far0, **kw), 2.0)
    # lifted by half the lift stage, carried half-way
    close(grasp_carry_reward(GRIP, obj, obj, obj, init_tcp, torch.tensor([0.05]), torch.tensor([0.175]), far0, **kw),
          2.0 + 0.5 + 2.5)
    # everything done: 8 (below the success reward, 10)
    close(grasp_carry_reward(GRIP, obj, obj, obj, init_tcp, torch.tensor([0.2]), torch.tensor([0.0]), far0, **kw), 8.0)
    # the object at the goal without the hand (e.g. pushed or thrown there) pays no lift or carry
    away = p(0.3, 0.6, 0.2)
    assert grasp_carry_reward(GRIP, away, obj, obj, init_tcp, torch.tensor([0.2]), torch.tensor([0.0]), far0,
                              **kw).item() < 1.0


def test_dial_turn_v2() -> None:
    axis = p(0.0, 0.75, 0.0)
    start, goal = p(0.0, 0.80, 0.0), p(0.0, 0.72, 0.03)
    init_tcp = p(0.0, 0.6, 0.2)
    at_bar = p(0.0, 0.80, dial_turn.V2_REACH_HEIGHT)
    close(dial_turn.dial_turn_reward_v2(at_bar, start, goal, start, init_tcp), 2.0)  # at the bar, not turned
    # turned half-way in chord: 2 * max(reach, 0.5) + 6 * 0.5
    d0 = (start - goal).norm().item()
    half = d0 - 0.5 * (d0 - dial_turn.TARGET_RADIUS)
    # the point of the dial's circle (radius 5 cm around the axis, table height) at chord distance ``half``
    a = torch.linspace(math.pi / 2, -math.pi / 2, 20001)
    circle = axis + 0.05 * torch.stack([a.cos(), a.sin(), torch.zeros_like(a)], dim=-1)
    turned = circle[((circle - goal).norm(dim=-1) - half).abs().argmin()][None]
    far_tcp = p(0.5, 0.4, 0.5)
    torch.testing.assert_close(dial_turn.dial_turn_reward_v2(far_tcp, turned, goal, start, init_tcp),
                               torch.tensor([1.0 + 3.0]), atol=1e-3, rtol=0.0)
    close(dial_turn.dial_turn_reward_v2(far_tcp, goal, goal, start, init_tcp), 8.0)  # at the goal: 8


def test_basketball_v2() -> None:
    ball0, goal, init_tcp = p(0.0, 0.65, 0.03), p(0.0, 0.8, 0.25), p(0.0, 0.6, 0.2)
    close(basketball.basketball_reward_v2(GRIP, ball0, ball0, goal, ball0, init_tcp), 2.0)  # at the ball, closing
    near_goal = p(0.0, 0.8 - basketball.TARGET_RADIUS, 0.25)  # held 8 cm in front of the hoop centre
    close(basketball.basketball_reward_v2(GRIP, near_goal, near_goal, goal, ball0, init_tcp), 8.0)


def test_box_close_v2_goes_over_the_walls() -> None:
    top0, goal, init_tcp = p(0.0, 0.47, box_close.TOP_LINK_REST_Z), p(0.0, 0.8, 0.133), p(0.0, 0.6, 0.2)
    lid = p(0.0, 0.47, box_close.TOP_LINK_REST_Z + box_close.LID_POINT)
    close(box_close.box_close_reward_v2(GRIP, top0, lid, lid, goal, top0, init_tcp), 2.0)
    # dragged 10 cm towards the box over the table: no carry progress (the path goes up first)
    dragged = p(0.0, 0.57, box_close.TOP_LINK_REST_Z)
    lid_dragged = dragged + torch.tensor([[0.0, 0.0, box_close.LID_POINT]])
    close(box_close.box_close_reward_v2(GRIP, dragged, lid_dragged, lid_dragged, goal, top0, init_tcp), 2.0)
    # lifted straight up to the carry height: lift stage done, and the carry has progressed by the climb
    up = p(0.0, 0.47, box_close.V2_CARRY_Z)
    lid_up = up + torch.tensor([[0.0, 0.0, box_close.LID_POINT]])
    climb = box_close.V2_CARRY_Z - box_close.TOP_LINK_REST_Z
    rest = math.hypot(0.33, box_close.V2_CARRY_Z - 0.133)
    expected = 3.0 + 5.0 * climb / (climb + rest - box_close.SUCCESS_RADIUS)
    torch.testing.assert_close(box_close.box_close_reward_v2(GRIP, up, lid_up, lid_up, goal, top0, init_tcp),
                               torch.tensor([expected]), atol=1e-4, rtol=0.0)
    over = goal + torch.tensor([[0.0, 0.0, box_close.SUCCESS_RADIUS]])
    lid_over = over + torch.tensor([[0.0, 0.0, box_close.LID_POINT]])
    close(box_close.box_close_reward_v2(GRIP, over, lid_over, lid_over, goal, top0, init_tcp), 8.0)


def test_disassemble_v2() -> None:
    handle0, init_tcp = p(0.05, 0.65, 0.025), p(0.0, 0.4, 0.2)
    goal = p(0.0, 0.65, 0.025 + 0.15)
    ring0 = p(0.0, 0.65, 0.025)
    close(disassemble.disassemble_reward_v2(GRIP, handle0, ring0, handle0, goal, handle0, init_tcp), 2.0)
    up = torch.tensor([[0.0, 0.0, 0.05]])  # a third of the way: lift 0.5, carry (0.15 - 0.10) / 0.10 = 0.5
    close(disassemble.disassemble_reward_v2(GRIP, handle0 + up, ring0 + up, handle0 + up, goal, handle0, init_tcp),
          2.0 + 0.5 + 2.5)
    up = torch.tensor([[0.0, 0.0, 0.1]])
    close(disassemble.disassemble_reward_v2(GRIP, handle0 + up, ring0 + up, handle0 + up, goal, handle0, init_tcp),
          8.0)


def test_wall_paths() -> None:
    puck0, goal, init_tcp = p(0.0, 0.62, 0.02), p(0.0, 0.88, 0.2), p(0.0, 0.6, 0.2)
    close(pick_place_wall.pick_place_wall_reward_v2(GRIP, puck0, puck0, goal, puck0, init_tcp), 2.0)
    # lifted to the crossing height at its start: the lift stage is done and the carry has gone the first leg
    up = p(0.0, 0.62, pick_place_wall.V2_OVER_Z)
    leg1 = pick_place_wall.V2_OVER_Z - 0.02
    rest = math.hypot(0.87 - 0.62, 0.2 - pick_place_wall.V2_OVER_Z) + (0.88 - 0.87)  # over the wall, then down
    expected = 3.0 + 5.0 * leg1 / (leg1 + rest - pick_place_wall.TARGET_RADIUS)
    torch.testing.assert_close(pick_place_wall.pick_place_wall_reward_v2(GRIP, up, up, goal, puck0, init_tcp),
                               torch.tensor([expected]), atol=1e-4, rtol=0.0)
    # held at the goal: 8
    close(pick_place_wall.pick_place_wall_reward_v2(GRIP, goal, goal, goal, puck0, init_tcp), 8.0)
    # push_wall: the lane beside the wall's end is stage 1, anything past the wall stage 2
    lane = p(push_wall.V2_LANE_X, 0.7, 0.03)
    assert push_wall.wall_stage(lane, lane[:, 0] <= push_wall.V2_IN_LANE).item() == 1
    assert push_wall.wall_stage(puck0, puck0[:, 0] <= push_wall.V2_IN_LANE).item() == 0
    behind = p(0.0, 0.8, 0.02)
    assert push_wall.wall_stage(behind, behind[:, 0] <= push_wall.V2_IN_LANE).item() == 2
    table_goal = p(0.0, 0.88, 0.02)
    # at the goal on the table: all but the lift stage (the puck is carried 1 cm up: then 8)
    close(push_wall.push_wall_reward_v2(GRIP, table_goal, table_goal, table_goal, puck0, init_tcp), 7.0)
    carried = table_goal + torch.tensor([[0.0, 0.0, push_wall.V2_LIFT]])
    close(push_wall.push_wall_reward_v2(GRIP, carried, carried, table_goal, puck0, init_tcp), 8.0)
    # pushing the puck straight at the wall (no lane) earns no carry progress
    at_wall = p(0.0, 0.715, 0.02)
    assert push_wall.push_wall_reward_v2(OPEN, at_wall, at_wall, table_goal, puck0, init_tcp).item() <= 1.0 + 1e-6


def test_shelf_place_v2() -> None:
    block0, goal, init_tcp = p(0.0, 0.55, 0.02), p(0.05, 0.85, 0.3), p(0.0, 0.5, 0.2)
    close(shelf_place.shelf_place_reward_v2(GRIP, block0, block0, goal, block0, init_tcp), 2.0)
    # in front of the shelf at the goal's height: lift done; the carry has done all but the last 16 cm
    front = goal - torch.tensor([[0.0, shelf_place.V2_FRONT, 0.0]])
    total = (front - block0).norm().item() + shelf_place.V2_FRONT
    expected = 3.0 + 5.0 * (total - shelf_place.V2_FRONT) / (total - shelf_place.TARGET_RADIUS)
    torch.testing.assert_close(shelf_place.shelf_place_reward_v2(GRIP, front, front, goal, block0, init_tcp),
                               torch.tensor([expected]), atol=1e-4, rtol=0.0)
    # under the board (below the goal's height, past the front edge) counts as the long way round
    under = p(0.05, 0.85, 0.15)
    assert (shelf_place.shelf_place_reward_v2(GRIP, under, under, goal, block0, init_tcp)
            < shelf_place.shelf_place_reward_v2(GRIP, front, front, goal, block0, init_tcp)).item()
    close(shelf_place.shelf_place_reward_v2(GRIP, goal, goal, goal, block0, init_tcp), 8.0)


def test_peg_insert_side_v2() -> None:
    peg0, goal, init_tcp = p(0.1, 0.6, 0.02), p(-0.27, 0.6, 0.13), p(0.0, 0.6, 0.2)
    grasp0 = peg0 + torch.tensor([peg_insert_side.GRASP_FROM_BODY])
    head0 = peg0 + torch.tensor([[-0.1, 0.0, 0.0]])
    close(peg_insert_side.peg_insert_side_reward_v2(GRIP, grasp0, head0, grasp0, goal, peg0, head0, init_tcp), 2.0)
    # head lined up at the entry point: lift done, carry all but the entry leg
    entry = goal + torch.tensor([[peg_insert_side.V2_ENTRY, 0.0, 0.0]])
    grasp = entry + (grasp0 - head0)
    total = (entry - head0).norm().item() + peg_insert_side.V2_ENTRY
    expected = 3.0 + 5.0 * (total - peg_insert_side.V2_ENTRY) / (total - peg_insert_side.TARGET_RADIUS)
    torch.testing.assert_close(
        peg_insert_side.peg_insert_side_reward_v2(GRIP, grasp, entry, grasp, goal, peg0, head0, init_tcp),
        torch.tensor([expected]), atol=1e-4, rtol=0.0)
    inserted = goal + (grasp0 - head0)
    close(peg_insert_side.peg_insert_side_reward_v2(GRIP, inserted, goal, inserted, goal, peg0, head0, init_tcp),
          8.0)


def test_pick_place_wall_v2_pays_10_on_every_success_step() -> None:
    """v2 pays the constant 10 on success steps (the paper version pays ~0.05 where the puck is 5-8 cm away)."""
    task_cls = TASKS["pick_place_wall"]
    task = task_cls.__new__(task_cls)
    state = SimpleNamespace(tcp=torch.zeros(3, 3), n=3)
    torch.testing.assert_close(task.success_reward_fn("v2")(state, torch.zeros(3, 4)), torch.full((3,), 10.0))
    assert task.success_reward_fn("paper") == task.success_reward


def test_unknown_reward_version_names_the_choices() -> None:
    task_cls = TASKS["reach"]
    with pytest.raises(ValueError, match="reward_version 'v3'.*valid choices.*paper.*v2"):
        task_cls.dense_reward(task_cls.__new__(task_cls), "v3")
    with pytest.raises(ValueError, match="reward_version 'v3'.*valid choices.*paper.*v2"):
        task_cls.success_reward_fn(task_cls.__new__(task_cls), "v3")
