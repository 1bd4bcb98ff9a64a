"""Faucet open: turn the faucet handle counter-clockwise (seen from above) to the open position (MTBench
``faucet_open``, Meta-World ``faucet-open-v3``)."""

from __future__ import annotations

import torch

from ..reward_utils import tolerance
from ..task import MetaWorldTask, TaskState, offset
from ._faucet import HANDLE_LENGTH, RESET_HIGH, RESET_LOW, SCENE, FaucetSceneMixin

TARGET_RADIUS = 0.07
REACH_RADIUS = 0.01
# MTBench shifts the observed handle point by (0, +.04, +.03) in its frame before measuring: (-0.04, 0, 0.03) here
# (Meta-World's faucet-open uses the same shift)
HANDLE_SHIFT = (-0.04, 0.0, 0.03)


def faucet_open_reward(tcp: torch.Tensor, handle: torch.Tensor, goal: torch.Tensor, faucet: torch.Tensor,
                       init_tcp: torch.Tensor) -> torch.Tensor:
    """MTBench's ``faucet_open`` dense term before its ``* .02`` (``[n]``, in [0, 5])::

        obj      = handle + (-0.04, 0, 0.03)
        in_place = tol(‖obj − goal‖, (0, .07), margin |‖goal − faucet‖ − .07|, long_tail)
        reach    = tol(‖obj − tcp‖, (0, .01), margin |‖obj − tcp_init‖ − .01|, gaussian)
        r = 2·reach + 3·in_place
    """
    obj = offset(handle, *HANDLE_SHIFT)
    target_to_obj = (obj - goal).norm(dim=-1)
    target_to_obj_init = (goal - faucet).norm(dim=-1)
    in_place = tolerance(target_to_obj, bounds=(0.0, TARGET_RADIUS), margin=(target_to_obj_init - TARGET_RADIUS).abs(),
                         sigmoid="long_tail")
    tcp_to_obj = (obj - tcp).norm(dim=-1)
    tcp_to_obj_init = (obj - init_tcp).norm(dim=-1)
    reach = tolerance(tcp_to_obj, bounds=(0.0, REACH_RADIUS), margin=(tcp_to_obj_init - REACH_RADIUS).abs(),
                      sigmoid="gaussian")
    return 2.0 * reach + 3.0 * in_place


def faucet_open_success(handle: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
    """MTBench: ``‖handle + (-0.04, 0, 0.03) − goal‖ ≤ 0.07`` (``[n]`` bool)."""
    return (offset(handle, *HANDLE_SHIFT) - goal).norm(dim=-1) <= TARGET_RADIUS


class FaucetOpen(FaucetSceneMixin, MetaWorldTask):
    """Turn the faucet handle from pointing at the robot (0) to pointing at +x (+90 degrees); see ``_faucet``.

    * Reset: faucet ~ U([-0.1, 0.8, 0], [0.1, 0.85, 0]) (MTBench's range; Meta-World's is +-0.05 in x), handle at 0.
      Goal = faucet + (0.175, 0, 0.125); ``obj_init_pos`` = the faucet position (MTBench).
    * Observation: object 1 = the ``handleStartOpen`` site (end of the handle, 1.5 cm on its -x side at 0) with the
      handle's orientation.
    * Dense reward: :func:`faucet_open_reward`; ``dense_scale`` = 0.02 (MTBench's faucet_open factor).
    * Success (MTBench): ``‖handle + (-0.04, 0, 0.03) − goal‖ ≤ 0.07``, i.e. hinge angles >= 1.398 rad (within
      10 degrees of the +1.57 limit).
    * Differences: the hand starts with its TCP at (0, 0.4, 0.2) (Meta-World's ``hand_init_pos``);
      ``init_tcp`` is recorded at every reset (MTBench: once per run).
    """

    name = "faucet_open"
    mtbench_id = 20
    description = "Rotate the faucet handle the other way to turn the tap on."
    scene = SCENE
    reset_low = RESET_LOW
    reset_high = RESET_HIGH
    dense_scale = 0.02
    HANDLE_SITE = "handleStartOpen"
    GOAL_DX = HANDLE_LENGTH

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return faucet_open_reward(s.tcp, s.obj_pos, s.goal, s.obj_init_pos, s.init_tcp)

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return faucet_open_success(s.obj_pos, s.goal)
