"""Multi-task network architectures (plain ``nn.Module``s and TensorDictModule builders)."""

from .mlp import MLP, activation_class, mlp_layers
from .registry import ARCHITECTURES, make_network, register_architecture

__all__ = ["ARCHITECTURES", "MLP", "activation_class", "make_network", "mlp_layers", "register_architecture"]
