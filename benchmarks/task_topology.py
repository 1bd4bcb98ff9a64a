"""How many MuJoCo Warp models MT50 would need if tasks shared models.

MT50's compiled task models grouped by their kinematic tree (parent bodies, joint types, equality constraints) and,
strictly, by every model field that MuJoCo Warp 4.0 cannot batch per world (geom types and collision filters, joint
axes, the sizes of everything), the model arrays that differ inside the strict groups (what a shared model has to
carry per world), and the physics blocks ``MetaWorldEnv(group_models=True)`` makes of MT50 (strict groups whose
differing fields MuJoCo Warp can all batch). CPU only, a few seconds.

    python benchmarks/task_topology.py
"""

from __future__ import annotations

import collections
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from mtbench.envs.metaworld.models import compiled_task, kinematic_signature, physics_groups, strict_signature  # noqa: E402
from mtbench.envs.metaworld.registry import MT50  # noqa: E402
from mtbench.sim import differing_arrays  # noqa: E402


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
    tasks = list(models)
    blocks = physics_groups([models[t] for t in tasks])
    print(f"group_models=True: {len(blocks)} physics blocks; shared: "
          + "; ".join(", ".join(tasks[i] for i in b) for b in blocks if len(b) > 1))


if __name__ == "__main__":
    main()
