"""Every MT10 task is solvable: its scripted controller succeeds in >= 80% of randomized episodes.

All ten tasks run together in one batched env (as in training), a few worlds per task, on the CPU.
"""

from __future__ import annotations

import pytest

from mtbench.envs.metaworld import MT10, TASKS
from mtbench.envs.metaworld.policies.evaluate import evaluate_scripted

WORLDS_PER_TASK = 5


@pytest.mark.slow
def test_every_mt10_task_has_a_definition() -> None:
    missing = [t for t in MT10 if t not in TASKS]
    assert not missing, f"MT10 tasks without a definition: {missing}"


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1])
def test_scripted_policies_solve_mt10(seed: int) -> None:
    rates = evaluate_scripted(list(MT10), WORLDS_PER_TASK, seed=seed, rand=True)
    print({t: f"{r:.0%}" for t, r in rates.items()})
    failing = {t: r for t, r in rates.items() if r < 0.8}
    assert not failing, f"scripted success below 80%: {failing}"
