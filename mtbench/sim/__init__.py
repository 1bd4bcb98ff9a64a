"""MuJoCo Warp simulation layer: physics only, no task semantics."""

from .warp_sim import WarpSim, launch_all, warp_device

__all__ = ["WarpSim", "launch_all", "warp_device"]
