"""Send every iteration's metrics to a TorchRL ``Logger`` (e.g. ``mtbench.logging.MCAPLogger``)."""

from __future__ import annotations

from typing import Any

from omegaconf import OmegaConf

from .base import TrainerHook


class MetricsLogger(TrainerHook):
    """Logs the run's config once as hyperparameters (with the env's ``env_info``) and each iteration's metrics
    at ``step = frames``. Its state (the logger's counters, whether the hyperparameters were logged) is part of
    checkpoints, so a resumed run continues the same log (``MCAPLogger(if_exists="append")``)."""

    name = "metrics_logger"

    def __init__(self, logger: Any) -> None:
        self.logger = logger
        self.hparams_logged = False

    def on_train_start(self, trainer: Any) -> None:
        if self.hparams_logged or trainer.config is None:
            return
        hparams = OmegaConf.to_container(trainer.config, resolve=True)
        hparams["env_info"] = trainer.env_info()  # e.g. the reward version the env actually runs
        self.logger.log_hparams(OmegaConf.create(hparams))
        self.hparams_logged = True

    def on_iteration_end(self, trainer: Any, metrics: dict[str, float]) -> None:
        self.logger.log_metrics(metrics, step=trainer.frames)

    def state_dict(self) -> dict[str, Any]:
        """TorchRL's ``Logger.state_dict()`` (it also flushes: the metrics up to the checkpoint are on disk)."""
        logger_state = getattr(self.logger, "state_dict", None)
        return {"hparams_logged": self.hparams_logged, "logger": logger_state() if callable(logger_state) else None}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.hparams_logged = bool(state.get("hparams_logged", True))
        load = getattr(self.logger, "load_state_dict", None)
        if state.get("logger") is not None and callable(load):
            load(state["logger"])


__all__ = ["MetricsLogger"]
