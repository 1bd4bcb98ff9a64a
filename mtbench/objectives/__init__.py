"""Multi-task losses and gradient-manipulation wrappers."""

from .gradients import compute_gradients, total_loss
from .grpo import MTGRPOLoss, discounted_reward_to_go, grpo_advantages
from .ppo import MTClipPPOBase, MTPPOLoss

__all__ = [
    "MTClipPPOBase",
    "MTGRPOLoss",
    "MTPPOLoss",
    "compute_gradients",
    "discounted_reward_to_go",
    "grpo_advantages",
    "total_loss",
]
