"""Multi-task losses and gradient-manipulation wrappers."""

from .gradients import compute_gradients, total_loss
from .grpo import MTGRPOLoss
from .per_task_gae import PerTaskGAE
from .per_task_returns import PerTaskMCAdvantage, discounted_reward_to_go, grpo_advantages
from .peng_q_lambda import PengQLambda, peng_q_lambda
from .pqn import MTPQNLoss
from .ppo import MTClipPPOBase, MTPPOLoss

# off-policy (MT-SAC)
from .nstep import NStepTransitions, nstep_transitions
from .sac import MTSACLoss

# gradient manipulation (issue #5)
from .cagrad import CAGrad, cagrad, cagrad_weights
from .diagnostics import DIAGNOSTIC_KEYS, GradientDiagnostics
from .famo import FAMO
from .grad_method import GRADIENT_METHODS, make_gradient_method
from .param_groups import PARAM_GROUPS, resolve_param_group
from .pcgrad import PCGrad, pcgrad, pcgrad_weights
from .per_task import task_means
from .task_gradients import cosine_stats, per_task_gradients
from .task_wrapper import TaskGradientWrapper

__all__ = [
    "MTClipPPOBase",
    "MTGRPOLoss",
    "MTPPOLoss",
    "MTPQNLoss",
    "MTSACLoss",
    "NStepTransitions",
    "PengQLambda",
    "PerTaskGAE",
    "PerTaskMCAdvantage",
    "compute_gradients",
    "discounted_reward_to_go",
    "grpo_advantages",
    "nstep_transitions",
    "peng_q_lambda",
    "total_loss",
    # gradient manipulation
    "CAGrad",
    "DIAGNOSTIC_KEYS",
    "FAMO",
    "GRADIENT_METHODS",
    "GradientDiagnostics",
    "PARAM_GROUPS",
    "PCGrad",
    "TaskGradientWrapper",
    "cagrad",
    "cagrad_weights",
    "cosine_stats",
    "make_gradient_method",
    "pcgrad",
    "pcgrad_weights",
    "per_task_gradients",
    "resolve_param_group",
    "task_means",
]
