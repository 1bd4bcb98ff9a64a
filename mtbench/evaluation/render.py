"""Batch rendering of an env's worlds with MuJoCo Warp's ray tracer (no OpenGL; Warp's CPU device or CUDA).

MuJoCo Warp 4.0.0 renders the worlds of one ``mjw.Model``/``mjw.Data`` pair with a BVH ray tracer
(``mjw.create_render_context`` -> ``mjw.refit_bvh`` -> ``mjw.render`` -> ``mjw.get_rgb``). It runs on the same
Warp device as the physics, so the same code renders on the CPU and on the GPU, straight from the simulator's
state (no copy to MuJoCo C, no GL context).

:class:`WorldRenderer` renders the first ``nworld`` worlds of one :class:`~mtbench.sim.WarpSim` through a
:class:`CameraSpec` (a look-at camera, fixed or following a body). The simulator's own data is only read: the
renderer hands MuJoCo Warp a shallow copy of ``mjw.Data`` whose world count is ``nworld`` and whose camera pose
arrays are the renderer's own, so the env's camera and light state is never written.
:class:`EnvRenderer` does this for every task block of an mtbench env: one renderer per task block for envs made of
per-task scenes (Meta-World), or one renderer over chosen worlds of an env whose tasks share one simulator (Parkour:
each world on its own terrain tile, selected per world through ``geom_dataid``).
"""

from __future__ import annotations

import dataclasses
import math
from contextlib import nullcontext
from typing import Any, Mapping

import mujoco
import mujoco_warp as mjw
import torch
import warp as wp

from ..sim import WarpSim, WarpSimSlice


@dataclasses.dataclass(frozen=True)
class CameraSpec:
    """A look-at camera.

    Args:
        eye: camera position (m). With ``track_body`` set, an offset from that body's position in each world.
        target: point the camera looks at (same convention as ``eye``).
        up: world direction that appears upwards in the image (must not be parallel to ``target - eye``).
        track_body: name of a body to follow (``eye``/``target`` become offsets from its position; the camera
            keeps its orientation, like MuJoCo's ``trackcom`` mode), or ``None`` for a fixed camera.
    """

    eye: tuple[float, float, float]
    target: tuple[float, float, float]
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)
    track_body: str | None = None

    def __post_init__(self) -> None:
        for name in ("eye", "target", "up"):
            value = tuple(float(v) for v in getattr(self, name))
            if len(value) != 3 or not all(math.isfinite(v) for v in value):
                raise ValueError(f"CameraSpec.{name} must be 3 finite numbers, got {getattr(self, name)!r}")
            object.__setattr__(self, name, value)
        fwd = torch.tensor(self.target) - torch.tensor(self.eye)
        if float(fwd.norm()) < 1e-9:
            raise ValueError("CameraSpec.eye and CameraSpec.target coincide")
        if float(torch.linalg.cross(fwd, torch.tensor(self.up)).norm()) < 1e-6 * float(fwd.norm()):
            raise ValueError(f"CameraSpec.up {self.up} is parallel to the viewing direction {tuple(fwd.tolist())}")

    @classmethod
    def from_any(cls, value: CameraSpec | Mapping[str, Any]) -> CameraSpec:
        """A ``CameraSpec`` or a mapping of its fields (e.g. an env's ``video_camera`` attribute)."""
        return value if isinstance(value, CameraSpec) else cls(**dict(value))


# Meta-World (Panda at (0, 0.15, 0) facing +y, table top at z = 0, objects and goals at y in [0.4, 0.95]):
# from the far right corner of the table, above it, looking at the middle of the workspace: the whole arm, the
# objects and the goal are in view for every MT10 task.
METAWORLD_CAMERA = CameraSpec(eye=(1.3, 1.2, 1.0), target=(-0.1, 0.5, 0.1))

# colour of rays that hit nothing (RGBA in [0, 1]): a light grey-blue sky instead of MuJoCo Warp's black
BACKGROUND = (0.62, 0.70, 0.78, 1.0)

