"""Pieces shared by assembly and disassemble (Meta-World ``sawyer_assembly_peg.xml``).

The scene: a round nut (free body ``RoundNut``, 0.22 kg) whose ring (eight capsules of radius 1.9 cm on a 4.8 cm
circle: 2.9 cm inner clearance) has a 13 cm arm ending in a handle (a 3.8 x 7.6 x 3.2 cm box). At rest the nut
lies flat with the quaternion ``NUT_QUAT`` (90 degrees about z), so its handle points along +x: the ring centre is
the site ``RoundNut``, the handle centre the site ``RoundNut-8`` = ring + (0.13, 0, 0). The peg (``peg``, a
cylinder of radius 2 cm and height 10 cm) is fixed to the world and moved per world with ``set_body_pos``
(MTBench's and Meta-World's peg is fixed to the table too).

MTBench's nut (``round_nut.xml``) is the same model laid out along its own -y axis, which is +x here; its quaternion
rewards compare the nut's orientation with that laid-down pose. For unit quaternions ``‖q − q0‖² = 2 − 2 q·q0``
depends only on the rotation from ``q0`` to ``q``, so MTBench's ``‖q_mtb − (0, 0, 0, 1)‖`` equals
``‖q − NUT_QUAT‖`` here (wxyz, with ``q`` on the same hemisphere as ``NUT_QUAT``, as MuJoCo keeps it from the reset).
"""

from __future__ import annotations

import torch

from ..task import Objects, TaskState

XML = "sawyer_assembly_peg.xml"
NUT_QUAT = (0.7071067811865476, 0.0, 0.0, 0.7071067811865476)  # wxyz, Meta-World's XML orientation of RoundNut
HANDLE_OFFSET = 0.13  # handle centre = ring centre + (0.13, 0, 0) when the nut lies flat
WRENCH_HANDLE_LENGTH = 0.02  # Meta-World/MTBench: |handle_x − tcp_x| below half of it counts as aligned
PEG_HALF_HEIGHT = 0.05
RING_RADIUS = 0.019  # capsule radius: the ring centre of a nut lying on the table is 1.9 cm high


def wrench_threshed(handle: torch.Tensor, tcp: torch.Tensor) -> torch.Tensor:
    """The handle point given to the caging reward: its x is the TCP's while ``|handle_x − tcp_x| < 0.01``
    (Meta-World's and MTBench's stand-in for the handle's length, MTBench's y_mtb)."""
    near = (handle[:, 0] - tcp[:, 0]).abs() < WRENCH_HANDLE_LENGTH / 2.0
    return torch.stack([torch.where(near, tcp[:, 0], handle[:, 0]), handle[:, 1], handle[:, 2]], dim=-1)


def quat_error(quat: torch.Tensor, quat0: torch.Tensor) -> torch.Tensor:
    """``‖quat − quat0‖`` over the last axis (wxyz quaternions ``[n, 4]``)."""
    return (quat - quat0).norm(dim=-1)


class NutSceneMixin:
    """Model ids, nut placement and the nut's observation; mix into a ``MetaWorldTask`` subclass (listed first)."""

    def bind(self, model) -> None:
        self.nut_body = self.body_id("RoundNut")
        self.nut_qpos = self.body_qposadr(self.nut_body)
        self.ring_site = self.site_id("RoundNut")
        self.handle_site = self.site_id("RoundNut-8")
        self.peg_body = self.body_id("peg")
        self.nut_quat = self.const(NUT_QUAT)

    def place_nut(self, s: TaskState, ring: torch.Tensor, mask: torch.Tensor) -> None:
        """Put the nut flat with its ring centre at ``ring`` ([n, 3]) in the worlds of ``mask``."""
        self.set_free_body(s.sim, self.nut_qpos, ring, mask, quat=self.nut_quat.expand(ring.shape[0], 4))

    def ring_center(self, s: TaskState) -> torch.Tensor:
        return s.sim.site_xpos[:, self.ring_site]

    def objects(self, s: TaskState) -> Objects:
        """The handle centre and the nut's quaternion (Meta-World's observation); no second object."""
        return Objects(s.sim.site_xpos[:, self.handle_site], s.sim.xquat[:, self.nut_body])
