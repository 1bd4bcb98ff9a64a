"""Meta-World's 39-d observation layout: the one definition used by the env, the scripted policies and the docs.

``observation = [frame(18), previous frame(18), goal(3)] + one_hot(K)`` where a *frame* is
``[tcp(3), gripper_open(1), obj_pos(3), obj_quat(4), obj2_pos(3), obj2_quat(4)]``. Positions are in the world
frame of Meta-World's scenes (metres; y points away from the robot, the table top is z = 0); quaternions are
MuJoCo's ``wxyz``. Tasks with one object report zeros for the second one.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch


@dataclass(frozen=True)
class Field:
    """One named slice ``[start, stop)`` of the observation."""

    name: str
    start: int
    stop: int
    doc: str

    @property
    def slice(self) -> slice:
        return slice(self.start, self.stop)

    @property
    def size(self) -> int:
        return self.stop - self.start


_FRAME_PARTS = (
    ("tcp", 3, "tool centre point: midpoint of the two finger pads (m)"),
    ("gripper_open", 1, "finger-pad distance / 0.1, clipped to [0, 1] (1 = open)"),
    ("obj_pos", 3, "position of the task's first object (m)"),
    ("obj_quat", 4, "orientation of the first object (wxyz; zeros where the task reports none)"),
    ("obj2_pos", 3, "position of the second object (m; zeros if the task has one object)"),
    ("obj2_quat", 4, "orientation of the second object (wxyz; zeros if none)"),
)


def _fields() -> tuple[Field, ...]:
    out, start = [], 0
    for prefix, doc_prefix in (("", ""), ("prev_", "previous step's ")):
        for name, size, doc in _FRAME_PARTS:
            out.append(Field(prefix + name, start, start + size, doc_prefix + doc))
            start += size
    out.append(Field("goal", start, start + 3, "goal position of the task (m)"))
    return tuple(out)


FIELDS: tuple[Field, ...] = _fields()
FIELD: dict[str, Field] = {f.name: f for f in FIELDS}
FRAME_DIM = 18
STATE_DIM = FIELDS[-1].stop  # 39
FRAME = slice(0, FRAME_DIM)
PREV_FRAME = slice(FRAME_DIM, 2 * FRAME_DIM)
GOAL = FIELD["goal"].slice


def frame(tcp: torch.Tensor, gripper_open: torch.Tensor, obj_pos: torch.Tensor, obj_quat: torch.Tensor,
          obj2_pos: torch.Tensor, obj2_quat: torch.Tensor) -> torch.Tensor:
    """One ``[n, 18]`` frame from its named parts (``gripper_open`` is ``[n]``)."""
    return torch.cat([tcp, gripper_open[:, None], obj_pos, obj_quat, obj2_pos, obj2_quat], dim=-1)


def compose(frame_now: torch.Tensor, frame_prev: torch.Tensor, goal: torch.Tensor,
            one_hot: torch.Tensor) -> torch.Tensor:
    """The full observation ``[n, 39 + K]``."""
    return torch.cat([frame_now, frame_prev, goal, one_hot], dim=-1)


def parse(obs: torch.Tensor) -> dict[str, torch.Tensor]:
    """Named views of an observation ``[..., >= 39]`` (a trailing one-hot is ignored); ``gripper_open`` and
    ``prev_gripper_open`` are ``[...]``, the others keep their last dimension."""
    if obs.shape[-1] < STATE_DIM:
        raise ValueError(f"observation has {obs.shape[-1]} dims; the Meta-World layout needs at least {STATE_DIM}")
    out = {f.name: obs[..., f.slice] for f in FIELDS}
    out["gripper_open"] = out["gripper_open"][..., 0]
    out["prev_gripper_open"] = out["prev_gripper_open"][..., 0]
    return out


def markdown_table() -> str:
    """The layout as a markdown table (reproduced in ``docs/metaworld.md``; a test keeps the two equal)."""
    lines = ["| dims | name | meaning |", "|---|---|---|"]
    for f in FIELDS:
        dims = str(f.start) if f.size == 1 else f"{f.start}-{f.stop - 1}"
        lines.append(f"| {dims} | `{f.name}` | {f.doc} |")
    lines.append(f"| {STATE_DIM}- | one-hot | task id over the env's K tasks (K = 10 for MT10, 50 for MT50) |")
    return "\n".join(lines)


__all__ = ["FIELD", "FIELDS", "FRAME", "FRAME_DIM", "GOAL", "PREV_FRAME", "STATE_DIM", "Field", "compose", "frame",
           "markdown_table", "parse"]
