"""Window open: slide a window sash open by pushing its handle sideways (Meta-World ``window-open-v3``)."""

from __future__ import annotations

import torch

from ..task import MetaWorldTask, TaskState
from ._window import SCENE, WindowSceneMixin, window_reward, window_success


class WindowOpen(WindowSceneMixin, MetaWorldTask):
    """Slide the window open by 20 cm along +x (Meta-World ``window-open-v3`` on the Panda).

    * Reset: window frame at x ~ U[-0.1, 0.1], y ~ U[0.7, 0.9], z = 0.16 (Meta-World frame; MTBench:
      x_mtb ~ U[.1, .3], y_mtb ~ U[-.1, .1]), sash closed (slide 0). Goal (MTBench's ``target_pos``) = the handle
      point at reset moved through the full 0.2 travel (+x); ``obj_init_pos`` = the window position.
    * Observation: object 1 = site ``handleOpenStart`` (``window + (-0.04 + slide, -0.095, 0)``), zero quaternion
      (as Meta-World); no object 2.
    * Dense reward (paper-era MTBench ``task_fns/window_open.py``): ``H(reach, in_place)`` (see
      :func:`._window.window_reward`: 1 cm in-place bound, Gaussian 2 cm reach), ``dense_scale`` 0.01.
      (Meta-World v2: ``10 · H(reach, in_place)`` on the x error with a 5 cm bound.)
    * Success (paper-era MTBench, ``‖obj − target‖ ≤ 0.01`` in 3-D, "changed from .05"): MTBench's obj is the
      handle and its target the initial handle position moved through the full 0.2 travel. In Meta-World's frame
      (MTBench's -y is Meta-World's +x) that is ``‖handle − (handle_init + (0.2, 0, 0))‖ ≤ 0.01``: the slide is
      within 1 cm of its 0.2 limit. It coincides with Meta-World's own rule (``|handle_x − goal_x| ≤ 0.05``,
      slide ≥ 0.19) except for the upper side, which only the soft joint limit can reach.
    * Differences: ``handle_init`` (Meta-World's ``window_handle_pos_init``) is measured after the reset;
      Meta-World reads the site before its kinematics are updated, i.e. at the previous episode's window
      position (the same point whenever the window did not move). The hand starts with the TCP at Meta-World's
      ``hand_init_pos`` (0, 0.4, 0.2).
    * Physics note: the side of the Panda hand pushes the handle (see the scripted policy).
    """

    name = "window_open"
    mtbench_id = 49
    description = "Slide a window open horizontally."
    scene = SCENE
    reset_low = (-0.1, 0.7, 0.16)
    reset_high = (0.1, 0.9, 0.16)
    direction = +1.0
    handle_site_name = "handleOpenStart"

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        window = vec[:, :3]
        self.place_window(s, window, 0.0, mask)
        self.masked_set(s.obj_init_pos, window, mask)

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return window_reward(s.tcp, s.obj_pos, s.goal, s.buffers["handle_init"], s.init_tcp)[0]

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return window_success(s.obj_pos, s.goal)
