"""Dial turn: turn a dial on the table by more than 100 degrees (Meta-World ``dial-turn-v3``, MTBench id 11)."""

from __future__ import annotations

import math

import mujoco
import torch

from ..reward_utils import hamacher_product, mtbench_gripper_openness, reach_progress_reward, tolerance
from ..scene import SceneSpec
from ..task import MetaWorldTask, Objects, TaskState, offset

DIAL_BODY = "dial"
DIAL_JOINT = "knob_Joint_1"
TIP_SITE = "dial_tip"
DIAL_RADIUS = 0.05  # Meta-World / MTBench: the observed point is 5 cm from the dial's axis
START_ANGLE = 3.14  # the joint's upper limit (see DialTurn)
GOAL_FROM_DIAL = (0.0, -0.03, 0.03)  # MTBench: obj_init_pos + (-.03, 0, .03) in its frame
PUSH_FROM_TIP = (0.05, 0.02, 0.09)  # MTBench: obj + (.02, -.05, .09) in its frame (= Meta-World's offset)
TARGET_RADIUS = 0.06  # MTBench ("changed from .07")
REACH_RADIUS = 0.005


def dial_turn_reward(tcp: torch.Tensor, obj: torch.Tensor, goal: torch.Tensor, obj_start: torch.Tensor,
                     init_tcp: torch.Tensor, tcp_closed: torch.Tensor) -> torch.Tensor:
    """MTBench ``dial_turn`` dense term before its ``* .01`` (``[n]``)::

        push     = obj + (0.05, 0.02, 0.09)                      # the point the hand should reach
        in_place = tol(‖obj − goal‖, (0, .06), margin |‖obj_start − goal‖ − .06|, long_tail)
        reach    = H(tol(‖push − tcp‖, (0, .005), margin |‖obj_start − init_tcp‖ − .005|, gaussian), tcp_closed)
        r = H(reach, in_place)

    ``obj_start`` is MTBench's ``dial_push_position_init``: the observed point at the start, *without* the push
    offset (Meta-World's ``dial_push_position`` includes it).
    """
    push = offset(obj, *PUSH_FROM_TIP)
    in_place = tolerance((obj - goal).norm(dim=-1), bounds=(0.0, TARGET_RADIUS),
                         margin=((obj_start - goal).norm(dim=-1) - TARGET_RADIUS).abs(), sigmoid="long_tail")
    reach = tolerance((push - tcp).norm(dim=-1), bounds=(0.0, REACH_RADIUS),
                      margin=((obj_start - init_tcp).norm(dim=-1) - REACH_RADIUS).abs(), sigmoid="gaussian")
    reach = hamacher_product(reach, tcp_closed)
    return hamacher_product(reach, in_place)


V2_REACH_HEIGHT = 0.05  # v2: the fingers work at the bar's height (the scripted policy's TCP height: 5 cm)
V2_REACH_RADIUS = 0.03  # v2: TCP within 3 cm of the point above the bar's end counts as at the bar


def dial_turn_reward_v2(tcp: torch.Tensor, obj: torch.Tensor, goal: torch.Tensor, obj_start: torch.Tensor,
                        init_tcp: torch.Tensor) -> torch.Tensor:
    """``reward_version="v2"`` dense reward ``[n]`` (0..8)::

        at_bar = obj + (0, 0, 0.05)                            # the bar's end, at the fingers' working height
        reach  = tolerance(‖tcp − at_bar‖, (0, .03), margin=‖init_tcp − at_bar_start‖, long_tail)
        turn   = progress(‖obj − goal‖, ‖obj_start − goal‖, .06)   # linear in the chord to the goal, 1 at success
        r = 2·max(reach, turn) + 6·turn

    Why: the paper-era reward multiplies reaching (a 5 mm Gaussian, times a closed gripper) with the turn's
    long-tail term, which is 0.1 until the dial has turned, so it pays at most ~0.1 per step before the dial moves
    and the turn itself is paid only near the goal. Here reaching the bar pays up to 2 on its own and every
    radian of turn pays the same (6 over the 1.81 rad that success needs); ``max(reach, turn)`` keeps the reach
    term once the dial turns, so that leaving the bar while turning costs nothing.
    """
    at_bar = offset(obj, 0.0, 0.0, V2_REACH_HEIGHT)
    d0 = (init_tcp - offset(obj_start, 0.0, 0.0, V2_REACH_HEIGHT)).norm(dim=-1)
    return reach_progress_reward((tcp - at_bar).norm(dim=-1), d0, V2_REACH_RADIUS,
                                 (obj - goal).norm(dim=-1), (obj_start - goal).norm(dim=-1), TARGET_RADIUS)


