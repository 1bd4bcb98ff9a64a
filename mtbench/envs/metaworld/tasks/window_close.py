"""Window close: slide an open window sash shut by pushing its handle sideways (Meta-World ``window-close-v3``)."""

from __future__ import annotations

import torch

from ..task import MetaWorldTask, TaskState
from ._window import SCENE, SLIDE_TRAVEL, WindowSceneMixin, window_reward, window_success


class WindowClose(WindowSceneMixin, MetaWorldTask):
    """Slide the window closed by 20 cm along -x (Meta-World ``window-close-v3`` on the Panda).

    * Reset: window frame at x = 0, y ~ U[0.75, 0.9], z = 0.2 (Meta-World frame; MTBench: x_mtb ~ U[.15, .3],
      y_mtb = 0), sash open (slide 0.2). Goal (MTBench's ``target_pos``) = the handle point at reset moved back
      through the full 0.2 travel (-x); ``obj_init_pos`` = the window position.
    * Observation: object 1 = site ``handleCloseStart`` (``window + (0.01 + slide, -0.095, 0)``), zero quaternion
      (as Meta-World); no object 2.
    * Dense reward (paper-era MTBench ``task_fns/window_close.py``): ``H(reach, in_place)`` (see
      :func:`._window.window_reward`: 1 cm in-place bound, Gaussian 2 cm reach), ``dense_scale`` 0.01.
      (Meta-World v2: ``10 · H(reach, in_place)`` on the x error with a 5 cm bound.)
    * Success (paper-era MTBench, ``‖obj − target‖ ≤ 0.01`` in 3-D): MTBench's obj is the handle and its target
      the initial (open) handle position moved back through the full 0.2 travel. In Meta-World's frame (MTBench's +y
      is Meta-World's -x): ``‖handle − (handle_init − (0.2, 0, 0))‖ ≤ 0.01``, i.e. the slide is within 1 cm of
      closed. Meta-World's own rule (``|handle_x − goal_x| ≤ 0.05``) accepts a slide up to 0.04.
    * Differences: ``handle_init`` (Meta-World's ``window_handle_pos_init``) is the handle point measured after the
      reset, with the sash open. Meta-World computes it as the site position before its kinematics are updated
      (sash closed, previous episode's window position) plus (0.2, 0, 0): the same point whenever the window did
      not move. The hand starts with the TCP at Meta-World's ``hand_init_pos`` (0, 0.4, 0.2).
    * Physics note: the side of the Panda hand pushes the handle (see the scripted policy).
    """

    name = "window_close"
    mtbench_id = 48
    description = "Slide a window closed horizontally."
    scene = SCENE
    reset_low = (0.0, 0.75, 0.2)
    reset_high = (0.0, 0.9, 0.2)
    direction = -1.0
    handle_site_name = "handleCloseStart"

    def reset(self, s: TaskState, vec: torch.Tensor, mask: torch.Tensor) -> None:
        window = vec[:, :3]
        self.place_window(s, window, SLIDE_TRAVEL, mask)
        self.masked_set(s.obj_init_pos, window, mask)

    def reward(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return window_reward(s.tcp, s.obj_pos, s.goal, s.buffers["handle_init"], s.init_tcp)[0]

    def success(self, s: TaskState, action: torch.Tensor) -> torch.Tensor:
        return window_success(s.obj_pos, s.goal)
