"""Multi-task losses and gradient-manipulation wrappers."""

from .gradients import compute_gradients, total_loss

__all__ = ["compute_gradients", "total_loss"]
