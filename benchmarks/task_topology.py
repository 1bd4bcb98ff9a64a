"""How many MuJoCo Warp models MT50 would need if tasks shared models.

MT50's compiled task models grouped by their kinematic tree (parent bodies, joint types, equality constraints) and,
strictly, by every model field that MuJoCo Warp 4.0 cannot batch per world (geom types and collision filters, joint
axes, the sizes of everything), then the model arrays that differ inside the strict groups: what a shared model
would have to carry per world. CPU only, a few seconds.

    python benchmarks/task_topology.py
"""

from __future__ import annotations

import collections
import sys
from pathlib import Path

import mujoco
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from mtbench.envs.metaworld.models import compiled_task  # noqa: E402
from mtbench.envs.metaworld.registry import MT50  # noqa: E402


def kinematic_signature(m: mujoco.MjModel) -> tuple:
    """The kinematic tree: sizes, parent bodies, joint types and bodies, equality constraint types."""
    return (m.nq, m.nv, m.nbody, tuple(m.body_parentid), tuple(m.jnt_type), tuple(m.jnt_bodyid), m.neq,
            tuple(m.eq_type))


def strict_signature(m: mujoco.MjModel) -> tuple:
    """The kinematic tree plus the fields a MuJoCo Warp model shares across its worlds."""
    return kinematic_signature(m) + (
        m.ngeom, tuple(m.geom_type), tuple(m.geom_bodyid), tuple(m.geom_contype), tuple(m.geom_conaffinity),
        tuple(m.geom_condim), m.nmesh, m.nmeshvert, m.nhfield, m.nsite, m.nu, m.nmocap, m.nkey, tuple(m.eq_obj1id),
        tuple(m.eq_obj2id), tuple(np.round(m.jnt_axis, 6).ravel()), m.ntendon, m.nsensor)


def differing_arrays(models: list[mujoco.MjModel]) -> set[str]:
    """Names of the model arrays whose values differ between the first model and any other."""
    m0, names = models[0], set()
    for m in models[1:]:
        for name in dir(m0):
            a = getattr(m0, name) if not name.startswith("_") else None
            if isinstance(a, np.ndarray) and a.dtype != object:
                b = getattr(m, name)
                if a.shape != b.shape or not np.array_equal(a, b):
                    names.add(name)
    return names


def main() -> None:
    models = {task: compiled_task(task)[1] for task in MT50}
    kinematic, strict = collections.defaultdict(list), collections.defaultdict(list)
    for task, m in models.items():
        kinematic[kinematic_signature(m)].append(task)
        strict[strict_signature(m)].append(task)
    print(f"tasks {len(models)} | kinematic signatures {len(kinematic)} | strict signatures (every field MuJoCo "
          f"Warp cannot batch equal) {len(strict)}")
    for title, groups in (("strict", strict), ("kinematic", kinematic)):
        for group in sorted(groups.values(), key=len, reverse=True):
            if len(group) > 1:
                print(f"  {title} group: {', '.join(group)}")
    counts = collections.Counter()
    for group in strict.values():
        if len(group) > 1:
            counts.update(differing_arrays([models[t] for t in group]))
    print("arrays that differ inside strict groups (groups affected):",
          ", ".join(f"{name} ({n})" for name, n in counts.most_common()))


if __name__ == "__main__":
    main()
