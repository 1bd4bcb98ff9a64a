"""MT-PPO / MT-GRPO training pipeline (Hydra front door in examples/train.py)."""
