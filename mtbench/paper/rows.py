"""The paper's tables as row configs: ``conf/paper/<table>/<row>.yaml``, composed with Hydra.

Every row file is a primary Hydra config: ``defaults: [/config, override /env: ..., override /loss: ...,
override /arch: ..., override /grad: ..., _self_]`` followed by the paper's values for the row (env size, loss
hyperparameters, gradient-method and architecture values where they differ by row, ``total_frames``) and a
``paper:`` node of metadata (table, row, label = the paper's exact variant name, source, metric, seeds, the
group options the row stands for, and for Parkour the pre-training row and required trainer features).

A group option that the library does not have yet (a Parkour env config, the MT-SAC / MT-PQN losses) is selected as
``null`` and given inline, so that every row composes today; ``paper.groups`` names the option, which
:func:`group_overrides` selects on the command line once its ``conf/<group>/<option>.yaml`` exists (the row's own
values still apply on top).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any, Sequence

from omegaconf import DictConfig, OmegaConf

__all__ = [
    "CONF_DIR",
    "GROUPS",
    "REPO_ROOT",
    "Row",
    "TABLE_ORDER",
    "compose_row",
    "compose_rows",
    "group_overrides",
    "load_table",
    "row_names",
    "table_names",
]

REPO_ROOT = Path(__file__).resolve().parents[2]
CONF_DIR = REPO_ROOT / "conf"
GROUPS = ("env", "loss", "arch", "grad")
TABLE_ORDER = ("mt10_rand", "mt50_rand", "parkour", "efficiency", "cosine")


def _paper_dir(conf_dir: Path) -> Path:
    return Path(conf_dir) / "paper"


def table_names(conf_dir: Path = CONF_DIR) -> list[str]:
    """Tables with at least one row config, the paper's order first."""
    root = _paper_dir(conf_dir)
    found = sorted(p.name for p in root.iterdir() if p.is_dir() and any(p.glob("*.yaml"))) if root.is_dir() else []
    return [t for t in TABLE_ORDER if t in found] + [t for t in found if t not in TABLE_ORDER]


def row_names(table: str, conf_dir: Path = CONF_DIR) -> list[str]:
    """Row ids of ``table`` in file order (sorted), pre-training rows first."""
    root = _paper_dir(conf_dir) / table
    if not root.is_dir():
        raise ValueError(f"unknown table {table!r}; valid choices: {table_names(conf_dir)}")
    names = sorted(p.stem for p in root.glob("*.yaml"))
    raw = {n: OmegaConf.load(root / f"{n}.yaml").get("paper", {}) for n in names}
    return sorted(names, key=lambda n: (raw[n].get("role") != "pretrain", _paper_order(table, n)))


def _paper_order(table: str, row: str) -> tuple[int, str]:
    """Sort key: the order of the paper's table where it has one, else the name."""
    from .paper_results import PAPER_VALUES

    order = list(PAPER_VALUES.get(table, {})) or [
        f"{s}_{a}" for s in ("mt10_rand", "mt50_rand") for a in ("ppo", "grpo", "sac", "pqn")]
    if table == "parkour":  # variants in the paper's order within each setting
        from .paper_results import PARKOUR_SETTINGS, _TABLE2

        order = [f"{s}_{v}" for s, _ in PARKOUR_SETTINGS for v in _TABLE2]
    return (order.index(row) if row in order else len(order), row)


def compose_row(table: str, row: str, overrides: Sequence[str] = (), conf_dir: Path = CONF_DIR) -> DictConfig:
    """The composed config of ``conf/paper/<table>/<row>.yaml``: what ``examples/train.py --config-dir
    conf/paper/<table> --config-name <row> <overrides>`` runs (less Hydra's own node)."""
    return compose_rows(table, [row], overrides, conf_dir)[row]


