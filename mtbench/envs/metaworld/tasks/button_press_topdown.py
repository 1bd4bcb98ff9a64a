"""Button press top-down: push a red button on top of a box straight down (Meta-World ``button-press-topdown-v3``).

Scene: Meta-World's ``sawyer_button_press_topdown.xml``. The button box is a fixed body; its position is sampled
per world (batched ``body_pos``). The button is a slide joint (``btnbox_joint``, 6 cm of travel, a weak spring
holding it up) whose body moves straight down when pressed.

Observation (object part): the button body position plus 0.193 m in z (Meta-World's ``_get_pos_objects``; this is
the top face of the button cap, 0.308 m above the table when unpressed) and the button body quaternion (wxyz).
Goal (obs[36:39]): Meta-World's target, the ``hole`` site of the box (0.215 m above the table, 9.3 cm below the
unpressed button top).

Reward: Meta-World v2 ``compute_reward`` (metaworld 3.0.0), Meta-World's own scale (max 10)::

    near_button    = tolerance(|obj - tcp|, (0, 0.01), margin=|obj - init_tcp|, long_tail)
    button_pressed = tolerance(|goal_z - obj_z|, (0, 0.005), margin=|goal_z - buttonStart_z|, long_tail)
    r = 5 * hamacher(1 - gripper_open, near_button) + (5 * button_pressed if |obj - tcp| <= 0.03 else 0)

Success (paper-era MTBench, ``task_fns/button_press_topdown.py``): ``|obj_z - target_z| <= 0.01`` where MTBench's
target is the unpressed button top moved down by the full 6 cm joint travel (``target = buttonStart - 0.06``), i.e.
the button is pressed at least 5 cm. Here: ``|obj_z - (obj_init_z - 0.06)| <= 0.01`` with ``obj_init_z`` the
observed button height at reset.

Differences:

* Meta-World's success is ``|goal_z - obj_z| <= 0.024`` against the ``hole`` site, i.e. a press of
  0.0935 - 0.024 = 6.95 cm, which is *beyond* the 6 cm joint range: the Sawyer only reaches it by pushing the
  button 1 cm through its (soft) joint limit. The literal "|dz| <= 0.01 to the hole" would need 8.35 cm of travel
  and is unreachable. MTBench's rule (relative to the end of the travel) is physically meaningful and is the
  default here. The dense reward keeps Meta-World's ``hole`` target, so its ``button_pressed`` term stays below 1
  (about 0.9 at full travel) as with the Sawyer.
* On success steps the env pays the flat ``success_bonus`` (MTBench added ``16 * button_pressed`` to the dense
  term instead; the framework uses one rule for every task).
* ``obs[0:3]`` and ``tcp`` are the Panda's finger-pad midpoint; ``obs[3]`` is the pad distance / 0.1.
* The box's own collision geoms move with it (``WarpSim.set_body_pos``; MuJoCo Warp treats them as static; left
  at the XML position they overlapped the button's rod and held the button up).

Physics notes: Meta-World's button joint limit is a soft constraint scaled by the button's 10 g mass, so a hard
shove pushes it 2-3 cm past the end of its travel (its collar then wedges in the box opening at about 7 cm), and
once the fingers straddle the cap they can pull it far above its rest position. ``edit_spec`` gives the slide
an armature and a stiff limit, and lets the joint alone guide the button (no button-box contacts).
"""

from __future__ import annotations

import mujoco
import torch

from ..reward_utils import hamacher_product, tolerance
from ..scene import SceneSpec, guide_by_joint
from ..task import MetaWorldTask, Objects, TaskState


def button_press_topdown_reward(
    tcp: torch.Tensor, init_tcp: torch.Tensor, obj: torch.Tensor, goal_z: torch.Tensor,
    obj_to_target_init: torch.Tensor, gripper_open: torch.Tensor,
) -> torch.Tensor:
    """Meta-World v2 dense reward of button-press-topdown (``[n]``, scale 0..10); pure function of tensors."""
    tcp_to_obj = (obj - tcp).norm(dim=-1)
    tcp_to_obj_init = (obj - init_tcp).norm(dim=-1)
    obj_to_target = (goal_z - obj[..., 2]).abs()
    near_button = tolerance(tcp_to_obj, bounds=(0.0, 0.01), margin=tcp_to_obj_init, sigmoid="long_tail")
    button_pressed = tolerance(obj_to_target, bounds=(0.0, 0.005), margin=obj_to_target_init, sigmoid="long_tail")
    reward = 5.0 * hamacher_product(1.0 - gripper_open, near_button)
    return reward + torch.where(tcp_to_obj <= 0.03, 5.0 * button_pressed, torch.zeros_like(button_pressed))


