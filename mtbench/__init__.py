"""mtbench: TorchRL-native massively parallel multi-task RL on MuJoCo Warp."""

__version__ = "0.1.0"
