"""Lever pull: swing a lever from pointing at the robot up to vertical (MTBench ``lever_pull``, Meta-World
``lever-pull-v3``)."""

from __future__ import annotations

import math

import mujoco
import torch

from ..reward_utils import hamacher_product, reach_progress_reward, tolerance
from ..scene import STIFF_LIMIT_SOLIMP, STIFF_LIMIT_SOLREF, SceneSpec
from ..task import MetaWorldTask, Objects, TaskState, offset

LEVER_RADIUS = 0.2
HINGE = "LeverAxis"
# MTBench's lever asset turns the hinge the other way: range [-1.57, 0] (Meta-World v3: [0, 1.57], which swings the
# lever *down* towards the table, so that its success rule, -angle within 7.5 degrees of 90, cannot be met)
HINGE_RANGE = (-1.57, 0.0)
# the lever link weighs 4 g: MuJoCo softens a contact by the bodies' inverse weights, so the hand sank into the ball;
# an armature on the hinge (1.25 kg at the 20 cm radius) makes contacts with it as stiff as with other objects
HINGE_ARMATURE = 0.05
# MTBench's shaping in its frame: offset (0, 0, .07), scale (1, 4, 4) over (x_mtb, y_mtb, z) = our (y, x, z)
SHOULDER_OFFSET = (0.0, 0.0, 0.07)
SHOULDER_SCALE = (4.0, 1.0, 4.0)
READY_RADIUS = 0.02
IN_PLACE_RADIUS = 0.04
SUCCESS_TOL = math.pi / 24.0
GOAL_OFFSET = (0.12, 0.0, 0.25 + LEVER_RADIUS)  # MTBench (0, -.12, .45) mapped; Meta-World's target


def scaled_norm(x: torch.Tensor, scale: tuple[float, float, float]) -> torch.Tensor:
    """``‖x · scale‖`` over the last axis (``[..., 3]``)."""
    return torch.stack([x[..., 0] * scale[0], x[..., 1] * scale[1], x[..., 2] * scale[2]], dim=-1).norm(dim=-1)


def lever_pull_reward(tcp: torch.Tensor, lever: torch.Tensor, goal: torch.Tensor, lever_init: torch.Tensor,
                      init_tcp: torch.Tensor) -> torch.Tensor:
    """MTBench's ``lever_pull`` dense term before its ``* .01`` (``[n]``, in [0, 1])::

        ready_to_lift = tol(‖(tcp + (0, 0, .07) − lever)·(4, 1, 4)‖, (0, .02),
                            margin ‖(tcp_init + (0, 0, .07) − lever_init)·(4, 1, 4)‖, long_tail)
        in_place      = tol(‖lever − goal‖, (0, .04), margin ‖lever_init − goal‖, long_tail)
        r = hamacher(ready_to_lift, in_place)
    """
    shoulder_to_lever = scaled_norm(offset(tcp, *SHOULDER_OFFSET) - lever, SHOULDER_SCALE)
    shoulder_to_lever_init = scaled_norm(offset(init_tcp, *SHOULDER_OFFSET) - lever_init, SHOULDER_SCALE)
    ready_to_lift = tolerance(shoulder_to_lever, bounds=(0.0, READY_RADIUS), margin=shoulder_to_lever_init,
                              sigmoid="long_tail")
    in_place = tolerance((lever - goal).norm(dim=-1), bounds=(0.0, IN_PLACE_RADIUS),
                         margin=(lever_init - goal).norm(dim=-1), sigmoid="long_tail")
    return hamacher_product(ready_to_lift, in_place)


def lever_pull_reward_v2(tcp: torch.Tensor, lever: torch.Tensor, lever_init: torch.Tensor, init_tcp: torch.Tensor,
                         hinge_angle: torch.Tensor) -> torch.Tensor:
    """``reward_version="v2"`` dense reward ``[n]`` (0..8), since ``v2-2026-11-28g``::

        reach = tol(‖(tcp + (0, 0, .07) − lever)·(4, 1, 4)‖, (0, .02),
                    margin max(‖(tcp_init + (0, 0, .07) − lever_init)·(4, 1, 4)‖ − .02, .05), long_tail)
        lift  = progress(π/2 + angle, π/2, π/24)   # linear in the angle: 0 at rest, 1 at the success angle
        r = 2·max(reach, lift) + 6·lift

    The paper-era reach target (the hand under the ball) and the angle of the success rule, composed as
    dial_turn's and door_close's v2 rewards (:func:`~..reward_utils.reach_progress_reward`). Why: the paper-era
    reward is the Hamacher product of reaching with a long-tail ``in_place`` that is ~0.1 until the lever moves, so
    before the lever moves it pays 0.06 per step at the hand's start and 0.13 with the hand under the ball, and a
    lever lifted by 17 degrees 0.19: reaching and starting the lift are barely paid. One of six MT50-rand runs
    (revision ``v2-2026-11-28f``, seed 1) never found the lever: a return of ~17 per episode from ~20 M frames to
    200 M, the hand 13.5 cm from the ball, 0% success (96-100% in four of the other five runs;
    docs/results/mt50_rand_ppo.md).
    """
    shoulder_to_lever = scaled_norm(offset(tcp, *SHOULDER_OFFSET) - lever, SHOULDER_SCALE)
    shoulder_to_lever_init = scaled_norm(offset(init_tcp, *SHOULDER_OFFSET) - lever_init, SHOULDER_SCALE)
    to_vertical = math.pi / 2.0 + hinge_angle  # the angle still to lift (the hinge turns negative to lift)
    return reach_progress_reward(shoulder_to_lever, shoulder_to_lever_init, READY_RADIUS, to_vertical,
                                 torch.full_like(to_vertical, math.pi / 2.0), SUCCESS_TOL)


