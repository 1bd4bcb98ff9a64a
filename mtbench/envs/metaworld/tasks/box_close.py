"""Box close: pick up a box's lid by its handle and put it on the box (Meta-World ``box-close-v3``; paper-era
MTBench ``task_fns/box_close.py``)."""

from __future__ import annotations

import mujoco
import torch

from ..reward_utils import grasp_place_reward, hamacher_product, polyline_distance, tolerance
from ..scene import SceneSpec
from ..task import FreeObjectTask, Objects, TaskState, offset

SUCCESS_RADIUS = 0.08
LID_QUAT = (0.7071067811865476, 0.0, 0.0, 0.7071067811865476)  # wxyz, the XML orientation of boxbodytop
TOP_LINK_FROM_BODY = 0.075  # top_link sits 7.5 cm above the lid's free body (boxbodytop)
TOP_LINK_REST_Z = 0.016  # lid lying on the table: its skirt (1.6 cm below top_link) on the table
LID_POINT = 0.08  # MTBench's "lid": its top_link2 (top_link + 0.09) − 0.01 along z, at the handle bar (0.082)
LIFTED_Z = 0.106  # MTBench: lid point above TABLE_Z + .106 ("the lid is already above [.04]"): 1 cm above rest
MTB_TABLE_Z = 1.027  # MTBench's table height, which enters one margin of its reward (see BoxClose)


