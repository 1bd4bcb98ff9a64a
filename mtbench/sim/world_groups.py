"""Several compiled MuJoCo models of one structure simulated as one MuJoCo Warp model (physics only).

Models that differ only in fields MuJoCo Warp can batch per world (``body_pos``, ``site_pos``, ``geom_size``, ...),
in their keyframes, or in fields MuJoCo Warp does not read (names, colours, cameras, lights) can share one
:class:`~mtbench.sim.WarpSim` (``WarpSim(..., world_models=...)``): each model's worlds get that model's values of
the batched fields and its own keyframes. :class:`WarpSimSlice` exposes one model's world range of such a sim with
the attributes of a :class:`~mtbench.sim.WarpSim`.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Sequence

import mujoco
import mujoco_warp as mjw
import numpy as np
import torch

if TYPE_CHECKING:
    from .warp_sim import WarpSim

KEY_FIELDS = ("key_time", "key_qpos", "key_qvel", "key_act", "key_mpos", "key_mquat", "key_ctrl", "key_plastic")
# MjModel arrays MuJoCo Warp neither reads nor derives anything from (visual / naming data, and body_sameframe,
# which MuJoCo Warp 4.0 does not use); checked against the mjw.Model fields: such a field must not be one of them
_IGNORED_PREFIXES = ("name_", "cam_", "light_", "mat_", "tex_", "skin_", "vis_")
_IGNORED_SUFFIXES = ("_rgba",)
_IGNORED_NAMES = frozenset({"names", "paths", "body_sameframe", "names_map"})


class UngroupableModels(ValueError):
    """The models differ in a field that MuJoCo Warp shares across the worlds of one model."""


def differing_arrays(models: Sequence[mujoco.MjModel]) -> set[str]:
    """Names of the model arrays whose values (or shapes) differ between the first model and any other."""
    m0, names = models[0], set()
    for m in models[1:]:
        for name in dir(m0):
            a = getattr(m0, name) if not name.startswith("_") else None
            if isinstance(a, np.ndarray) and a.dtype != object:
                b = getattr(m, name)
                if a.shape != b.shape or not np.array_equal(a, b):
                    names.add(name)
    return names


def _mjw_array_shapes() -> dict[str, tuple]:
    from mujoco_warp._src import warp_util

    return {f.name: tuple(f.type.shape) for f in dataclasses.fields(mjw.Model) if warp_util.is_array_spec(f.type)}


def batchable_fields() -> frozenset[str]:
    """The ``mjw.Model`` fields MuJoCo Warp can hold one copy of per world (leading ``*`` dimension)."""
    return frozenset(name for name, shape in _mjw_array_shapes().items() if shape and shape[0] == "*")


def _ignored(name: str, mjw_fields: dict) -> bool:
    if name in mjw_fields:
        return False
    return name in _IGNORED_NAMES or name.startswith(_IGNORED_PREFIXES) or name.endswith(_IGNORED_SUFFIXES)


def classify_differences(models: Sequence[mujoco.MjModel]) -> tuple[tuple[str, ...], tuple[str, ...], tuple[str, ...]]:
    """``(batched, keyframes, unbatchable)``: the differing model arrays MuJoCo Warp can batch per world, the
    differing keyframe arrays, and those that make the models impossible to simulate as one MuJoCo Warp model
    (fields it shares across worlds; differing fields it does not read are left out)."""
    shapes = _mjw_array_shapes()
    batched, keys, bad = [], [], []
    for name in sorted(differing_arrays(models)):
        if name in KEY_FIELDS:
            keys.append(name)
        elif shapes.get(name, ())[:1] == ("*",):
            batched.append(name)
        elif not _ignored(name, shapes):
            bad.append(name)
    if len({m.nkey for m in models}) > 1:
        bad.append("nkey")
    return tuple(batched), tuple(keys), tuple(bad)


def per_world_fields(models: Sequence[mujoco.MjModel]) -> tuple[str, ...]:
    """The model fields to batch per world so that ``models`` can share one MuJoCo Warp model; raises
    :class:`UngroupableModels` naming the differing fields MuJoCo Warp cannot batch."""
    batched, _, bad = classify_differences(models)
    if bad:
        raise UngroupableModels(f"the models differ in fields MuJoCo Warp shares across worlds: {list(bad)}")
    return batched


def groupable(models: Sequence[mujoco.MjModel]) -> bool:
    """Whether ``models`` can share one MuJoCo Warp model (:func:`per_world_fields` does not raise)."""
    return not classify_differences(models)[2]


class WarpSimSlice:
    """Worlds ``[start, stop)`` of a :class:`~mtbench.sim.WarpSim`, with its per-world attributes as zero-copy views
    (writes go to the simulator) and its per-world operations restricted to those worlds. Physics launches, resets
    and checkpoints stay with the whole sim (``.sim``)."""

    def __init__(self, sim: "WarpSim", start: int, stop: int) -> None:
        if not 0 <= start < stop <= sim.nworld:
            raise ValueError(f"world range [{start}, {stop}) is not inside the sim's {sim.nworld} worlds")
        self.sim = sim
        self.worlds = slice(start, stop)
        self.nworld = stop - start
        self.device = sim.device
        self.wp_device = sim.wp_device
        self.substeps = sim.substeps
        self.batched_fields = sim.batched_fields
        self.contact_forces = sim.contact_forces
        w = self.worlds
        for name in ("qpos", "qvel", "ctrl", "mocap_pos", "mocap_quat", "xpos", "xquat", "site_xpos", "time"):
            setattr(self, name, getattr(sim, name)[w])
        self._geom_xpos = sim.geom_xpos[w]

    @property
    def mjm(self) -> mujoco.MjModel:
        return self.sim.world_mjm(self.worlds.start)

    def model_field(self, name: str) -> torch.Tensor:
        """The sim's :meth:`~mtbench.sim.WarpSim.model_field`, restricted to these worlds if it is batched."""
        view = self.sim.model_field(name)
        return view[self.worlds] if name in self.batched_fields else view

    def set_body_pos(self, body: int, pos: torch.Tensor, mask: torch.Tensor) -> None:
        self.sim.set_body_pos(body, pos, mask, worlds=self.worlds)

    @property
    def geom_xpos(self) -> torch.Tensor:
        return self._geom_xpos

    @property
    def body_contact_force(self) -> torch.Tensor:
        return self.sim.body_contact_force[self.worlds]

    def unhealthy(self, max_abs_qvel: float = 1e4) -> torch.Tensor:
        return self.sim.unhealthy(max_abs_qvel)[self.worlds]

    def overflowed(self, kinds: int, clear: bool = False) -> torch.Tensor:
        return self.sim.overflowed(kinds, clear, worlds=self.worlds)
