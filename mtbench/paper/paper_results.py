"""The MTBench paper's numbers (Joshi et al., RLC 2025; ``mtbench-paper.tex``), transcribed with the table and row
ids of ``conf/paper/<table>/<row>.yaml`` so that reports can put them beside ours.

* :data:`PAPER_VALUES`: ``{table: {row: {metric: PaperValue}}}``.
  - ``mt10_rand`` / ``mt50_rand``: appendix table ``table:main_table_results_metaworld`` ("Table 5"): success rate
    SR (%) and return R, point estimate with its 95 % bootstrapped CI; MT-PPO unless the row says otherwise; 1 B
    frames, 10 seeds.
  - ``parkour``: ``table:main_result_parkour`` ("Table 2"): progress P (%), mean +- standard deviation; 250 M
    frames (caption), 10 seeds. Row ids are ``<setting>_<variant>`` (setting ``easy``, ``hard``, ``hard_cl``).
  - ``efficiency`` (Figure ``fig:efficiency``) and ``cosine`` (Figure ``fig:cosine_sim``) are figures without
    numbers; :data:`PAPER_NOTES` keeps what the text states about them.
* :data:`APPENDIX_HPARAMS`: the appendix hyperparameter tables (MT-PPO, MT-GRPO, MT-PQN, MT-SAC, Parkour MT-PPO);
  a ``(mt10, mt50)`` tuple where the paper writes ``a / b`` (``(easy, hard)`` for Parkour).
* :data:`PAPER_LABELS`: the exact variant names of the tex, per table and row.

No torch import.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

__all__ = ["APPENDIX_HPARAMS", "PAPER_LABELS", "PAPER_NOTES", "PAPER_TABLES", "PAPER_VALUES", "PaperValue",
           "paper_value"]


@dataclass(frozen=True)
class PaperValue:
    """One number of the paper: ``value`` with its 95 % CI (``lo``, ``hi``) or its standard deviation ``std``."""

    value: float
    lo: float | None = None
    hi: float | None = None
    std: float | None = None

    def __str__(self) -> str:
        if self.lo is not None and self.hi is not None:
            return f"{self.value:.2f} [{self.lo:.2f}, {self.hi:.2f}]"
        if self.std is not None:
            return f"{self.value:.2f} ± {self.std:.2f}"
        return f"{self.value:.2f}"


def _ci(value: float, lo: float, hi: float) -> PaperValue:
    return PaperValue(value, lo=lo, hi=hi)


def _std(value: float, std: float) -> PaperValue:
    return PaperValue(value, std=std)


# ---------------------------------------------------------------------------------------------------------------
# Table 5 (appendix "More Results", label table:main_table_results_metaworld)
# columns: MT10-rand SR, MT10-rand R, MT50-rand SR, MT50-rand R
_TABLE5: dict[str, tuple[str, tuple[PaperValue, PaperValue, PaperValue, PaperValue]]] = {
    "vanilla": ("Vanilla", (
        _ci(87.51, 86.99, 87.97), _ci(1032.99, 1016.82, 1045.94),
        _ci(63.26, 60.91, 65.37), _ci(817.77, 789.13, 842.97))),
    "multihead": ("Multihead", (
        _ci(85.19, 81.42, 88.21), _ci(1005.69, 980.87, 1027.55),
        _ci(74.03, 71.47, 76.58), _ci(954.97, 939.72, 962.84))),
    "grpo_vanilla": ("GRPO-Vanilla", (
        _ci(91.12, 88.32, 93.96), _ci(916.32, 899.83, 933.60),
        _ci(74.48, 73.31, 75.64), _ci(916.83, 898.69, 935.66))),
    "pcgrad": ("PCGrad", (
        _ci(86.21, 83.19, 88.32), _ci(1038.27, 1022.88, 1050.59),
        _ci(59.74, 55.52, 64.12), _ci(760.99, 739.05, 772.13))),
    "cagrad": ("CAGrad", (
        _ci(82.98, 79.23, 86.27), _ci(938.43, 896.83, 972.29),
        _ci(67.70, 64.76, 70.53), _ci(874.45, 845.62, 903.10))),
    "famo": ("FAMO", (
        _ci(87.26, 82.53, 91.57), _ci(1016.11, 964.30, 1053.88),
        _ci(74.52, 73.25, 75.75), _ci(961.03, 946.64, 976.15))),
    "paco": ("PaCo", (
        _ci(84.37, 81.61, 86.61), _ci(995.39, 970.20, 1017.21),
        _ci(70.46, 67.01, 73.32), _ci(917.84, 881.61, 953.14))),
    "sh_moore": ("SH-MOORE", (
        _ci(84.60, 81.55, 87.59), _ci(1022.64, 1006.23, 1037.54),
        _ci(66.33, 64.56, 68.29), _ci(837.70, 815.00, 860.89))),
    "mh_moore": ("MH-MOORE", (
        _ci(86.94, 83.91, 89.01), _ci(1044.85, 1029.76, 1056.96),
        _ci(79.46, 77.40, 82.24), _ci(1019.59, 999.24, 1048.88))),
    "sh_care": ("SH-CARE", (
        _ci(81.51, 78.52, 84.49), _ci(964.28, 948.59, 979.89),
        _ci(67.51, 66.33, 68.72), _ci(842.04, 822.31, 864.66))),
    "mh_care": ("MH-CARE", (
        _ci(84.79, 81.34, 87.32), _ci(990.03, 972.35, 1006.34),
        _ci(71.05, 69.88, 72.30), _ci(863.88, 850.43, 878.51))),
    "soft_modularization": ("Soft-Modularization", (
        _ci(82.96, 80.15, 85.66), _ci(994.29, 980.24, 1009.03),
        _ci(67.72, 65.06, 69.93), _ci(860.41, 832.44, 883.77))),
}

# Table 2 (label table:main_result_parkour): progress P (%) mean +- std; columns easy, hard, hard-CL
_TABLE2: dict[str, tuple[str, tuple[PaperValue, PaperValue, PaperValue]]] = {
    "vanilla": ("Vanilla", (_std(80.39, 0.43), _std(54.51, 0.82), _std(68.12, 0.43))),
    "multihead": ("Multihead", (_std(73.17, 2.53), _std(49.65, 1.27), _std(62.17, 1.05))),
    "pcgrad": ("PCGrad", (_std(80.61, 0.78), _std(55.98, 0.24), _std(68.37, 0.65))),
    "cagrad": ("CAGrad", (_std(80.25, 0.32), _std(55.88, 0.91), _std(67.75, 0.43))),
    "famo": ("FAMO", (_std(79.79, 0.29), _std(55.56, 0.97), _std(68.57, 0.76))),
    "paco": ("PaCo", (_std(78.63, 0.70), _std(58.65, 0.77), _std(64.15, 0.98))),
    "sh_moore": ("SH-MOORE", (_std(64.61, 1.69), _std(46.78, 0.65), _std(49.53, 0.52))),
    "soft_modularization": ("Soft-Modularization", (_std(69.29, 3.81), _std(47.28, 0.23), _std(51.43, 0.35))),
}
PARKOUR_SETTINGS: tuple[tuple[str, str], ...] = (
    ("easy", "Parkour-easy"), ("hard", "Parkour-hard"), ("hard_cl", "Parkour-hard-CL"))

PAPER_VALUES: dict[str, dict[str, dict[str, PaperValue]]] = {
    "mt10_rand": {row: {"success": v[0], "return": v[1]} for row, (_, v) in _TABLE5.items()},
    "mt50_rand": {row: {"success": v[2], "return": v[3]} for row, (_, v) in _TABLE5.items()},
    "parkour": {f"{setting}_{row}": {"progress": v[i]}
                for row, (_, v) in _TABLE2.items() for i, (setting, _) in enumerate(PARKOUR_SETTINGS)},
    "efficiency": {},
    "cosine": {},
}

PAPER_LABELS: dict[str, dict[str, str]] = {
    "mt10_rand": {row: label for row, (label, _) in _TABLE5.items()},
    "mt50_rand": {row: label for row, (label, _) in _TABLE5.items()},
    "parkour": {f"{setting}_{row}": label for row, (label, _) in _TABLE2.items() for setting, _ in PARKOUR_SETTINGS},
}

# What each table reproduces: (source in the tex, metric, the paper's frames per run, the paper's seeds)
PAPER_TABLES: dict[str, dict[str, Any]] = {
    "mt10_rand": {"title": "Meta-World MT10-rand, MT-PPO variants",
                  "source": "Table 5 (appendix, table:main_table_results_metaworld), MT10-rand columns; Figure "
                            "fig: main_result_metaworld",
                  "metric": "success", "frames": 1_000_000_000, "seeds": 10, "interval": "95% bootstrap CI"},
    "mt50_rand": {"title": "Meta-World MT50-rand, MT-PPO variants",
                  "source": "Table 5 (appendix, table:main_table_results_metaworld), MT50-rand columns",
                  "metric": "success", "frames": 1_000_000_000, "seeds": 10, "interval": "95% bootstrap CI"},
    "parkour": {"title": "Parkour easy / hard / hard-CL, MT-PPO variants",
                "source": "Table 2 (table:main_result_parkour)",
                "metric": "progress", "frames": 250_000_000, "seeds": 10, "interval": "mean ± std over seeds"},
    "efficiency": {"title": "On-policy vs off-policy (MT-PPO, MT-GRPO, MT-SAC, MT-PQN)",
                   "source": "Figure fig:efficiency (no numbers; see PAPER_NOTES)",
                   "metric": "success", "frames": None, "seeds": 10, "interval": "pointwise 95% bootstrap CI"},
    "cosine": {"title": "Actor vs critic task-gradient cosine similarity, MT10-rand",
               "source": "Figure fig:cosine_sim (no numbers)",
               "metric": "success", "frames": 1_000_000_000, "seeds": 10, "interval": "min-max band"},
}

PAPER_NOTES: dict[str, list[str]] = {
    "efficiency": [
        "MT10-rand after 200M frames: MT-PPO took roughly 22 minutes, MT-SAC roughly 12 hours (wall-clock).",
        "MT-SAC matched to MT-PPO's gradient steps per epoch reaches a near-zero success rate.",
        "MT-PQN, left to run long enough, roughly matches MT-PPO in MT10-rand.",
    ],
    "cosine": [
        "Critic task gradients show lower minimum cosine similarities than actor task gradients (O3: value "
        "learning is the bottleneck).",
    ],
    "parkour": [
        "Curriculum (hard-CL) vs no curriculum (hard): about +10 progress points (O4).",
        "Caption: 250M frames per run; appendix: 2000 / 4000 PPO epochs for easy / hard (4096 envs x 32 steps: "
        "262M / 524M frames). The rows follow the appendix epochs.",
    ],
    "mt10_rand": [
        "Vanilla MT-PPO asymptotically outperforms the multi-task architectures in MT10-rand (O2).",
    ],
    "mt50_rand": [
        "MH-MOORE surpasses vanilla MT-PPO by roughly 16 points of success rate in MT50-rand (O2).",
    ],
}


def paper_value(table: str, row: str, metric: str) -> PaperValue | None:
    """The paper's number for ``(table, row, metric)``, or ``None`` when the paper gives none."""
    return PAPER_VALUES.get(table, {}).get(row, {}).get(metric)


