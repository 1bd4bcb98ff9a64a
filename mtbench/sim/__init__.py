"""MuJoCo Warp simulation layer: physics only, no task semantics."""

from .warp_sim import FATAL_OVERFLOW, HFIELD_OVERFLOW, WarpSim, launch_all, warp_device

__all__ = ["FATAL_OVERFLOW", "HFIELD_OVERFLOW", "WarpSim", "launch_all", "warp_device"]
