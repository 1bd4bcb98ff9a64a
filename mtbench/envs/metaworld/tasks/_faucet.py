"""Pieces shared by faucet_open and faucet_close (Meta-World ``sawyer_faucet.xml``).

The scene: a fixed faucet body ``faucetBase`` placed per world (batched ``body_pos``) on the table; the handle
``faucet_link2`` turns about a vertical hinge (``knob_Joint_1``, range [-1.57, 1.57] rad, damping 2) at
``faucetBase + (0, 0, 0.124)``. At 0 the 17.5 cm handle points to -y (towards the robot); positive angles turn it
counter-clockwise seen from above (towards +x: open), negative ones clockwise (towards -x: closed). The handle sites
``handleStartClose`` / ``handleStartOpen`` sit at ``(+-0.015, -0.175, 0)`` in the handle frame, i.e. at the end of
the handle, 1.5 cm to either side of its axis.

MTBench (``task_fns/faucet_*.py``) uses its own copy of this asset turned by -90 degrees in its frame, which is
Meta-World's orientation once mapped to ours (``x_mw = -y_mtb``, ``y_mw = x_mtb + 0.6``). It observes the bodies
``handleStartClose`` / ``handleStartOpen`` at the same places as the sites here (Meta-World subtracts 1 cm in z;
MTBench does not). Its reset space is the faucet position only: ``x_mtb in [.2, .25], y_mtb in [-.1, .1]`` at table
height, i.e. ``x in [-0.1, 0.1], y in [0.8, 0.85], z = 0`` here (Meta-World's faucet-close range; Meta-World's
faucet-open range is narrower in x, +-0.05). Targets: ``faucet + (-+0.175, 0, 0.125)`` (MTBench ``(0, +-.175,
.125)`` mapped; Meta-World's too).
"""

from __future__ import annotations

import mujoco
import torch

from ..scene import SceneSpec, guide_by_joint
from ..task import Objects, TaskState, offset

SCENE = SceneSpec("sawyer_faucet.xml", hand_init_pos=(0.0, 0.4, 0.2))  # Meta-World's hand_init_pos
RESET_LOW = (-0.1, 0.8, 0.0)
RESET_HIGH = (0.1, 0.85, 0.0)
HANDLE_LENGTH = 0.175  # MTBench's faucet_handle_length (= Meta-World's _handle_length)
GOAL_HEIGHT = 0.125
BASE_BODY = "faucetBase"
HANDLE_BODY = "faucet_link2"
HINGE = "knob_Joint_1"


class FaucetSceneMixin:
    """Model ids, reset writes and observation of the faucet scene; mix into a ``MetaWorldTask`` (listed first)."""

    HANDLE_SITE: str  # handleStartClose / handleStartOpen
    GOAL_DX: float  # -HANDLE_LENGTH (close) or +HANDLE_LENGTH (open)

    @classmethod
    def edit_spec(cls, spec: mujoco.MjSpec) -> None:
        """The handle turns on its hinge alone (its parent never collides with it; stiff limit)."""
        guide_by_joint(spec, HANDLE_BODY, HINGE, ("faucet_link",))

    def bind(self, model) -> None:
        self.base_body = self.body_id(BASE_BODY)
        self.handle_body = self.body_id(HANDLE_BODY)
        self.hinge_qpos = self.joint_qposadr(HINGE)
        self.handle_site = self.site_id(self.HANDLE_SITE)

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        base = vec[:, :3]
        self.set_body_pos(s.sim, self.base_body, base, mask)
        self.set_joint(s.sim, self.hinge_qpos, 0.0, mask)
        self.masked_set(s.obj_init_pos, base, mask)  # MTBench: obj_init_pos = the faucet position
        self.masked_set(s.goal, offset(base, self.GOAL_DX, 0.0, GOAL_HEIGHT), mask)

    def objects(self, s: TaskState) -> Objects:
        """The handle site with the handle's orientation (MTBench's ``handleStart*`` body)."""
        return Objects(s.sim.site_xpos[:, self.handle_site], s.sim.xquat[:, self.handle_body])
