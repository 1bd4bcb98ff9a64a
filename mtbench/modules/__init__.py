"""Multi-task network architectures (plain ``nn.Module``s and TensorDictModule builders).

Registered names (``make_network(arch, ...)``): ``mlp``, ``multihead``, ``soft_modularization``, ``care``,
``care_mh``, ``paco``, ``moore``, ``moore_mh``, ``residual_mlp``. See docs/architectures.md.
"""

from .care import CARE
from .compositional_linear import CompositionalLinear
from .experts import ParallelExperts
from .gram_schmidt import gram_schmidt
from .mlp import MLP, activation_class, mlp_layers
from .moore import MOORE
from .multihead import MultiHeadMLP
from .paco import PaCo
from .q_network import DecomposedQNetwork, decomposed_q_value, greedy_value, make_q_network, make_q_policy
from .residual_mlp import ResidualMLP
from .registry import ARCHITECTURES, arch_kwargs, make_network, register_architecture
from .soft_modularization import SoftModularization
from .stacked_linear import StackedLinear
from .task_embeddings import pretrained_task_embeddings
from .td_module import make_td_network

__all__ = [
    "ARCHITECTURES",
    "CARE",
    "CompositionalLinear",
    "DecomposedQNetwork",
    "MLP",
    "MOORE",
    "MultiHeadMLP",
    "PaCo",
    "ParallelExperts",
    "ResidualMLP",
    "SoftModularization",
    "StackedLinear",
    "activation_class",
    "arch_kwargs",
    "decomposed_q_value",
    "gram_schmidt",
    "greedy_value",
    "make_network",
    "make_q_network",
    "make_q_policy",
    "make_td_network",
    "mlp_layers",
    "pretrained_task_embeddings",
    "register_architecture",
]
