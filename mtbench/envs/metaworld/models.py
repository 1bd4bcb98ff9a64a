"""Compile each task's MuJoCo model once per process (shared by every env that uses the task)."""

from __future__ import annotations

from functools import lru_cache

import mujoco
import numpy as np

from ...sim import groupable
from .registry import task_class
from .scene import build_scene
from .task import MetaWorldTask


@lru_cache(maxsize=None)
def compiled_task(name: str, robot_collision: str = "primitive") -> tuple[type[MetaWorldTask], mujoco.MjModel]:
    """``(task class, compiled MjModel)`` for the task ``name`` with the given hand/finger collision geometry."""
    cls = task_class(name)
    return cls, build_scene(cls.scene, edit_spec=cls.edit_spec, robot_collision=robot_collision)


def kinematic_signature(m: mujoco.MjModel) -> tuple:
    """The kinematic tree: sizes, parent bodies, joint types and bodies, equality constraint types."""
    return (m.nq, m.nv, m.nbody, tuple(m.body_parentid), tuple(m.jnt_type), tuple(m.jnt_bodyid), m.neq,
            tuple(m.eq_type))


def strict_signature(m: mujoco.MjModel) -> tuple:
    """The kinematic tree plus the fields a MuJoCo Warp model shares across its worlds: models with the same
    strict signature can be simulated as one MuJoCo Warp model whose differing fields are batched per world
    (``MetaWorldEnv(group_models=True)``; :func:`mtbench.sim.per_world_fields` checks the remaining fields)."""
    return kinematic_signature(m) + (
        m.ngeom, tuple(m.geom_type), tuple(m.geom_bodyid), tuple(m.geom_contype), tuple(m.geom_conaffinity),
        tuple(m.geom_condim), m.nmesh, m.nmeshvert, m.nhfield, m.nsite, m.nu, m.nmocap, m.nkey, tuple(m.eq_obj1id),
        tuple(m.eq_obj2id), tuple(np.round(m.jnt_axis, 6).ravel()), m.ntendon, m.nsensor)


def physics_groups(models: list[mujoco.MjModel]) -> list[list[int]]:
    """Indices of ``models`` that can share one MuJoCo Warp model (``MetaWorldEnv(group_models=True)``), adjacent or
    not: each model joins the first earlier group of its :func:`strict_signature` that it can be batched with
    (:func:`mtbench.sim.groupable`), else starts a group; groups in the order of their first model."""
    groups: list[list[int]] = []
    signatures = [strict_signature(m) for m in models]
    for i, m in enumerate(models):
        for group in groups:
            if signatures[group[0]] == signatures[i] and groupable([models[j] for j in group] + [m]):
                group.append(i)
                break
        else:
            groups.append([i])
    return groups
