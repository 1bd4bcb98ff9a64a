"""Train MT-PPO / MT-GRPO on an mtbench env (Hydra front door).

    python examples/train.py                                   # GPU: MT10-rand, MT-PPO, paper sizes
                                                               # CPU: the small real preset env=cpu_small
    python examples/train.py env=mt10_rand loss=ppo arch=moore grad=pcgrad
    python examples/train.py loss=grpo env=mt50_rand seed=3
    python examples/train.py resume=outputs/<date>/<time>/checkpoints/last.pt   # same overrides as the run

Every option lives in conf/ (config.yaml, env/, loss/, arch/, grad/); see docs/training.md.
"""

from __future__ import annotations

import sys

import hydra
from omegaconf import DictConfig

from mtbench.trainer.run import main_argv, run


@hydra.main(config_path="../conf", config_name="config", version_base="1.3")
def main(cfg: DictConfig) -> None:
    run(cfg)


if __name__ == "__main__":
    sys.argv = main_argv()
    main()
