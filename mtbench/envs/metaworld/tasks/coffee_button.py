"""Coffee button: push the button on the front of the coffee machine (Meta-World ``coffee-button-v3``, MTBench id 8)."""

from __future__ import annotations

import torch

from ..reward_utils import hamacher_product, mtbench_gripper_openness, tolerance
from ..task import MetaWorldTask, Objects, TaskState, offset
from ._coffee import BUTTON_FROM_MACHINE, BUTTON_TRAVEL, SCENE, CoffeeSceneMixin, edit_coffee_scene

NEAR_BOUND = 0.05  # MTBench: near_button = tol(tcp_to_obj, (0, 0.05), ...); also the gate of the pressing term
CLOSED = 0.95  # MTBench: the pressing term counts while tcp_closed >= 0.95
SUCCESS_TOL = 0.01
# MTBench's success also asks ||tcp - obj|| < 0.02, which the Panda cannot reach while pressing (see CoffeeButton);
# we use MTBench's own "near the button" radius of this reward instead.
TCP_RADIUS = 0.05
MUG_FROM_MACHINE = (0.0, -0.37, 0.0)  # MTBench: mug at obj_init_pos - .15 along x_mtb, on the table


def coffee_button_reward(tcp: torch.Tensor, obj: torch.Tensor, init_tcp: torch.Tensor, goal: torch.Tensor,
                         tcp_closed: torch.Tensor) -> torch.Tensor:
    """MTBench ``coffee_button`` dense term before its ``* .01`` (``[n]``)::

        near_button    = tol(‖obj − tcp‖, (0, .05), margin ‖obj − init_tcp‖, long_tail)
        button_pressed = tol(|obj_y − goal_y|, (0, .005), margin .03, long_tail)
        r = 2 · H(tcp_closed, near_button) + 8 · button_pressed   if ‖obj − tcp‖ <= .05 and tcp_closed >= .95
        r = 2 · H(tcp_closed, near_button)                        otherwise
    """
    tcp_to_obj = (obj - tcp).norm(dim=-1)
    tcp_to_obj_init = (obj - init_tcp).norm(dim=-1)  # MTBench: the *current* button point
    obj_to_target = (obj[..., 1] - goal[..., 1]).abs()
    near_button = tolerance(tcp_to_obj, bounds=(0.0, NEAR_BOUND), margin=tcp_to_obj_init, sigmoid="long_tail")
    button_pressed = tolerance(obj_to_target, bounds=(0.0, 0.005), margin=BUTTON_TRAVEL, sigmoid="long_tail")
    reward = 2.0 * hamacher_product(tcp_closed, near_button)
    pressing = (tcp_to_obj <= NEAR_BOUND) & (tcp_closed >= CLOSED)
    return torch.where(pressing, reward + 8.0 * button_pressed, reward)


def coffee_button_success(tcp: torch.Tensor, obj: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """``|obj_y − goal_y| <= 0.01`` (pressed at least 2 of its 3 cm) and ``‖tcp − obj‖ < 0.05`` (``[n]`` bool)."""
    return ((obj[..., 1] - goal[..., 1]).abs() <= SUCCESS_TOL) & ((obj - tcp).norm(dim=-1) < TCP_RADIUS)


class CoffeeButton(CoffeeSceneMixin, MetaWorldTask):
    """Press the coffee machine's button (facing the robot) at least 2 cm into the machine.

    * Scene: Meta-World ``sawyer_coffee.xml`` (hand starts at Meta-World's (0, 0.4, 0.2)).
    * Reset (MTBench ``obj_low/obj_high`` (.2, -.1) .. (.25, .1) on the table, "changed from .3 to .25"; mapped
      ``x = -y_mtb``, ``y = x_mtb + 0.6``, ``z = z_mtb - 1.027``): machine at x ~ U[-0.1, 0.1], y ~ U[0.8, 0.85],
      z = 0 (Meta-World v3: y up to 0.9). The mug stands on the table at ``machine + (0, -0.37, 0)`` (MTBench:
      ``obj_init_pos - .15`` along x_mtb; Meta-World puts it under the spout, ``machine + (0, -0.22, 0)``), its
      handle towards -x as MTBench spawns it.
    * Observation: object 1 = ``buttonStart`` (the button's front face centre) and the button's quaternion;
      object 2 = the mug's centre and quaternion. ``obj_init_pos = machine + (0, -0.22, 0.3)``, goal =
      ``obj_init_pos + (0, 0.03, 0)`` (MTBench: ``+.03`` along x_mtb, the end of the travel).
    * Dense reward: :func:`coffee_button_reward` (MTBench before ``* .01``; openness ``‖pads‖ / 0.095``).
    * Success: ``|obj_y − goal_y| <= 0.01`` and ``‖tcp − obj‖ < 0.05``; success steps pay 10.
    * Difference (physically impossible rule): MTBench's success asks ``‖tcp − obj‖ < 0.02``. The Panda's palm
      (3.7 cm above the TCP, reaching 10.2 cm ahead of it along y) has to pass above the machine's top (0.37, 7 cm
      above the button's centre) while the fingertips (0.9 cm below the TCP) press the button's upper edge, so the
      TCP stays at least 3.6 cm from the button's face centre while the button is pressed 2 cm. The rule keeps
      MTBench's intent (the hand is at the button when it is pressed) with the radius MTBench itself uses for "near
      the button" in this reward (the ``near_button`` bound and the gate of the pressing term), 0.05.
    * Other differences: ``init_tcp`` per reset (MTBench: once); Meta-World's ``tolerance`` inside the bounds
      (MTBench's returns 0 there when the margin is positive).
    """

    name = "coffee_button"
    mtbench_id = 8
    description = "Push the button on the front of the coffee machine."
    scene = SCENE
    reset_low = (-0.1, 0.8, 0.0)
    reset_high = (0.1, 0.85, 0.0)

    @classmethod
    def edit_spec(cls, spec) -> None:
        edit_coffee_scene(spec)

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        machine = vec[:, :3]
        self.place_machine(s, machine, mask)
        self.place_mug(s, offset(machine, *MUG_FROM_MACHINE), mask)
        obj_init = offset(machine, *BUTTON_FROM_MACHINE)
        self.masked_set(s.obj_init_pos, obj_init, mask)
        self.masked_set(s.goal, offset(obj_init, 0.0, BUTTON_TRAVEL, 0.0), mask)

    def objects(self, s: TaskState) -> Objects:
        return Objects(*self.button_pose(s), *self.mug_pose(s))

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        tcp_closed = 1.0 - mtbench_gripper_openness(s.left_pad, s.right_pad)
        return coffee_button_reward(s.tcp, s.obj_pos, s.init_tcp, s.goal, tcp_closed)

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return coffee_button_success(s.tcp, s.obj_pos, s.goal)
