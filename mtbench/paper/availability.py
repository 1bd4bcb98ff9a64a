"""Is a row runnable with the library as it is now? Decided at run time from the library itself, so that rows
become available when the env / loss / architecture / trainer feature they need lands, with no change here.

A row is available when
* its env name is one of ``mtbench.envs.setting_names()`` (and, for a Meta-World set, every task of the set is
  implemented and ``MetaWorldEnv`` accepts the row's env overrides),
* its loss is in the trainer's losses (``mtbench.trainer.LOSSES``), its architecture is registered
  (``mtbench.modules.ARCHITECTURES``) and its gradient method too (``mtbench.objectives.GRADIENT_METHODS``),
* every trainer feature it ``requires`` is a top-level key of ``conf/config.yaml`` (Parkour rows need
  ``pretrained``: starting from the flat-ground pre-training weights),
* the values it sets inside a group (``loss:``, ``grad:``, ...) are keys of the library's config for that option
  (``conf/<group>/<option>.yaml``), when that file exists,
* its pre-training row (if any) is available.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from omegaconf import OmegaConf

from .rows import CONF_DIR, GROUPS, Row

__all__ = ["FEATURES", "Library", "row_problems"]

# what a required config key means, for the messages
FEATURES: dict[str, str] = {
    "pretrained": "start from the flat-ground pre-training weights (MTBench's checkpoint=)",
}


def _no_env_problem(name: str, overrides: Mapping[str, Any]) -> str | None:
    return None


@dataclass
class Library:
    """What the library offers now (names of settings, losses, architectures, gradient methods, config keys)."""

    settings: frozenset[str]
    losses: frozenset[str]
    archs: frozenset[str]
    grads: frozenset[str]
    config_keys: frozenset[str]
    conf_dir: Path = CONF_DIR
    env_problem: Callable[[str, Mapping[str, Any]], str | None] = field(default=_no_env_problem)

    @classmethod
    def current(cls, conf_dir: Path = CONF_DIR) -> "Library":
        """Read the installed library (imports mtbench.envs, mtbench.trainer, mtbench.modules, mtbench.objectives)."""
        from mtbench.envs import setting_names
        from mtbench.modules import ARCHITECTURES
        from mtbench.objectives import GRADIENT_METHODS
        from mtbench.trainer import LOSSES

        return cls(
            settings=frozenset(setting_names()),
            losses=frozenset(LOSSES),
            archs=frozenset(ARCHITECTURES),
            grads=frozenset(GRADIENT_METHODS),
            config_keys=frozenset(OmegaConf.load(Path(conf_dir) / "config.yaml").keys()),  # type: ignore[arg-type]
            conf_dir=Path(conf_dir),
            env_problem=_metaworld_env_problem,
        )


def _metaworld_env_problem(name: str, overrides: Mapping[str, Any]) -> str | None:
    """For a Meta-World set: are all its tasks implemented, and does ``MetaWorldEnv`` take the overrides?"""
    from mtbench.envs import METAWORLD_SETS
    from mtbench.envs.metaworld import MetaWorldEnv, benchmark_tasks

    if name not in METAWORLD_SETS:
        return None
    try:
        benchmark_tasks(METAWORLD_SETS[name][0])
    except NotImplementedError as err:
        return f"env {name!r}: {err}"
    params = inspect.signature(MetaWorldEnv.__init__).parameters
    if not any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values()):
        unknown = sorted(k for k in overrides if k not in params)
        if unknown:
            return f"env {name!r}: MetaWorldEnv does not take the overrides {unknown}"
    return None


FREE_FORM_KEYS = ("env.overrides",)
"""Config nodes whose keys are keyword arguments checked elsewhere (``env.overrides``: the env constructor's, by
``env_problem``), so a row may set keys there that the library's yaml does not list."""


def _unknown_keys(row_values: Any, lib_values: Any, prefix: str) -> list[str]:
    """Dotted keys that ``row_values`` sets but ``lib_values`` does not have (free-form empty dicts and
    :data:`FREE_FORM_KEYS` accept all)."""
    if not isinstance(row_values, Mapping) or not isinstance(lib_values, Mapping) or not lib_values:
        return []
    if prefix.rstrip(".") in FREE_FORM_KEYS:
        return []
    out = []
    for key, value in row_values.items():
        if key not in lib_values:
            out.append(f"{prefix}{key}")
        else:
            out += _unknown_keys(value, lib_values[key], f"{prefix}{key}.")
    return out


def row_problems(row: Row, lib: Library, rows: Mapping[str, Row] | None = None) -> list[str]:
    """Why ``row`` cannot run now (empty when it can). ``rows``: the table's rows by name (for pre-training)."""
    problems: list[str] = []
    cfg = row.cfg
    env_name = cfg.env.name
    if isinstance(env_name, str):
        if env_name not in lib.settings:
            problems.append(f"env {env_name!r} is not built yet (not in mtbench.envs.setting_names())")
        else:
            node = cfg.env.get("overrides")
            overrides = OmegaConf.to_container(node, resolve=True) if node is not None else {}
            issue = lib.env_problem(env_name, overrides)  # type: ignore[arg-type]
            if issue:
                problems.append(issue)
    if cfg.loss.name not in lib.losses:
        problems.append(f"loss {cfg.loss.name!r} is not in the trainer's losses {sorted(lib.losses)}")
    if cfg.arch.name not in lib.archs:
        problems.append(f"arch {cfg.arch.name!r} is not registered (mtbench.modules.ARCHITECTURES)")
    if cfg.grad.name not in lib.grads:
        problems.append(f"gradient method {cfg.grad.name!r} is not registered (mtbench.objectives.GRADIENT_METHODS)")
    for key in row.requires:
        if key not in lib.config_keys:
            what = FEATURES.get(key, "a trainer feature")
            problems.append(f"needs the trainer option {key!r} ({what}), which conf/config.yaml does not have yet")
    for group in GROUPS:
        option = row.groups.get(group)
        path = lib.conf_dir / group / f"{option}.yaml"
        if option is None or group not in row.raw or not path.is_file():
            continue
        lib_cfg = OmegaConf.to_container(OmegaConf.load(path))
        row_cfg = OmegaConf.to_container(row.raw[group])
        unknown = _unknown_keys(row_cfg, lib_cfg, f"{group}.")
        if unknown:
            problems.append(f"sets {unknown}, which conf/{group}/{option}.yaml does not have")
    if row.pretrain is not None:
        pre = (rows or {}).get(row.pretrain)
        if pre is None:
            problems.append(f"pre-training row {row.pretrain!r} is missing from table {row.table!r}")
        else:
            problems += [f"pre-training row {pre.name}: {p}" for p in row_problems(pre, lib, rows)]
    return problems
