"""door_open's ``reward_version="v2"`` reward: known answers of :func:`door_open_reward_v2` on constructed states,
and the scripted controller's episode in the env (CPU, two worlds)."""

from __future__ import annotations

import math

import pytest
import torch

from mtbench.envs.metaworld.tasks import door_open
from mtbench.envs.metaworld.tasks.door_open import door_open_reward_v2

# A parking state of a trained MT50-rand policy: handle at (-0.02, 0.59, 0.15) with the door open by 0.97 rad, the
# open gripper at the paper-era reward's "door" point, handle + (0.075, -0.15, 0) (roughly).
PARK_ANGLE = 0.97
PARK_TCP = (0.07, 0.42, 0.175)
HANDLE = (-0.02, 0.59, 0.15)
HANDLE_ON_DOOR = (0.325, -0.062)


def p(*xyz: float) -> torch.Tensor:
    return torch.tensor([xyz], dtype=torch.float32)


def rot(x: float, y: float, angle: float) -> tuple[float, float]:
    """Door coordinates ``(x, y)`` in world x-y offsets with the door open by ``angle`` (hinge qpos ``-angle``)."""
    c, s = math.cos(-angle), math.sin(-angle)
    return x * c - y * s, x * s + y * c


def hinge_of(handle: tuple[float, float, float], angle: float) -> tuple[float, float, float]:
    hx, hy = rot(*HANDLE_ON_DOOR, angle)
    return handle[0] - hx, handle[1] - hy, handle[2]


def push_point(hinge: tuple[float, float, float], angle: float) -> tuple[float, float, float]:
    dx, dy = rot(0.33, 0.055, angle)
    return hinge[0] + dx, hinge[1] + dy, hinge[2] + 0.10


def hook_point(hinge: tuple[float, float, float], angle: float) -> tuple[float, float, float]:
    dx, dy = rot(0.40, -0.071, angle)
    return hinge[0] + dx, hinge[1] + dy - 0.054, hinge[2]


def v2(tcp: tuple[float, float, float], hinge: tuple[float, float, float], angle: float) -> float:
    return door_open_reward_v2(p(*tcp), p(*hinge), torch.tensor([-angle])).item()


def approx(x: float, tol: float = 1e-5) -> object:
    return pytest.approx(x, abs=tol)


def long_tail(d: float) -> float:
    """``tolerance(d, (0, .05), margin=.3, long_tail)`` (0.1 at the margin: scale 3)."""
    x = max(d - 0.05, 0.0) / 0.3
    return 1.0 / (1.0 + 9.0 * x * x)


def test_the_hinge_of_the_parking_state_is_a_reset_state() -> None:
    hinge = hinge_of(HANDLE, PARK_ANGLE)
    safe = (hinge[0] + 0.185, hinge[1] + 0.1)
    assert 0.0 <= safe[0] <= 0.1 and 0.95 <= safe[1] <= 1.05


def test_door_open_v2_known_answers() -> None:
    """Phase A pays the reach to the hook point (1 there), phase B 1 + the reach to the push point, both + 6·a/1.5."""
    closed_hinge = (-0.135, 0.9, 0.15)
    assert v2(hook_point(closed_hinge, 0.0), closed_hinge, 0.0) == approx(1.0)
    far = hook_point(closed_hinge, 0.0)
    far = (far[0], far[1] - 0.35, far[2])  # 5 cm + the margin away: 0.1
    assert v2(far, closed_hinge, 0.0) == approx(0.1)

    hinge = hinge_of(HANDLE, PARK_ANGLE)
    opened = 6.0 * PARK_ANGLE / 1.5
    push = push_point(hinge, PARK_ANGLE)
    parking = v2(PARK_TCP, hinge, PARK_ANGLE)
    assert parking == approx(1.0 + long_tail(math.dist(PARK_TCP, push)) + opened)
    at_push = v2(push, hinge, PARK_ANGLE)
    assert at_push == approx(2.0 + opened)
    finished = v2(push_point(hinge, 1.5), hinge, 1.5)
    assert finished == approx(8.0)
    assert parking + 0.5 < at_push < finished
    # every step along the straight way from the parking spot to the push point pays
    path = [v2(tuple(a + f * (b - a) for a, b in zip(PARK_TCP, push)), hinge, PARK_ANGLE) for f in
            [i / 10 for i in range(11)]]
    assert all(b >= a for a, b in zip(path, path[1:]))


def test_door_open_v2_switch_does_not_lower_the_reward() -> None:
    hinge = hinge_of(HANDLE, 0.0)
    before = v2(hook_point(hinge, 0.5999), hinge, 0.5999)
    after = v2(hook_point(hinge, 0.6), hinge, 0.6)
    assert before == approx(1.0 + 6.0 * 0.5999 / 1.5, tol=1e-4)
    assert after > before


def test_scripted_door_open_succeeds_under_v2() -> None:
    """The scripted controller opens the door in both worlds under v2, and the env pays v2's reward, not the paper's."""
    from mtbench.envs.make import make_env
    from mtbench.envs.metaworld.policies import scripted_policy

    policy = scripted_policy("door_open")
    rewards, success = {}, {}
    for version in ("paper", "v2"):
        env = make_env(["door_open"], num_envs=[2], device="cpu", seed=0, rand=True, random_start_progress=False,
                       reward_version=version)
        td = env.reset()
        per_step = []
        for _ in range(env.max_episode_steps):
            td["action"] = policy(td["observation"][:, : env.state_dim])
            out, td = env.step_and_maybe_reset(td)
            per_step.append(out["next", "reward"].reshape(-1).clone())
        stats = env.pop_episode_stats()
        rewards[version] = torch.stack(per_step)
        success[version] = (stats["success"] / stats["episodes"].clamp_min(1)).item()
    assert success["v2"] == 1.0
    assert (rewards["v2"] - rewards["paper"]).abs().max().item() > 0.5
    assert rewards["v2"].max().item() == 10.0  # success steps pay 10
    dense = rewards["v2"][rewards["v2"] < 10.0]
    assert 0.0 <= dense.min().item() and dense.max().item() <= 8.0
    assert door_open.DoorOpen.has_v2_reward()
