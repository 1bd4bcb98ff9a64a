"""Every Meta-World task is solvable: its scripted controller succeeds in >= 80% of randomized episodes.

All 50 tasks run together in one batched env (as in training), 10 worlds per task (randomized object and goal
positions), on the CPU, with the default ``reward_version="paper"`` (the success rules are the same in both
versions, but hammer's success also reads its dense reward).
"""

from __future__ import annotations

import pytest

from mtbench.envs.metaworld import ALL_TASK_NAMES, MT10, NUM_METAWORLD_TASKS, TASKS
from mtbench.envs.metaworld.policies import scripted_policy
from mtbench.envs.metaworld.policies.evaluate import evaluate_scripted

WORLDS_PER_TASK = 10
# Tasks whose scripted controller cannot reach 80%, with the reason (see the task files):
KNOWN_UNSOLVED = {
    # MTBench's peg_unplug_side lays a 16.5 cm plug on the table, along the fingers' opening axis, and asks to lift
    # it into the outlet 13 cm up: the Panda's 8 cm opening cannot grasp it (neither could MTBench's Franka)
    "peg_unplug_side",
}


def test_all_50_tasks_and_policies_exist() -> None:
    assert len(ALL_TASK_NAMES) == NUM_METAWORLD_TASKS and set(MT10) <= set(TASKS)
    for task in ALL_TASK_NAMES:
        assert callable(scripted_policy(task))


@pytest.mark.slow
def test_scripted_policies_solve_mt50() -> None:
    rates = evaluate_scripted(list(ALL_TASK_NAMES), WORLDS_PER_TASK, seed=0, rand=True)
    print({t: f"{r:.0%}" for t, r in rates.items()})
    failing = {t: r for t, r in rates.items() if r < 0.8}
    assert set(failing) <= KNOWN_UNSOLVED, f"scripted success below 80%: {failing}"
    assert len(rates) - len(failing) >= 48