def lever_pull_success(hinge_angle: torch.Tensor) -> torch.Tensor:
    """MTBench: ``|−angle − π/2| ≤ π/24`` (``[n]`` bool; ``angle`` in [-1.57, 0], -π/2 = vertical)."""
    return (-hinge_angle - math.pi / 2.0).abs() <= SUCCESS_TOL


class LeverPull(MetaWorldTask):
    """Swing the lever up by 90 degrees (Meta-World's ``sawyer_lever_pull.xml``).

    * Scene: a fixed lever base ``lever`` placed per world (batched ``body_pos``); the lever ``lever_link1`` turns
      about the x axis (``LeverAxis``) at ``base + (0.12, 0, 0.25)``: a 20 cm rod along -y ending in a ball (radius
      3 cm) whose centre is the ``leverStart`` site. ``edit_spec`` gives the hinge MTBench's range [-1.57, 0] (see
      ``HINGE_RANGE``; negative angles lift the ball), a stiff limit and an armature (``HINGE_ARMATURE``).
    * Reset: base ~ U([-0.1, 0.7, 0], [0.1, 0.8, 0]) (MTBench x_mtb in [.1, .2], y_mtb in [-.1, .1] mapped; also
      Meta-World's range), hinge at 0 (MTBench resets it to its upper limit). Goal = base + (0.12, 0, 0.45): the
      ball with the lever vertical. ``obj_init_pos`` = the base position (MTBench); the ball's position at reset
      (MTBench's ``lever_pos_init``) is recorded in the ``lever_init`` buffer.
    * Observation: object 1 = the ``leverStart`` site (ball centre) with the lever's orientation.
    * Dense reward: :func:`lever_pull_reward` (``dense_scale`` 0.01); ``reward_version="v2"``:
      :func:`lever_pull_reward_v2` (reach under the ball, then linear pay per radian lifted). MTBench's offset
      (0, 0, .07) and scale (1, 4, 4) in its frame are (0, 0, 0.07) and (4, 1, 4) here (Meta-World: offset
      (0, 0.055, 0.07), same scale).
    * Success (MTBench): hinge within 7.5 degrees of vertical (``angle <= -1.4399``).
    * Differences: MTBench captured ``lever_pos_init`` once, at the first observation of the run, and kept it for
      every later episode (stale after a "-rand" reset); it is recorded at every reset here, as Meta-World does.
      The hand starts with its TCP at (0, 0.4, 0.2) (Meta-World's ``hand_init_pos``).
    """

    name = "lever_pull"
    mtbench_id = 27
    description = "Rotate a lever by ninety degrees with the gripper."
    scene = SceneSpec("sawyer_lever_pull.xml", hand_init_pos=(0.0, 0.4, 0.2))
    reset_low = (-0.1, 0.7, 0.0)
    reset_high = (0.1, 0.8, 0.0)
    buffers = {"lever_init": (3,)}

    @classmethod
    def edit_spec(cls, spec: mujoco.MjSpec) -> None:
        """MTBench's hinge range, a stiff limit and an armature on the hinge."""
        joint = spec.joint(HINGE)
        if joint is None:
            raise ValueError(f"lever_pull: no joint {HINGE!r} in the scene")
        joint.range = list(HINGE_RANGE)
        joint.solref_limit = list(STIFF_LIMIT_SOLREF)
        joint.solimp_limit = list(STIFF_LIMIT_SOLIMP)
        joint.armature = HINGE_ARMATURE

    def bind(self, model) -> None:
        self.base_body = self.body_id("lever")
        self.lever_body = self.body_id("lever_link1")
        self.hinge_qpos = self.joint_qposadr(HINGE)
        self.ball_site = self.site_id("leverStart")

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        base = vec[:, :3]
        self.set_body_pos(s.sim, self.base_body, base, mask)
        self.set_joint(s.sim, self.hinge_qpos, 0.0, mask)
        self.masked_set(s.obj_init_pos, base, mask)
        self.masked_set(s.goal, offset(base, *GOAL_OFFSET), mask)

    def after_reset(self, s: TaskState, mask: torch.Tensor) -> None:
        self.masked_set(s.buffers["lever_init"], s.obj_pos, mask)

    def objects(self, s: TaskState) -> Objects:
        return Objects(s.sim.site_xpos[:, self.ball_site], s.sim.xquat[:, self.lever_body])

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return lever_pull_reward(s.tcp, s.obj_pos, s.goal, s.buffers["lever_init"], s.init_tcp)

    def reward_v2(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return lever_pull_reward_v2(s.tcp, s.obj_pos, s.buffers["lever_init"], s.init_tcp,
                                    s.sim.qpos[:, self.hinge_qpos])

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return lever_pull_success(s.sim.qpos[:, self.hinge_qpos])
