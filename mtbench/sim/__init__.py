"""MuJoCo Warp simulation layer: physics only, no task semantics."""

from .warp_sim import FATAL_OVERFLOW, HFIELD_OVERFLOW, WarpSim, launch_all, warp_device
from .world_groups import UngroupableModels, WarpSimSlice, differing_arrays, groupable, per_world_fields

__all__ = ["FATAL_OVERFLOW", "HFIELD_OVERFLOW", "UngroupableModels", "WarpSim", "WarpSimSlice", "differing_arrays",
           "groupable", "launch_all", "per_world_fields", "warp_device"]
