"""The scandots: terrain heights under a 12 x 11 grid of points around the base, read from the height grid in torch.

MTBench (``legged_base.py`` ``_get_heights``) samples the terrain's height grid (not ray casts): each point, given in
the base frame on ``x in SCAN_X``, ``y in SCAN_Y`` (x-major order: point ``k`` is
``(SCAN_X[k // 11], SCAN_Y[k % 11])``), is turned about z by a heading (the env passes the original's
``quat_apply_yaw`` heading, 2 atan2(q_z, q_w)) and moved to the base position; the grid index is
``floor((p + border) / hs)`` (clipped to the grid) and the height is the minimum of the samples at ``(a, b)``,
``(a + 1, b)`` and ``(a, b + 1)``.
"""

from __future__ import annotations

import torch

SCAN_X = (-0.45, -0.3, -0.15, 0.0, 0.15, 0.3, 0.45, 0.6, 0.75, 0.9, 1.05, 1.2)
SCAN_Y = (-0.75, -0.6, -0.45, -0.3, -0.15, 0.0, 0.15, 0.3, 0.45, 0.6, 0.75)
NUM_SCAN_POINTS = len(SCAN_X) * len(SCAN_Y)  # 132


def scan_points(device: torch.device | str = "cpu") -> torch.Tensor:
    """Base-frame scan points ``[132, 2]`` in the original's x-major order."""
    gx, gy = torch.meshgrid(torch.tensor(SCAN_X), torch.tensor(SCAN_Y), indexing="ij")
    return torch.stack([gx.flatten(), gy.flatten()], dim=-1).to(device=device, dtype=torch.float32)


class HeightGrid:
    """The terrain height grid on the device, sampled as MTBench samples it.

    Args:
        heights: ``[nx, ny]`` metres; cell ``(a, b)`` at world ``(-border + a*hs, -border + b*hs)``.
        horizontal_scale: ``hs`` (m).
        border_size: ``border`` (m).
    """

    def __init__(self, heights: torch.Tensor, horizontal_scale: float, border_size: float) -> None:
        self.heights = heights.float()
        self.hs = float(horizontal_scale)
        self.border = float(border_size)
        self._flat = self.heights.reshape(-1)
        self._ny = self.heights.shape[1]

    def min3(self, x: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
        """Minimum height of the grid samples ``(a, b)``, ``(a+1, b)``, ``(a, b+1)`` at world points ``x, y`` (any
        shape), ``a = floor((x + border) / hs)`` clipped to ``[0, nx - 2]`` (same for ``b``)."""
        nx, ny = self.heights.shape
        a = torch.floor((x + self.border) / self.hs).long().clamp(0, nx - 2)
        b = torch.floor((y + self.border) / self.hs).long().clamp(0, ny - 2)
        i = a * ny + b
        h = torch.minimum(self._flat[i], self._flat[i + ny])
        return torch.minimum(h, self._flat[i + 1])

    def scan(self, base_xy: torch.Tensor, yaw: torch.Tensor, points: torch.Tensor) -> torch.Tensor:
        """Ground heights ``[N, P]`` under the scan ``points`` ``[P, 2]`` of bases at world ``base_xy`` ``[N, 2]``
        with heading ``yaw`` ``[N]``."""
        c, s = torch.cos(yaw)[:, None], torch.sin(yaw)[:, None]
        px, py = points[:, 0][None, :], points[:, 1][None, :]
        x = c * px - s * py + base_xy[:, 0:1]
        y = s * px + c * py + base_xy[:, 1:2]
        return self.min3(x, y)