# Model fields that MuJoCo Warp's renderer reads per world (``field[worldid % field.shape[0]]``): a renderer of chosen
# worlds gathers those that the simulator batches per world (e.g. Parkour's per-world terrain tile, ``geom_dataid``)
RENDER_MODEL_FIELDS = ("geom_dataid", "geom_matid", "geom_rgba", "geom_size", "light_active", "light_ambient",
                       "light_attenuation", "light_castshadow", "light_cutoff", "light_diffuse", "light_exponent",
                       "light_specular", "light_type", "mat_emission", "mat_rgba", "mat_shininess", "mat_specular",
                       "mat_texid", "mat_texrepeat", "mat_texuniform", "cam_fovy", "cam_intrinsic", "cam_projection",
                       "cam_sensorsize")
# Data fields that it reads (besides the camera poses, which the renderer owns)
RENDER_DATA_FIELDS = ("geom_xpos", "geom_xmat", "light_xpos", "light_xdir", "flexvert_xpos")


def look_at(eye: torch.Tensor, target: torch.Tensor, up: torch.Tensor) -> torch.Tensor:
    """MuJoCo camera orientation ``[..., 3, 3]`` (columns: right, up, backward; the camera looks along -z)."""
    fwd = torch.nn.functional.normalize(target - eye, dim=-1)
    right = torch.nn.functional.normalize(torch.linalg.cross(fwd, up.expand_as(fwd)), dim=-1)
    cam_up = torch.linalg.cross(right, fwd)
    return torch.stack([right, cam_up, -fwd], dim=-1)