# ---------------------------------------------------------------------------------------------------------------
# Appendix hyperparameter tables ("Hyperparameter Details"); (a, b) = "a / b" in the paper (MT10 / MT50, or
# Parkour-easy / Parkour-hard). Keys are the paper's variable_name column.
APPENDIX_HPARAMS: dict[str, dict[str, Any]] = {
    "mt_ppo": {
        "num_envs": (24576, 24576), "network.mlp.units": [256, 128, 64], "minibatch_size": (16384, 32768),
        "horizon": 32, "mini_epochs": 5, "max_epochs": (1272, 1272), "episodeLength": 150, "gamma": 0.99,
        "e_clip": 0.2, "entropy_coef": 0.005, "learning_rate": 5e-4, "lr_schedule": "fixed", "tau": 0.95,
        "normalize_value": True, "normalize_input": True, "network.separate": True,
    },
    "care": {
        "care.units": [400, 400, 400], "encoder.num_experts": 6, "encoder.num_layers": 2, "encoder.D": 50,
        "encoder.temperature": 1.0, "attention.units": [50, 50], "context_encoder.units": [50, 50],
        "context_encoder.bias": True,
    },
    "moore": {
        "moore.num_experts": (4, 6), "moore.num_layers": 3, "moore.D": 400, "moore.agg_activation": ["Linear", "Tanh"],
        "task_encoder.units": [256], "task_encoder.bias": False,
    },
    "paco": {
        "paco.K": (5, 20), "paco.D": 400, "paco.num_layers": 3, "task_encoder.bias": False,
        "task_encoder.compositional_initializer": "orthogonal", "task_encoder.activation": "softmax",
    },
    "soft_modularization": {
        "soft_network.num_experts": 2, "soft_network.num_layer": 4, "state_encoder.units": [256, 256],
        "task_encoder.units": [256],
    },
    "pcgrad": {"num_envs": (24576, 8192), "project_actor_gradient": False, "project_critic_gradient": True},
    "cagrad": {"num_envs": (24576, 6144), "project_actor_gradient": False, "project_critic_gradient": True, "c": 0.4},
    "famo": {"gamma": 1e-3, "w_lr": 1e-3, "epsilon": 1e-2, "norm_w_grad": True},
    "mt_grpo": {
        "num_envs": (4096, 24576), "minibatch_size": (16384, 76800), "episodeLength": 150, "horizon": 150,
        "mini_epochs": 5, "max_epochs": (1908, 1272), "gamma": 0.99, "e_clip": 0.2, "entropy_coef": 0.005,
        "learning_rate": 5e-4, "lr_schedule": "fixed", "tau": 0.95, "normalize_value": True,
        "normalize_input": True, "network.separate": True,
    },
    "mt_pqn": {  # MT10 only
        "num_envs": 8192, "gamma": 0.99, "q_lambda": 0.5, "num_minibatches": 4, "episodeLength": 500,
        "binsPerDim": 3, "actionScale": 0.005, "mini_epochs": 8, "max_grad_norm": 10.0, "horizon": 16,
        "start_e": 1.0, "end_e": 0.005, "decay_epsilon": True, "exploration_fraction": 0.005, "critic_lr": 3e-4,
        "anneal_lr": True, "normalize_value": False, "normalize_input": False, "q.residual_network": True,
        "q.num_blocks": 2, "q.D": 256, "q.norm_first_layer": False,
    },
    "mt_sac": {  # MT10 and MT50 alike
        "num_envs": 4096, "network.mlp.units": [512, 256, 128], "gamma": 0.99, "network.separate": True,
        "gradient_steps_per_itr": 32, "learnable_temperature": True, "use_disentangled_alpha": True,
        "init_alpha": 1.0, "alpha_lr": 5e-3, "critic_lr": 5e-4, "critic_tau": 0.01, "batch_size": 8192,
        "nstep": 16, "grad_norm": 0.5, "horizon": 1, "normalize_value": True, "normalize_input": True,
        "replay_buffer_size": 5_000_000, "target_entropy_coef": 1.0,
    },
    "parkour_ppo": {
        "minibatch_size": 16384, "horizon": 32, "mini_epochs": 5, "max_epochs": (2000, 4000), "episodeLength": 800,
        "gamma": 0.99, "e_clip": 0.2, "entropy_coef": 0.005, "learning_rate": 5e-4, "lr_schedule": "adaptive",
        "tau": 0.95, "normalize_value": False, "normalize_input": False, "network.separate": True,
        "moore.num_experts": 2, "moore.num_layers": 2, "moore.D": 256, "moore.agg_activation": ["Linear", "Linear"],
        "moore.task_encoder.units": [128], "task_encoder.bias": False, "multi_head": False,
        "paco.K": 5, "paco.D": 400, "paco.num_layers": 3,
        "soft_network.num_experts": 2, "soft_network.num_layer": 2, "state_encoder.units": [256, 256],
        "soft_network.task_encoder.units": [128],
        "project_actor_gradient": False, "project_critic_gradient": True, "c": 0.4,
        "famo.gamma": 1e-4, "famo.w_lr": 5e-3, "famo.epsilon": 1e-3, "famo.norm_w_grad": True,
    },
}