def button_press_topdown_success(obj_z: torch.Tensor, obj_init_z: torch.Tensor) -> torch.Tensor:
    """MTBench success: the button top within ``SUCCESS_TOL`` of the end of its travel (``[n]`` bool)."""
    target_z = obj_init_z - ButtonPressTopdown.TRAVEL
    return (obj_z - target_z).abs() <= ButtonPressTopdown.SUCCESS_TOL


class ButtonPressTopdown(MetaWorldTask):
    """Press the button down through its travel (see the module docstring)."""

    name = "button_press_topdown"
    mtbench_id = 4
    description = "Press a button downward from above."
    scene = SceneSpec("sawyer_button_press_topdown.xml", hand_init_pos=(0.0, 0.4, 0.2))
    # box position x, y, z (Meta-World obj_low/obj_high); the goal (hole site) follows from it
    reset_low = (-0.1, 0.8, 0.115)
    reset_high = (0.1, 0.9, 0.115)
    OBS_Z_OFFSET = 0.193  # Meta-World: button body position + (0, 0, 0.193)
    TRAVEL = 0.06  # joint range of btnbox_joint (MTBench target = start - 0.06)
    SUCCESS_TOL = 0.01  # MTBench; Meta-World: 0.024 to the hole site (see module docstring)
    buffers = {"obj_to_target_init": (), "button_init": (3,)}

    # The 10 g button's joint limit is a mass-scaled soft constraint, roughly a 30 N/m spring, so the arm can
    # shove the button 2-3 cm past the end of its travel or pull it far above its rest position once the fingers
    # straddle the cap, and a hard shove through the box overflows the constraint buffers. An armature of 0.5 kg
    # on the slide joint plus a stiff limit keeps it within about 7 mm of its range under the same abuse.
    BUTTON_ARMATURE = 0.5

    @classmethod
    def edit_spec(cls, spec: mujoco.MjSpec) -> None:
        """Button slide: armature (see ``BUTTON_ARMATURE``), stiff limit, guided by its joint alone."""
        guide_by_joint(spec, "button", "btnbox_joint", ("buttonbox", "RetainingWall"))  # checks the names
        spec.joint("btnbox_joint").armature = cls.BUTTON_ARMATURE

    def bind(self, model) -> None:
        self.box_body = self.body_id("box")
        self.button_body = self.body_id("button")
        self.button_qpos = self.joint_qposadr("btnbox_joint")
        self.hole_site = self.site_id("hole")
        self.start_site = self.site_id("buttonStart")

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        self.set_body_pos(s.sim, self.box_body, vec[:, :3], mask)
        self.set_joint(s.sim, self.button_qpos, 0.0, mask)
        self.masked_set(s.obj_init_pos, vec[:, :3], mask)

    def after_reset(self, s: TaskState, mask: torch.Tensor) -> None:
        # Meta-World: target = hole site after mj_forward; margin = |target_z - buttonStart_z|
        hole = s.sim.site_xpos[:, self.hole_site]
        start = s.sim.site_xpos[:, self.start_site]
        self.masked_set(s.goal, hole, mask)
        self.masked_set(s.buffers["obj_to_target_init"], (hole[:, 2] - start[:, 2]).abs(), mask)
        self.masked_set(s.buffers["button_init"], s.obj_pos, mask)

    def objects(self, s: TaskState) -> Objects:
        pos = s.sim.xpos[:, self.button_body]
        top = torch.stack([pos[:, 0], pos[:, 1], pos[:, 2] + self.OBS_Z_OFFSET], dim=-1)
        return Objects(top, s.sim.xquat[:, self.button_body])

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return button_press_topdown_reward(s.tcp, s.init_tcp, s.obj_pos, s.goal[:, 2],
                                           s.buffers["obj_to_target_init"], s.gripper_open)

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return button_press_topdown_success(s.obj_pos[:, 2], s.buffers["button_init"][:, 2])
