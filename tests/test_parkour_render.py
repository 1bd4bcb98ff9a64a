"""Rendering Parkour worlds (evaluation videos): every world shows its own terrain tile (MuJoCo Warp builds the
ray-tracing BVH only of the heightfield the compiled model names; the renderer builds the others), chosen worlds
render exactly as they do among all worlds, and the env renderer groups the frames by task."""

from __future__ import annotations

from typing import Any

import pytest
import torch

from mtbench.evaluation.render import BACKGROUND, CameraSpec, EnvRenderer, WorldRenderer, env_camera, task_worlds

TASKS = ["box_jump_even", "staircase_climbing", "flat"]
W, H = 64, 48


@pytest.fixture(scope="module")
def env() -> Any:
    """3 terrains x 2 worlds on a 2-row grid: the two worlds of a terrain stand on different tiles."""
    from mtbench.envs import make_env

    env = make_env(TASKS, num_envs=6, device="cpu", num_rows=2, random_start_progress=False)
    td = env.reset()
    for _ in range(3):
        td["action"] = torch.zeros(6, 12)
        _, td = env.step_and_maybe_reset(td)
    return env


def _background_share(images: torch.Tensor) -> torch.Tensor:
    """Per image, the share of pixels of the sky colour in its lower half (where the terrain is)."""
    sky = torch.tensor([round(255 * c) for c in BACKGROUND[:3]], dtype=torch.int16)
    lower = images[:, H // 2:].to(torch.int16)
    return ((lower - sky).abs().max(-1).values <= 2).float().mean((1, 2))


def test_every_world_shows_its_own_terrain_tile(env: Any) -> None:
    tiles = env.sim.model_field("geom_dataid")[:, env.scene.hfield_geom]
    assert len(set(tiles.tolist())) == 6  # six worlds on six different tiles
    images = WorldRenderer(env.sim, 6, W, H, env_camera(env)).render()
    assert images.shape == (6, H, W, 3) and images.dtype == torch.uint8
    # the terrain fills the lower half of every view (without the extra BVHs only tile 0 was drawn: sky elsewhere)
    assert (_background_share(images) < 0.05).all(), _background_share(images)
    assert not torch.equal(images[0], images[2])  # box jumps and stairs look different


def test_chosen_worlds_render_exactly_as_among_all_worlds(env: Any) -> None:
    camera = CameraSpec.from_any(env.video_camera)
    everything = WorldRenderer(env.sim, 6, W, H, camera).render()
    chosen = WorldRenderer(env.sim, 2, W, H, camera, worlds=[4, 1]).render()
    assert torch.equal(chosen, everything[[4, 1]])
    with pytest.raises(ValueError, match=r"worlds must be 2 world indices in \[0, 5\], got \[4, 6\]"):
        WorldRenderer(env.sim, 2, W, H, camera, worlds=[4, 6])


def test_env_renderer_groups_the_frames_by_task(env: Any) -> None:
    renderer = EnvRenderer(env, W, H, worlds_per_task=2)
    assert renderer.task_ids == [6, 15, 20] and renderer.num_tasks == 3
    tasks, worlds = task_worlds(env, 2)
    assert tasks == [6, 15, 20] and worlds.tolist() == [[0, 1], [2, 3], [4, 5]]
    frames = renderer.render()
    everything = WorldRenderer(env.sim, 6, W, H, env_camera(env)).render()
    assert torch.equal(frames, everything.reshape(3, 2, H, W, 3))
    with pytest.raises(ValueError, match=r"worlds_per_task must be in \[1, 2\] \(the worlds of task 6\), got 3"):
        EnvRenderer(env, W, H, worlds_per_task=3)
