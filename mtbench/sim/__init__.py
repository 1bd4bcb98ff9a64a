"""MuJoCo Warp simulation layer: physics only, no task semantics."""

from .warp_sim import WarpSim, step_all, warp_device

__all__ = ["WarpSim", "step_all", "warp_device"]