def compose_rows(
    table: str, rows: Sequence[str], overrides: Sequence[str] = (), conf_dir: Path = CONF_DIR
) -> dict[str, DictConfig]:
    """Compose several rows of one table in one Hydra context (the table folder as the primary config dir and
    ``conf/`` on the search path, as ``examples/train.py --config-dir conf/paper/<table>`` does).

    Results are cached per process until a YAML file under ``conf_dir`` changes; callers get copies."""
    conf = Path(conf_dir).resolve()
    folder = _paper_dir(conf) / table
    for row in rows:
        if not (folder / f"{row}.yaml").is_file():
            raise ValueError(f"no row config {folder / row}.yaml; valid rows of {table!r}: {row_names(table, conf)}")
    key = (str(conf), table, tuple(overrides), _fingerprint(conf))
    cached = _CACHE.setdefault(key, {})
    missing = [r for r in rows if r not in cached]
    if missing:
        from hydra import compose, initialize_config_dir
        from hydra.core.global_hydra import GlobalHydra

        if GlobalHydra.instance().is_initialized():  # compose() needs its own context
            GlobalHydra.instance().clear()
        search = [f"hydra.searchpath=[file://{conf}]", *overrides]
        with initialize_config_dir(config_dir=str(folder), version_base="1.3"):
            for row in missing:
                cached[row] = compose(config_name=row, overrides=search)
    return {row: copy.deepcopy(cached[row]) for row in rows}


_CACHE: dict[tuple, dict[str, DictConfig]] = {}


def _fingerprint(conf: Path) -> tuple[int, int]:
    """(number of YAML files, newest modification time) of ``conf``: changes when a config is edited or added."""
    stamps = [p.stat().st_mtime_ns for p in conf.rglob("*.yaml")]
    return len(stamps), max(stamps, default=0)


@dataclass
class Row:
    """One row of a paper table: its config file, composed config and ``paper`` metadata."""

    table: str
    name: str
    path: Path
    cfg: DictConfig

    @cached_property
    def meta(self) -> dict[str, Any]:
        return OmegaConf.to_container(self.cfg.get("paper") or {}, resolve=True)  # type: ignore[return-value]

    @cached_property
    def raw(self) -> DictConfig:
        """The row file itself (uncomposed): the values the row sets."""
        return OmegaConf.load(self.path)

    @property
    def label(self) -> str:
        return str(self.meta.get("label", self.name))

    @property
    def seeds(self) -> list[int]:
        return [int(s) for s in self.meta.get("seeds", [42])]

    @property
    def metric(self) -> str:
        return str(self.meta.get("metric", "success"))

    @property
    def groups(self) -> dict[str, str]:
        return {str(k): str(v) for k, v in (self.meta.get("groups") or {}).items()}

    @property
    def pretrain(self) -> str | None:
        value = self.meta.get("pretrain")
        return None if value is None else str(value)

    @property
    def requires(self) -> list[str]:
        return [str(r) for r in self.meta.get("requires") or []]

    @property
    def is_pretrain(self) -> bool:
        return self.meta.get("role") == "pretrain"

    @property
    def frames(self) -> int:
        """The paper's frames per run (``total_frames``; ``max_iterations`` x batch when it is null)."""
        if self.cfg.get("total_frames") is not None:
            return int(self.cfg.total_frames)
        return int(self.cfg.max_iterations) * int(self.cfg.env.num_envs) * int(self.cfg.loss.horizon)

    def describe(self) -> str:
        c = self.cfg
        return (f"env={c.env.name} loss={c.loss.name} arch={c.arch.name} grad={c.grad.name} "
                f"envs={c.env.num_envs}")


def load_table(table: str, conf_dir: Path = CONF_DIR, rows: Sequence[str] | None = None) -> list[Row]:
    """The composed rows of ``table`` (all, or ``rows`` in the given order)."""
    names = row_names(table, conf_dir)
    if rows is not None:
        unknown = [r for r in rows if r not in names]
        if unknown:
            raise ValueError(f"unknown rows {unknown} of table {table!r}; valid choices: {names}")
        names = list(rows)
    root = _paper_dir(conf_dir) / table
    cfgs = compose_rows(table, names, conf_dir=conf_dir)
    return [Row(table, n, root / f"{n}.yaml", cfgs[n]) for n in names]


def group_overrides(row: Row, conf_dir: Path = CONF_DIR) -> list[str]:
    """Hydra overrides that select the row's group options: ``<group>=<option>`` where
    ``conf/<group>/<option>.yaml`` exists, ``env=null`` for an env option that does not exist yet (every launch names
    ``env=`` so that ``examples/train.py`` does not swap in its CPU preset)."""
    out = []
    for group in GROUPS:
        option = row.groups.get(group)
        if option is None:
            continue
        if (Path(conf_dir) / group / f"{option}.yaml").is_file():
            out.append(f"{group}={option}")
        elif group == "env":
            out.append("env=null")
    return out