def box_close_reward(action: torch.Tensor, lid: torch.Tensor, tcp: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """Dense reward ``[n]`` (see :class:`BoxClose`): ``lid`` is the handle point (top_link + 0.08 along the lid's
    z), ``goal`` the target, ``action[:, 3]`` the gripper effort."""
    radius = (tcp[:, :2] - lid[:, :2]).norm(dim=-1)
    outside = radius > 0.02
    floor = torch.where(outside, 0.04 * torch.log(torch.where(outside, radius - 0.02, 1.0)) + 0.4, 0.0)
    # MTBench's margin is half its floor height in its own frame, where the table is at 1.027 m
    margin = (floor + MTB_TABLE_Z) / 2.0
    below = tolerance((floor - tcp[:, 2]).clamp_min(0.0), bounds=(0.0, 0.01), margin=margin, sigmoid="long_tail")
    above_floor = torch.where(tcp[:, 2] >= floor, 1.0, below)
    in_place = tolerance((tcp - lid).norm(dim=-1), bounds=(0.0, 0.02), margin=0.5, sigmoid="long_tail")
    grab = (action[:, 3].clamp(-1.0, 1.0) + 1.0) / 2.0
    ready_to_lift = hamacher_product(above_floor, in_place)
    diff = goal - lid
    pos_error = torch.stack([diff[:, 0], diff[:, 1], 3.0 * diff[:, 2]], dim=-1).norm(dim=-1)
    lifted = 0.2 * (lid[:, 2] > LIFTED_Z).to(lid.dtype) + 0.8 * tolerance(
        pos_error, bounds=(0.0, 0.05), margin=0.25, sigmoid="long_tail")
    return 2.0 * hamacher_product(grab, ready_to_lift) + 8.0 * lifted


V2_HOLD_RADIUS = 0.02  # v2: TCP within 2 cm of the handle bar's middle
V2_CARRY_Z = 0.14  # v2: top_link height at which the lid's skirt clears the box's 6 cm walls (scripted: 0.15)
V2_NEAR_BOX = 0.15  # v2: horizontal distance to the goal under which the lid may travel low


def box_close_reward_v2(action: torch.Tensor, top: torch.Tensor, lid: torch.Tensor, tcp: torch.Tensor,
                        left_pad: torch.Tensor, right_pad: torch.Tensor, gripper_open: torch.Tensor, goal: torch.Tensor,
                        top_init: torch.Tensor, init_tcp: torch.Tensor) -> torch.Tensor:
    """``reward_version="v2"`` dense reward ``[n]`` (0..7): :func:`~..reward_utils.grasp_place_reward` (pick_place's
    form) with the handle bar (``lid``) as grasp point and ``top`` (top_link) as the carried object, hold radius 2 cm,
    and the carry measured along the path up from the lid's start to ``V2_CARRY_Z`` and then straight to the goal, while
    the lid is low and more than 15 cm (horizontally) from the goal; straight to the goal otherwise.

    Why: the paper-era reward pays 2 for the TCP at the bar with the gripper closing, 0.2 for the lid 1 cm up and
    the rest through a long-tail term of the (z x 3) distance to the goal; dragging the lid over the table scores
    about as much as lifting it, and the box's walls stop a dragged lid. v2 cages the handle bar and pays the lid's
    way over the walls once it is held and lifted.
    """
    lid_init = offset(top_init, 0.0, 0.0, LID_POINT)
    above_start = torch.stack([top_init[:, 0], top_init[:, 1], torch.full_like(top_init[:, 2], V2_CARRY_Z)], dim=-1)
    low_and_far = (top[:, 2] < V2_CARRY_Z - 0.02) & ((top[:, :2] - goal[:, :2]).norm(dim=-1) > V2_NEAR_BOX)
    carry = polyline_distance(top, [above_start, goal], (~low_and_far).long())
    carry0 = polyline_distance(top_init, [above_start, goal], torch.zeros_like(top[:, 0], dtype=torch.long))
    return grasp_place_reward(action, tcp, left_pad, right_pad, gripper_open, lid, lid_init, init_tcp,
                              top[:, 2] - top_init[:, 2], carry, carry0,
                              obj_radius=0.01, pad_success_thresh=0.05, object_reach_radius=0.01, xz_thresh=0.005,
                              hold_radius=V2_HOLD_RADIUS, place_radius=SUCCESS_RADIUS)


def box_close_success(lid_base: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """``‖top_link − goal‖ < 0.08`` (``lid_base`` is the lid's ``top_link``)."""
    return (lid_base - goal).norm(dim=-1) < SUCCESS_RADIUS


class BoxClose(FreeObjectTask):
    """Put the lid (23 x 23 cm plate with a side skirt and a handle bar on two posts, 0.25 kg) on the open box
    (20 x 20 cm, 6 cm high).

    Scene: Meta-World ``sawyer_box.xml``. The lid is the free body ``boxbodytop`` (turned 90 degrees about z, so
    the 10 cm handle bar, a capsule of radius 8 mm 8.2 cm above ``top_link``, runs along x); the box ``boxbody``
    is fixed to the world and moved per world with ``set_body_pos``. ``edit_spec`` adds the site ``lid_point`` at
    ``top_link`` + (0, 0, 0.08): MTBench's "lid" point (its ``top_link2`` at 0.09 minus 0.01), on the handle bar.
    MTBench's "lid base" is ``top_link``, the lid plate's bottom. ``edit_spec`` also stops the lid's two visual
    meshes (plate and handle, in the default geom class) from colliding, as MTBench removed them ("appearing as a
    solid rectangle"): their convex hulls are solid slabs, which made the closed lid rest 1.6 cm high on the box
    walls by its skirt's hull and filled the handle between its posts. The lid collides through Meta-World's
    primitive collision geoms only; closed, ``top_link`` rests on the walls at z = 0.06.

    Reset (MTBench ranges mapped to this frame, ``x = -y_mtb, y = x_mtb + 0.6, z = z_mtb - 1.027``): lid
    ``top_link`` at U([-0.05, 0.45], [0.05, 0.5]) lying on the table (z = 0.016; MTBench puts ``top_link`` at the
    table and lets the contacts push it up; it moved Meta-World's lid range y in [0.5, 0.55] by -0.05), goal ~
    U([-0.1, 0.75, 0.133], [0.1, 0.85, 0.133]) (MTBench; Meta-World: y in [0.7, 0.8]) with the box at the goal's
    x-y on the table. No rejection (MTBench has none; lid and box are always >= 25 cm apart, Meta-World's bound).
    ``obj_init_pos`` = ``top_link`` at reset (unused by the reward, as in MTBench).
    Object observation: ``top_link`` position and quaternion (wxyz), as Meta-World (MTBench observed the handle
    point and the box). No second object.

    Reward: MTBench's dense term (before its ``* .01``), with ``lid`` = ``lid_point``::

        r = ‖tcp_xy − lid_xy‖;  floor = 0 if r <= 0.02 else 0.04·ln(r − 0.02) + 0.4
        above_floor = 1 if tcp_z >= floor else tolerance(max(floor − tcp_z, 0), (0, 0.01),
                                                         margin=(floor + 1.027)/2, long_tail)
        in_place = tolerance(‖tcp − lid‖, (0, 0.02), margin=0.5, long_tail)
        grab = (clip(action[3], −1, 1) + 1)/2
        lifted = 0.2·[lid_z > 0.106] + 0.8·tolerance(‖(goal − lid)·(1, 1, 3)‖, (0, 0.05), margin=0.25, long_tail)
        r = 2·hamacher(grab, hamacher(above_floor, in_place)) + 8·lifted

    The margin ``(floor + 1.027)/2`` is MTBench's ``floor/2`` in its own frame (table at 1.027 m), kept so that
    the reward has MTBench's values (Meta-World: ``floor/2`` with the table at 0). MTBench computes the lid's
    quaternion term but, unlike Meta-World, does not multiply the reward by it.
    Success (MTBench and Meta-World): ``‖top_link − goal‖ < 0.08``: the lid held over the box, or lying on it
    within 3.3 cm of the box's centre.
    ``reward_version="v2"``: :func:`box_close_reward_v2` (pick_place's form on the handle bar, path over the walls).
    """

    name = "box_close"
    mtbench_id = 3
    description = "Pick up the box lid and put it on top of the box to close it."
    scene = SceneSpec("sawyer_box.xml", hand_init_pos=(0.0, 0.6, 0.2))
    # lid top_link x, y, z then goal x, y, z
    reset_low = (-0.05, 0.45, TOP_LINK_REST_Z, -0.1, 0.75, 0.133)
    reset_high = (0.05, 0.5, TOP_LINK_REST_Z, 0.1, 0.85, 0.133)
    MIN_GOAL_DIST = 0.0  # MTBench: no goal rejection
    OBJ_BODY = "boxbodytop"

    @classmethod
    def edit_spec(cls, spec: mujoco.MjSpec) -> None:
        """MTBench's lid point as a site on ``top_link``; the lid's visual meshes do not collide."""
        top = spec.body("top_link")
        top.add_site(name="lid_point", pos=[0.0, 0.0, LID_POINT], size=[0.005] * 3, group=4)
        for geom in top.geoms:
            if geom.type == mujoco.mjtGeom.mjGEOM_MESH:
                geom.contype, geom.conaffinity = 0, 0

    def bind(self, model) -> None:
        self.obj_body = self.body_id(self.OBJ_BODY)
        self.obj_qpos = self.body_qposadr(self.obj_body)
        self.top_body = self.body_id("top_link")
        self.box_body = self.body_id("boxbody")
        self.lid_site = self.site_id("lid_point")
        self.lid_quat = self.const(LID_QUAT)

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        top, goal = vec[:, :3], vec[:, 3:6]
        self.set_free_body(s.sim, self.obj_qpos, offset(top, 0.0, 0.0, -TOP_LINK_FROM_BODY), mask,
                           quat=self.lid_quat.expand(top.shape[0], 4))
        self.set_body_pos(s.sim, self.box_body, torch.stack([goal[:, 0], goal[:, 1], goal[:, 2] * 0.0], dim=-1), mask)
        self.masked_set(s.obj_init_pos, top, mask)
        self.masked_set(s.goal, goal, mask)

    def objects(self, s: TaskState) -> Objects:
        return Objects(*self.body_pose(s, self.top_body))

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return box_close_reward(action, s.sim.site_xpos[:, self.lid_site], s.tcp, s.goal)

    def reward_v2(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return box_close_reward_v2(action, s.obj_pos, s.sim.site_xpos[:, self.lid_site], s.tcp, s.left_pad, s.right_pad,
                                   s.gripper_open, s.goal, s.obj_init_pos, s.init_tcp)

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return box_close_success(s.obj_pos, s.goal)
