"""Hammer: pick up a hammer and drive a nail into a block with it (MTBench ``hammer``, Meta-World ``hammer-v3``)."""

from __future__ import annotations

import torch

from ..reward_utils import gripper_caging_reward, tolerance
from ..scene import SceneSpec
from ..task import MetaWorldTask, Objects, TaskState, unit_quat

HANDLE_LENGTH = 0.14  # MTBench's HAMMER_HANDLE_LENGTH
# MTBench's hammer head point: hammer + (.07, -.16, 0) in its frame, world-fixed = (0.16, 0.07, 0) here: the centre
# of the head's +y striking face (Meta-World uses (0.16, 0.06, 0))
HEAD_OFFSET = (0.16, 0.07, 0.0)
LIFTED_HEIGHT = 0.04  # MTBench: head z > table + .04 ("changed from +.02")
NAIL_DRIVEN = 0.09  # nail joint position counted as driven in (MTBench, Meta-World)
SUCCESS_DENSE = 5.0  # MTBench: success also needs its dense reward (x .01) above .05
HAMMER_Z = 0.05  # MTBench places the hammer 5 cm above the table (hammer_height / 2); it drops onto the table


def hammer_head(hammer: torch.Tensor) -> torch.Tensor:
    """MTBench's head point ``[n, 3]``: the hammer position shifted by ``HEAD_OFFSET`` (not rotated with it)."""
    return torch.stack([hammer[:, 0] + HEAD_OFFSET[0], hammer[:, 1] + HEAD_OFFSET[1], hammer[:, 2] + HEAD_OFFSET[2]],
                       dim=-1)


def hammer_reward(action: torch.Tensor, hammer: torch.Tensor, goal: torch.Tensor, hammer_init: torch.Tensor,
                  tcp: torch.Tensor, left_pad: torch.Tensor, right_pad: torch.Tensor,
                  init_tcp: torch.Tensor) -> torch.Tensor:
    """MTBench's ``hammer`` dense term before its ``* .01`` (``[n]``, in [0, 8])::

        head     = hammer + (0.16, 0.07, 0)
        threshed = hammer with x replaced by tcp_x where |hammer_x − tcp_x| < 0.07 (half the handle)
        grab     = caging(threshed; obj_radius .015, pad_success_thresh .02, object_reach_radius .01,
                          xz_thresh .01, medium density; obj_init = hammer_init)
        in_place = 0.1·[head_z > 0.04] + 0.9·tol(‖goal − head‖, (0, .02), margin .2, long_tail)
        r = 2·grab + 6·in_place

    (MTBench computes a hammer-orientation term but does not use it; Meta-World multiplies by it.)
    """
    head = hammer_head(hammer)
    near = (hammer[:, 0] - tcp[:, 0]).abs() < HANDLE_LENGTH / 2.0
    threshed = torch.stack([torch.where(near, tcp[:, 0], hammer[:, 0]), hammer[:, 1], hammer[:, 2]], dim=-1)
    grab = gripper_caging_reward(
        action, threshed, obj_radius=0.015, pad_success_thresh=0.02, object_reach_radius=0.01, xz_thresh=0.01,
        left_pad=left_pad, right_pad=right_pad, tcp_center=tcp, obj_init_pos=hammer_init, init_tcp=init_tcp,
        medium_density=True,
    )
    lifted = (head[:, 2] > LIFTED_HEIGHT).to(hammer.dtype)
    in_place = 0.1 * lifted + 0.9 * tolerance((goal - head).norm(dim=-1), bounds=(0.0, 0.02), margin=0.2,
                                              sigmoid="long_tail")
    return 2.0 * grab + 6.0 * in_place


def hammer_success(nail: torch.Tensor, dense: torch.Tensor) -> torch.Tensor:
    """MTBench: nail joint > 0.09 and the dense term (before ``* .01``) > 5 (``[n]`` bool)."""
    return (nail > NAIL_DRIVEN) & (dense > SUCCESS_DENSE)


class Hammer(MetaWorldTask):
    """Grasp the hammer and drive the nail into the block (Meta-World's ``sawyer_hammer.xml``).

    * Scene: the hammer (``hammerbody``, free joint; 1.1 kg, handle along +x with the head at x = 0.16) and the fixed
      block ``box`` at (0.24, 0.85, 0) (MTBench: (.25, -.24) in its frame, also fixed) whose nail (``nail_link``,
      slide ``NailSlideJoint`` along +y, range [0, 0.1]) sticks out towards the robot at height 0.11.
    * Reset: hammer ~ U([-0.1, 0.4, 0.05], [0.1, 0.5, 0.05]), unrotated (MTBench x_mtb in [-.2, -.1], y_mtb in
      [-.1, .1] at table + .05 with its "laid down" orientation, mapped; Meta-World's x-y range, at z = 0), nail
      out (0). Goal = the block's ``goal`` site, box + (0, -0.11, 0.11) (MTBench's ``target`` body, same place).
      ``obj_init_pos`` = the hammer's reset position.
    * Observation: object 1 = the hammer body (position, orientation); object 2 = the ``nail_link`` body (MTBench;
      Meta-World reports the ``nailHead`` site).
    * Dense reward: :func:`hammer_reward` (``dense_scale`` 0.01); success pays 20 (MTBench's hammer bonus).
    * Success (MTBench): nail driven in beyond 9 cm *and* dense term > 5 (MTBench's guard against knocking the nail
      in without the hammer: the head must be near the target, e.g. 7 cm with the hammer held, or lifted).
    * Differences: the hand starts with its TCP at (0, 0.4, 0.2) (Meta-World's ``hand_init_pos``); ``init_tcp`` is
      recorded at every reset (MTBench: once per run).
    """

    name = "hammer"
    mtbench_id = 21
    description = "Pick up a hammer and hit a nail so it is driven into the wall."
    scene = SceneSpec("sawyer_hammer.xml", hand_init_pos=(0.0, 0.4, 0.2))
    reset_low = (-0.1, 0.4, HAMMER_Z)
    reset_high = (0.1, 0.5, HAMMER_Z)
    success_bonus = 20.0

    def bind(self, model) -> None:
        body = model.body("hammerbody")
        self.hammer_qpos = int(model.jnt_qposadr[int(body.jntadr[0])])
        self.hammer_body = self.body_id("hammer")
        self.nail_body = self.body_id("nail_link")
        self.nail_qpos = self.joint_qposadr("NailSlideJoint")
        self.goal_site = self.site_id("goal")

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        pos = vec[:, :3]
        self.set_free_body(s.sim, self.hammer_qpos, pos, mask, unit_quat(pos))
        self.set_joint(s.sim, self.nail_qpos, 0.0, mask)
        self.masked_set(s.obj_init_pos, pos, mask)

    def after_reset(self, s: TaskState, mask: torch.Tensor) -> None:
        self.masked_set(s.goal, s.sim.site_xpos[:, self.goal_site], mask)

    def objects(self, s: TaskState) -> Objects:
        return Objects(s.sim.xpos[:, self.hammer_body], s.sim.xquat[:, self.hammer_body],
                       s.sim.xpos[:, self.nail_body], s.sim.xquat[:, self.nail_body])

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return hammer_reward(action, s.obj_pos, s.goal, s.obj_init_pos, s.tcp, s.left_pad, s.right_pad, s.init_tcp)

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return hammer_success(s.sim.qpos[:, self.nail_qpos], self.reward(s, action))