class WorldRenderer:
    """RGB frames ``[nworld, H, W, 3]`` (uint8, on the sim's device) of the first ``nworld`` worlds of ``sim``, or of
    the worlds ``worlds``.

    Args:
        sim: the block's simulator (its current state is rendered: call after the env step).
        nworld: how many worlds (the first ones of the block) to render.
        width, height: image size in pixels.
        camera: the camera (:class:`CameraSpec`).
        shadows: ray-traced shadows (costs a second ray per light and pixel).
        worlds: indices of the worlds to render instead of the first ``nworld`` (``nworld`` must be their count):
            every frame gathers their geometry poses and per-world model fields (``RENDER_DATA_FIELDS``,
            ``RENDER_MODEL_FIELDS``) into the renderer's own arrays.

    The model must have at least one camera: MuJoCo Warp renders through model cameras. The renderer uses the
    projection (field of view) of camera 0 and replaces its pose by ``camera`` in its own copy of the camera
    arrays (the env's model and data are not changed).

    Heightfields: MuJoCo Warp's render context builds the ray-tracing BVH of the heightfields that the compiled
    model's geoms name; a model that selects another heightfield per world (Parkour's terrain tiles, through a
    batched ``geom_dataid``) has the BVH of each further heightfield built the first time a rendered world shows it
    (one small host read of the rendered worlds' heightfield ids per frame, only for such models).
    """

    def __init__(
        self,
        sim: WarpSim,
        nworld: int,
        width: int,
        height: int,
        camera: CameraSpec,
        *,
        shadows: bool = True,
        worlds: torch.Tensor | list[int] | None = None,
    ) -> None:
        if not 1 <= nworld <= sim.nworld:
            raise ValueError(f"nworld must be in [1, {sim.nworld}] (the block's worlds), got {nworld}")
        if worlds is not None:
            worlds = torch.as_tensor(worlds, dtype=torch.long).reshape(-1)
            if worlds.numel() != nworld or bool(((worlds < 0) | (worlds >= sim.nworld)).any()):
                raise ValueError(f"worlds must be {nworld} world indices in [0, {sim.nworld - 1}], got "
                                 f"{worlds.tolist()}")
        if width < 1 or height < 1:
            raise ValueError(f"image size must be positive, got {width}x{height}")
        mjm = sim.mjm
        if mjm.ncam < 1:
            raise ValueError(
                "the model has no camera: MuJoCo Warp's renderer draws through model cameras, add one "
                "(<camera name=\"eval\" pos=\"0 0 1\"/>) to the scene"
            )
        self.sim = sim
        self.nworld = int(nworld)
        self.width, self.height = int(width), int(height)
        self.camera = camera
        self._track_body = -1
        if camera.track_body is not None:
            self._track_body = mujoco.mj_name2id(mjm, mujoco.mjtObj.mjOBJ_BODY, camera.track_body)
            if self._track_body < 0:
                bodies = [mujoco.mj_id2name(mjm, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(mjm.nbody)]
                raise ValueError(f"unknown CameraSpec.track_body {camera.track_body!r}; valid choices: {bodies}")
        self.device = sim.device
        with wp.ScopedDevice(sim.wp_device):
            self._rc = mjw.create_render_context(
                mjm, self.nworld, (self.width, self.height), render_rgb=True, render_depth=False,
                render_seg=False, use_shadows=shadows, cam_active=[0], background_color=BACKGROUND,
            )
            n = self.nworld
            self._cam_xpos = wp.zeros((n, mjm.ncam), dtype=wp.vec3)
            self._cam_xmat = wp.zeros((n, mjm.ncam), dtype=wp.mat33)
            self._rgb = wp.zeros((n, self.height, self.width), dtype=wp.vec3)
            self._worlds = None if worlds is None else worlds.to(sim.device)
            gathered_data, self._gather = {}, []  # (source torch view, renderer's torch view) pairs
            model = sim.model
            if worlds is not None:
                for name in RENDER_DATA_FIELDS:
                    gathered_data[name] = self._gathered(getattr(sim.data, name), n)
                batched = {}
                for name in RENDER_MODEL_FIELDS:
                    field = getattr(sim.model, name, None)
                    if isinstance(field, wp.array) and field.ndim >= 1 and field.shape[0] == sim.nworld > 1:
                        batched[name] = self._gathered(field, n)
                model = dataclasses.replace(sim.model, **batched) if batched else sim.model
        # the env's data, seen as `nworld` worlds with the renderer's own camera poses (arrays are shared), or
        # the chosen worlds' copies
        self._data = dataclasses.replace(sim.data, nworld=n, cam_xpos=self._cam_xpos, cam_xmat=self._cam_xmat,
                                         **gathered_data)
        self._model = model
        self._mjm = mjm
        hfield_geoms = [g for g in range(mjm.ngeom) if mjm.geom_type[g] == mujoco.mjtGeom.mjGEOM_HFIELD]
        self._hfield_geoms = torch.as_tensor(hfield_geoms, dtype=torch.long, device=self.device)
        dataid = getattr(model, "geom_dataid", None)
        self._per_world_hfields = (len(self._hfield_geoms) > 0 and mjm.nhfield > 1 and dataid is not None
                                   and dataid.shape[0] > 1)
        self._hfields_built = {int(h) for h in mjm.geom_dataid[hfield_geoms] if h >= 0}
        self._cam_xpos_t = wp.to_torch(self._cam_xpos)
        self._cam_xmat_t = wp.to_torch(self._cam_xmat)
        self._rgb_t = wp.to_torch(self._rgb)  # [n, H, W, 3] float in [0, 1]
        dev = self.device
        self._eye = torch.tensor(camera.eye, dtype=torch.float32, device=dev)
        self._target = torch.tensor(camera.target, dtype=torch.float32, device=dev)
        self._up = torch.tensor(camera.up, dtype=torch.float32, device=dev)

    def _gathered(self, field: wp.array, n: int) -> wp.array:
        """A renderer-owned array of ``n`` worlds shaped like ``field``, refreshed from the chosen worlds' rows of
        ``field`` at every frame."""
        out = wp.zeros((n, *field.shape[1:]), dtype=field.dtype, device=field.device)
        if out.size > 0:
            self._gather.append((wp.to_torch(field), wp.to_torch(out)))
        return out

    def _ensure_hfield_bvhs(self) -> None:
        """Build the ray-tracing BVH of every heightfield that a rendered world selects and that has none yet."""
        if not self._per_world_hfields:
            return
        ids = wp.to_torch(self._model.geom_dataid)[: self.nworld, self._hfield_geoms]
        missing = sorted({int(h) for h in ids.reshape(-1).tolist() if h >= 0} - self._hfields_built)
        if not missing:
            return
        from mujoco_warp._src import bvh as mjw_bvh  # the render context's own heightfield BVH builder

        bvh_ids, half = self._rc.hfield_bvh_id.numpy(), self._rc.hfield_bounds_size.numpy()
        with wp.ScopedDevice(self.sim.wp_device):
            for h in missing:
                mesh, size = mjw_bvh.build_hfield_bvh(self._mjm, h)
                self._rc.hfield_registry[mesh.id] = mesh  # keeps the mesh alive
                bvh_ids[h], half[h] = mesh.id, size
        self._rc.hfield_bvh_id.assign(bvh_ids)
        self._rc.hfield_bounds_size.assign(half)
        wp.synchronize_device(self.sim.wp_device)  # the copies before the render, which runs on torch's stream
        self._hfields_built.update(missing)

    def _place_camera(self) -> None:
        eye, target = self._eye.expand(self.nworld, 3), self._target.expand(self.nworld, 3)
        if self._track_body >= 0:
            xpos = self.sim.xpos if self._worlds is None else self.sim.xpos[self._worlds]
            base = xpos[: self.nworld, self._track_body]
            eye, target = base + eye, base + target
        self._cam_xpos_t[:, 0] = eye
        self._cam_xmat_t[:, 0] = look_at(eye, target, self._up)

    def render(self) -> torch.Tensor:
        """Render the current state: uint8 ``[nworld, H, W, 3]`` on the sim's device (no host sync, except the
        heightfield check of models with per-world heightfields)."""
        for source, target in self._gather:
            torch.index_select(source, 0, self._worlds, out=target)
        self._ensure_hfield_bvhs()
        self._place_camera()
        stream = None
        if self.device.type == "cuda":  # after the env's work, which is joined into torch's current stream
            stream = wp.stream_from_torch(torch.cuda.current_stream(self.device))
        with wp.ScopedDevice(self.sim.wp_device), wp.ScopedStream(stream) if stream is not None else nullcontext():
            mjw.refit_bvh(self._model, self._data, self._rc)
            mjw.render(self._model, self._data, self._rc)
            mjw.get_rgb(self._rc, 0, self._rgb)
        return (self._rgb_t.clamp(0.0, 1.0) * 255.0).round_().to(torch.uint8)



def block_sims(env: Any) -> list[WarpSim | WarpSimSlice]:
    """The simulator of every task block of an mtbench env (``env.blocks[i][1].sim``): a
    :class:`~mtbench.sim.WarpSim`, or a :class:`~mtbench.sim.WarpSimSlice` of one shared by several tasks
    (``group_models``)."""
    blocks = getattr(env, "blocks", None)
    if blocks is None:
        raise TypeError(f"env {type(env).__name__} has no 'blocks' (mtbench env contract): cannot render it")
    sims = []
    for i, block in enumerate(blocks):
        state = block[1] if isinstance(block, (tuple, list)) else block
        sim = getattr(state, "sim", None)
        if not isinstance(sim, (WarpSim, WarpSimSlice)):
            raise TypeError(f"block {i} of {type(env).__name__} has no WarpSim at .sim: cannot render it")
        sims.append(sim)
    return sims


def env_camera(env: Any) -> CameraSpec:
    """The env's ``video_camera`` (a :class:`CameraSpec` or a mapping of its fields) or :data:`METAWORLD_CAMERA`."""
    spec = getattr(env, "video_camera", None)
    return METAWORLD_CAMERA if spec is None else CameraSpec.from_any(spec)


def task_worlds(env: Any, worlds_per_task: int) -> tuple[list[int], torch.Tensor]:
    """The tasks that have worlds in an env whose tasks share one simulator (``env.task_id``) and the indices
    ``[num_tasks, worlds_per_task]`` of their first worlds; ``ValueError`` if one has fewer."""
    task_id = torch.as_tensor(env.task_id).reshape(-1).cpu()
    tasks = torch.unique(task_id).tolist()
    rows = []
    for task in tasks:
        worlds = torch.nonzero(task_id == task).reshape(-1)
        if len(worlds) < worlds_per_task:
            raise ValueError(f"worlds_per_task must be in [1, {len(worlds)}] (the worlds of task {task}), "
                             f"got {worlds_per_task}")
        rows.append(worlds[:worlds_per_task])
    return tasks, torch.stack(rows)


class EnvRenderer:
    """Frames of the first ``worlds_per_task`` worlds of every task block of an mtbench env: one
    :class:`WorldRenderer` per task block (envs of per-task scenes, ``env.blocks``: Meta-World), or one over the
    chosen worlds of the env's one simulator (``env.sim`` with ``env.task_id``: Parkour; tasks without worlds are
    left out).

    ``render()`` returns uint8 ``[num_tasks, worlds_per_task, H, W, 3]`` on the env's device; ``task_ids`` lists
    the rendered tasks in that order; ``world_index`` (``[num_tasks, worlds_per_task]``) the rendered worlds' indices
    in the env's batch, for an env of one simulator (None for task blocks).
    """

    def __init__(
        self,
        env: Any,
        width: int,
        height: int,
        *,
        worlds_per_task: int = 1,
        camera: CameraSpec | None = None,
        shadows: bool = True,
    ) -> None:
        camera = camera if camera is not None else env_camera(env)
        self.worlds_per_task = int(worlds_per_task)
        if worlds_per_task < 1:
            raise ValueError(f"worlds_per_task must be >= 1, got {worlds_per_task}")
        self._shared = getattr(env, "blocks", None) is None and isinstance(getattr(env, "sim", None), WarpSim)
        if self._shared:
            self.task_ids, worlds = task_worlds(env, self.worlds_per_task)
            self.renderers = [WorldRenderer(env.sim, worlds.numel(), width, height, camera, shadows=shadows,
                                            worlds=worlds.reshape(-1))]
            self.world_index = worlds.to(self.renderers[0].device)
        else:
            self.world_index = None
            sims = block_sims(env)
            fewest = min(s.nworld for s in sims)
            if not worlds_per_task <= fewest:
                raise ValueError(f"worlds_per_task must be in [1, {fewest}] (the smallest task block), "
                                 f"got {worlds_per_task}")
            self.task_ids = list(range(len(sims)))
            self.renderers = []
            for s in sims:  # a WarpSimSlice renders its first worlds of the shared sim
                sim, worlds = (s, None) if isinstance(s, WarpSim) else (
                    s.sim, torch.arange(s.worlds.start, s.worlds.start + worlds_per_task))
                self.renderers.append(WorldRenderer(sim, worlds_per_task, width, height, camera, shadows=shadows,
                                                    worlds=worlds))
        self.num_tasks = len(self.task_ids)
        self.device = self.renderers[0].device

    def render(self) -> torch.Tensor:
        if self._shared:
            frames = self.renderers[0].render()
            return frames.reshape(self.num_tasks, self.worlds_per_task, *frames.shape[1:])
        return torch.stack([r.render() for r in self.renderers])


def tile(frames: torch.Tensor, grid: int) -> torch.Tensor:
    """``[..., grid * grid, H, W, C]`` -> ``[..., grid * H, grid * W, C]`` (row-major tiles)."""
    *lead, n, h, w, c = frames.shape
    if n != grid * grid:
        raise ValueError(f"{n} images do not fill a {grid}x{grid} grid")
    x = frames.reshape(*lead, grid, grid, h, w, c)
    nd = len(lead)
    x = x.permute(*range(nd), nd, nd + 2, nd + 1, nd + 3, nd + 4)
    return x.reshape(*lead, grid * h, grid * w, c)


__all__ = ["CameraSpec", "EnvRenderer", "METAWORLD_CAMERA", "RENDER_DATA_FIELDS", "RENDER_MODEL_FIELDS",
           "WorldRenderer", "block_sims", "env_camera", "look_at", "task_worlds", "tile"]