def dial_turn_success(obj: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """MTBench: ``‖obj − goal‖ <= 0.06``: the dial turned by at least 103.5 degrees (``[n]`` bool)."""
    return (obj - goal).norm(dim=-1) <= TARGET_RADIUS


def dial_angle_for_success() -> float:
    """Smallest turn (rad) from the start that satisfies the success rule. The goal is 0.03 from the axis on the side
    opposite the start direction and 0.03 up, so with the observed point at radius r turned by ``turn``:
    ``‖obj − goal‖² = r² + 2·0.03² − 2·0.03·r·cos(π − turn)``, which is ``<= 0.06²`` for
    ``cos(π − turn) >= (r² + 2·0.03² − 0.06²) / (2·0.03·r)``."""
    c = (DIAL_RADIUS**2 + 2 * 0.03**2 - TARGET_RADIUS**2) / (2 * 0.03 * DIAL_RADIUS)
    return math.pi - math.acos(c)


class DialTurn(MetaWorldTask):
    """Turn the dial until its observed point is within 6 cm of the goal.

    * Scene: Meta-World ``sawyer_dial.xml``: body ``dial`` (world-fixed, placed per world) with a knob on the hinge
      ``knob_Joint_1`` (vertical axis, range [-3.14, 3.14]): a disc (radius 5 cm, 3.6 cm high) carrying a bar
      (9.2 x 3 x 3 cm, 3.6 .. 6.6 cm above the table) along the knob's local y axis. Hand starts at Meta-World's
      (0, 0.6, 0.2).
    * Reset (MTBench ``obj_low/obj_high`` (.1, -.1) .. (.2, .1) on the table, mapped ``x = -y_mtb``,
      ``y = x_mtb + 0.6``, ``z = z_mtb - 1.027``): dial at x ~ U[-0.1, 0.1], y ~ U[0.7, 0.8], z = 0 (the same as
      Meta-World v3).
    * Observation: object 1 = the point 5 cm from the axis along the knob's -y direction at table height (Meta-World's
      ``_get_pos_objects``: ``dial + 0.05 (sin q, -cos q, 0)``; site ``dial_tip``), the dial body's quaternion.
      ``obj_init_pos`` = the dial body position.
    * MTBench's start and goal, mapped: MTBench starts its joint at the lower limit (-3.14) and observes
      ``dial + 0.05 (-cos q, sin q, 0)`` in its frame, i.e. the point starts on the far side (away from the robot),
      and its goal is ``dial + (-.03, 0, .03)``: 3 cm towards the robot and 3 cm up, on the side opposite the start.
      Here the joint starts at its upper limit (3.14), where the observed point is on the far side, and the goal
      is ``dial + (0, -0.03, 0.03)``. MTBench's formula mirrors its own geometry (the point turns the other way
      than the knob), so its joint turns counter-clockwise (seen from above) while ours turns clockwise; every
      reward and success value is the same function of the turned angle. Success needs a turn of at least
      :func:`dial_angle_for_success` (1.81 rad; Meta-World: 1.37 rad with radius 0.07).
    * Dense reward: :func:`dial_turn_reward` (MTBench before ``* .01``; closedness ``1 − ‖pads‖ / 0.095``).
      MTBench's ``dial_push_position_init`` (the observed point at the start, buffer ``obj_start``) is measured at
      every reset (MTBench: once, at the first observation of the run, like ``init_tcp``).
    * ``reward_version="v2"``: :func:`dial_turn_reward_v2` (reach the bar, then linear pay per radian turned).
    * Success: ``‖obj − goal‖ <= 0.06``; success steps pay 10.
    * Differences: ``init_tcp`` and ``obj_start`` per reset; Meta-World's ``tolerance`` inside the bounds (MTBench's
      returns 0 there when the margin is positive).
    """

    name = "dial_turn"
    mtbench_id = 11
    description = "Turn a dial on the table to the goal angle."
    scene = SceneSpec("sawyer_dial.xml", hand_init_pos=(0.0, 0.6, 0.2))
    reset_low = (-0.1, 0.7, 0.0)
    reset_high = (0.1, 0.8, 0.0)
    buffers = {"obj_start": (3,)}

    @classmethod
    def edit_spec(cls, spec: mujoco.MjSpec) -> None:
        """The site ``dial_tip`` on the knob (the body of ``knob_Joint_1``) at the observed point."""
        knob = spec.joint(DIAL_JOINT).parent
        knob.add_site(name=TIP_SITE, pos=[0.0, -DIAL_RADIUS, 0.0], size=[0.005, 0.005, 0.005], group=4)

    def bind(self, model) -> None:
        self.dial_body = self.body_id(DIAL_BODY)
        self.dial_qpos = self.joint_qposadr(DIAL_JOINT)
        self.tip_site = self.site_id(TIP_SITE)

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        dial = vec[:, :3]
        self.set_body_pos(s.sim, self.dial_body, dial, mask)
        self.set_joint(s.sim, self.dial_qpos, START_ANGLE, mask)
        self.masked_set(s.obj_init_pos, dial, mask)
        self.masked_set(s.goal, offset(dial, *GOAL_FROM_DIAL), mask)

    def after_reset(self, s: TaskState, mask: torch.Tensor) -> None:
        self.masked_set(s.buffers["obj_start"], s.obj_pos, mask)

    def objects(self, s: TaskState) -> Objects:
        return Objects(s.sim.site_xpos[:, self.tip_site], s.sim.xquat[:, self.dial_body])

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        tcp_closed = 1.0 - mtbench_gripper_openness(s.left_pad, s.right_pad)
        return dial_turn_reward(s.tcp, s.obj_pos, s.goal, s.buffers["obj_start"], s.init_tcp, tcp_closed)

    def reward_v2(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return dial_turn_reward_v2(s.tcp, s.obj_pos, s.goal, s.buffers["obj_start"], s.init_tcp)

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return dial_turn_success(s.obj_pos, s.goal)
