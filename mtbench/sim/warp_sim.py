"""One compiled MuJoCo model simulated for many worlds with MuJoCo Warp, exposed as zero-copy torch tensors.

This layer knows physics only: it owns ``mjw.Model``/``mjw.Data`` for a block of ``nworld`` identical-topology
worlds, steps them (captured as a CUDA graph on the GPU, as a Warp CPU graph on the CPU), resets a masked subset
of worlds to a keyframe, recomputes kinematics, and reports worlds whose state is not finite or whose contact /
constraint buffers overflowed. Nothing here knows about tasks, rewards or observations.
"""

from __future__ import annotations

import dataclasses
import gc
import os
from typing import Sequence

import mujoco
import mujoco_warp as mjw
import numpy as np
import torch
import warp as wp

from .world_groups import KEY_FIELDS, per_world_fields

if not os.environ.get("MTBENCH_WARP_VERBOSE"):
    # no per-kernel load/compile chatter (set MTBENCH_WARP_VERBOSE=1 to see it); errors still raise
    wp.config.quiet = True
    if hasattr(wp, "LOG_WARNING"):
        wp.config.log_level = wp.LOG_WARNING
_WARP_INITIALIZED = False

# Overflows that make a world's physics wrong (dropped contacts / constraints). Solver or linesearch iteration
# limits are not: the solution is just less converged.
FATAL_OVERFLOW = int(
    mjw.OverflowType.ALL
    & ~mjw.OverflowType.ITERATIONS
    & ~mjw.OverflowType.LS_ITERATIONS
    & ~mjw.OverflowType.CONTACT_MATCH
    & ~mjw.OverflowType.TACTILE
)
# A geom touching more than mujoco.mjMAXCONPAIR (50) heightfield prisms: MuJoCo Warp stops examining prisms there and
# still writes the pair's contacts (the deepest and the most spread-out ones among the prisms it examined), so the
# world's physics goes on with a partial contact set instead of going wrong. A scene can declare it not fatal
# (``WarpSim(fatal_overflow=FATAL_OVERFLOW & ~HFIELD_OVERFLOW)``) and count it with :meth:`WarpSim.overflowed`.
HFIELD_OVERFLOW = int(mjw.OverflowType.HFIELD)

# Box-box narrowphase choices (see ``WarpSim``).
BOX_BOX_COLLIDERS = ("primitive", "gjk")


@wp.kernel
def _zero_nonfinite_rows(mask: wp.array(dtype=wp.bool), values: wp.array2d(dtype=wp.float32)):
    """``values[w, j] = 0`` where world ``w`` is masked and the value is NaN or infinite."""
    w, j = wp.tid()
    if mask[w]:
        if not wp.isfinite(values[w, j]):
            values[w, j] = 0.0


def _float_rows(arr: wp.array, nworld: int) -> wp.array | None:
    """A ``[nworld, k]`` float32 view of a contiguous per-world array of float32-based dtype (vectors, matrices,
    ...), or ``None`` for arrays of another kind."""
    if not isinstance(arr, wp.array) or arr.ndim < 1 or arr.shape[0] != nworld or arr.size == 0:
        return None
    scalar = getattr(arr.dtype, "_wp_scalar_type_", arr.dtype)
    if scalar is not wp.float32 or not arr.is_contiguous:
        return None
    per_world = (arr.size * wp.types.type_size_in_bytes(arr.dtype)) // (nworld * 4)
    return wp.array(ptr=arr.ptr, dtype=wp.float32, shape=(nworld, per_world), device=arr.device, copy=False)


def _init_warp() -> None:
    global _WARP_INITIALIZED
    if not _WARP_INITIALIZED:
        wp.config.quiet = True
        wp.init()
        _WARP_INITIALIZED = True


def warp_device(device: torch.device | str) -> str:
    """Warp device string for a torch device (``cpu`` or ``cuda:<i>``); raises if it is not available."""
    device = torch.device(device)
    _init_warp()
    if device.type == "cpu":
        return "cpu"
    if device.type == "cuda":
        if not torch.cuda.is_available():
            raise RuntimeError(f"device {device} requested but CUDA is not available; valid choices: ['cpu']")
        index = torch.cuda.current_device() if device.index is None else device.index
        if index >= torch.cuda.device_count():
            raise RuntimeError(f"device {device} does not exist; {torch.cuda.device_count()} CUDA device(s) found")
        return f"cuda:{index}"
    raise ValueError(f"unsupported device {device}; valid choices: ['cpu', 'cuda[:i]']")


class WarpSim:
    """``nworld`` worlds of one MuJoCo model on a Warp device.

    Args:
        mjm: compiled MuJoCo model. If it has keyframes, ``reset`` uses keyframe ``reset_key``.
        nworld: number of worlds.
        device: torch device (``cpu`` or ``cuda[:i]``); Warp runs on the matching device.
        substeps: physics steps per call of :meth:`step`.
        nconmax: contacts per world (pooled across worlds); njmax: constraint rows per world (hard limit).
        batched_fields: model fields given one copy per world (e.g. ``("body_pos",)``), writable through
            :meth:`model_field`.
        use_graph: capture step/reset/kinematics as graphs (CUDA graphs on GPU; Warp CPU graphs on CPU).
        reset_key: keyframe index used by :meth:`reset` (ignored when the model has no keyframe).
        warn_overflow: let MuJoCo Warp print a message whenever a contact/constraint buffer overflows (off: the
            overflow is reported per world by :meth:`unhealthy` instead).
        box_box_collider: ``"primitive"``: MuJoCo C's box-box routine (up to 8 contacts, as in MuJoCo C);
            ``"gjk"``: MuJoCo Warp's default general convex collider (GJK/EPA, up to 4 contacts).
        contact_forces: after the substeps of every :meth:`step`, also compute the net contact force on every body
            (``mjw.rne_postconstraint``), read through :attr:`body_contact_force`.
        fatal_overflow: the ``mjw.OverflowType`` bits that make a world unhealthy (:meth:`unhealthy`); default
            ``FATAL_OVERFLOW`` (every dropped contact or constraint).
        world_models: several models of one structure in one sim (``None``: every world is ``mjm``): a list of
            ``(model, count)`` whose counts add up to ``nworld`` (``mjm`` must be the first model); worlds
            ``[sum(counts[:i]), sum(counts[:i+1]))`` simulate model ``i``: its values of the fields that differ
            (batched per world, added to ``batched_fields``), its keyframes (:meth:`reset`) and its initial state.
            Raises :class:`~mtbench.sim.world_groups.UngroupableModels` if the models differ in a field MuJoCo Warp
            shares across worlds.
    """

    def __init__(
        self,
        mjm: mujoco.MjModel,
        nworld: int,
        device: torch.device | str = "cpu",
        *,
        substeps: int = 1,
        nconmax: int | None = None,
        njmax: int | None = None,
        batched_fields: Sequence[str] = (),
        use_graph: bool = True,
        reset_key: int = 0,
        warn_overflow: bool = False,
        box_box_collider: str = "primitive",
        contact_forces: bool = False,
        fatal_overflow: int = FATAL_OVERFLOW,
        world_models: Sequence[tuple[mujoco.MjModel, int]] | None = None,
    ) -> None:
        if box_box_collider not in BOX_BOX_COLLIDERS:
            raise ValueError(f"unknown box_box_collider {box_box_collider!r}; valid choices: "
                             f"{', '.join(BOX_BOX_COLLIDERS)}")
        if nworld < 1:
            raise ValueError(f"nworld must be positive, got {nworld}")
        if substeps < 1:
            raise ValueError(f"substeps must be positive, got {substeps}")
        self.mjm = mjm
        self.nworld = nworld
        self.substeps = substeps
        self.device = torch.device(device)
        self.wp_device = warp_device(self.device)
        if self.device.type == "cuda" and self.device.index is None:
            self.device = torch.device(self.wp_device)
        self.use_graph = use_graph
        self.world_models: list[tuple[mujoco.MjModel, int]] | None = None
        if world_models is not None:
            world_models = [(m, int(c)) for m, c in world_models]
            if not world_models or world_models[0][0] is not mjm:
                raise ValueError("world_models must start with mjm (the model the sim is built from)")
            if any(c < 1 for _, c in world_models) or sum(c for _, c in world_models) != nworld:
                raise ValueError(f"world_models counts {[c for _, c in world_models]} must be positive and add up "
                                 f"to nworld={nworld}")
            extra = per_world_fields([m for m, _ in world_models])  # raises UngroupableModels
            batched_fields = tuple(batched_fields) + tuple(f for f in extra if f not in batched_fields)
            self.world_models = world_models
        self.batched_fields = tuple(batched_fields)
        self.contact_forces = bool(contact_forces)
        self.fatal_overflow = int(fatal_overflow)
        self._has_key = mjm.nkey > 0
        if self._has_key and not 0 <= reset_key < mjm.nkey:
            raise ValueError(f"reset_key {reset_key} out of range for a model with {mjm.nkey} keyframes")
        data0 = mujoco.MjData(mjm)
        if self._has_key:
            mujoco.mj_resetDataKeyframe(mjm, data0, reset_key)
        mujoco.mj_forward(mjm, data0)
        with wp.ScopedDevice(self.wp_device):
            batch = {name: nworld for name in batched_fields} or None
            self.model = mjw.put_model(mjm, batch_sizes=batch)
            # no per-occurrence prints from inside the step: affected worlds are reported by unhealthy() (the
            # env resets and counts them); warn_overflow=True prints MuJoCo Warp's messages for fatal overflows
            self.model.opt.warn_overflow = self.fatal_overflow if warn_overflow else 0
            if box_box_collider == "primitive":  # MuJoCo Warp reads this flag when it builds the collision table
                self.model.opt.disableflags |= int(mjw.DisableBit.NATIVECCD)
            self.data = mjw.put_data(mjm, data0, nworld=nworld, nconmax=nconmax, njmax=njmax)
            if self.world_models is not None and self._has_key:
                self._stack_keyframes()
            self._key_ids = wp.full(nworld, -1, dtype=int)
            # a reset of a world that went non-finite also zeroes the NaN/inf values its derived quantities and
            # solver buffers kept (MuJoCo Warp's reset restores the state, not e.g. the constraint rows beyond
            # nefc, which its solver still reads: the world would turn NaN again at its next step)
            self._clean_mask = wp.zeros(nworld, dtype=bool)
            self._clean_flag = wp.zeros(1, dtype=wp.int32)
            self._clean_rows = self._per_world_float_arrays()
        self.stream: torch.cuda.Stream | None = None
        self._wp_stream = None
        if self.device.type == "cuda":
            self.stream = torch.cuda.Stream(device=self.device)
            self._wp_stream = wp.stream_from_torch(self.stream)
        self._key_ids_t = wp.to_torch(self._key_ids)
        #: the keyframe a reset gives each world: 0, or its model's keyframe 0 with ``world_models``
        self._world_key = torch.zeros_like(self._key_ids_t)
        self._clean_mask_t = wp.to_torch(self._clean_mask)
        self._clean_flag_t = wp.to_torch(self._clean_flag)
        if not self._has_key:
            self._reset_mask = wp.zeros(nworld, dtype=bool, device=self.wp_device)
            self._reset_mask_t = wp.to_torch(self._reset_mask)
        d = self.data
        # zero-copy torch views of the state (writes go straight to the simulator)
        self.qpos = wp.to_torch(d.qpos)
        self.qvel = wp.to_torch(d.qvel)
        self.ctrl = wp.to_torch(d.ctrl)
        self.mocap_pos = wp.to_torch(d.mocap_pos)
        self.mocap_quat = wp.to_torch(d.mocap_quat)
        self.xpos = wp.to_torch(d.xpos)
        self.xquat = wp.to_torch(d.xquat)
        self.site_xpos = wp.to_torch(d.site_xpos)
        self.time = wp.to_torch(d.time)
        self._overflow = wp.to_torch(d.overflow)
        self._geom_xpos = wp.to_torch(d.geom_xpos)
        self._cfrc_ext = wp.to_torch(d.cfrc_ext)
        # views of the per-world model fields, made here: torch.compile traces a dict lookup, not wp.to_torch
        self._field_views: dict[str, torch.Tensor] = {}
        for name in self.batched_fields:
            self.model_field(name)
        self._static_geoms = self._static_geom_table()
        if self.world_models is not None:
            self._init_world_models(reset_key)
        self._graphs: dict[str, object] = {}
        self._phases = {"step": self._step_impl, "reset": self._reset_impl, "kin": self._kinematics_impl}
        if use_graph:
            self._capture()

    # ---------------------------------------------------------------- model fields
    def model_field(self, name: str) -> torch.Tensor:
        """Zero-copy torch view of a model field (shape ``(nworld, ...)`` if it was batched, else ``(1, ...)``)."""
        view = self._field_views.get(name)
        if view is None:
            view = self._field_views[name] = wp.to_torch(getattr(self.model, name))
        return view

    # ---------------------------------------------------------------- graphs
    def _step_impl(self) -> None:
        for _ in range(self.substeps):
            mjw.step(self.model, self.data)
        if self.contact_forces:  # forces of the last substep's contacts and constraint solution
            mjw.rne_postconstraint(self.model, self.data)
        mjw.kinematics(self.model, self.data)

    def _per_world_float_arrays(self) -> list[wp.array]:
        """``[nworld, k]`` float views of every per-world float array of the data (state, derived quantities,
        constraint rows), for :meth:`_clean_nonfinite`."""
        found, seen = [], set()
        stack = [self.data]
        while stack:
            obj = stack.pop()
            for f in dataclasses.fields(obj):
                value = getattr(obj, f.name)
                if dataclasses.is_dataclass(value) and not isinstance(value, type):
                    stack.append(value)
                    continue
                rows = _float_rows(value, self.nworld) if isinstance(value, wp.array) else None
                if rows is not None and value.ptr not in seen:
                    seen.add(value.ptr)
                    found.append(rows)
        return found

    def _clean_nonfinite(self) -> None:
        for rows in self._clean_rows:
            wp.launch(_zero_nonfinite_rows, dim=rows.shape, inputs=[self._clean_mask, rows])

    def _reset_impl(self) -> None:
        # only when a staged world is unhealthy (a conditional graph node: free otherwise)
        wp.capture_if(self._clean_flag, on_true=self._clean_nonfinite)
        if self._has_key:  # per-world key ids: -1 leaves a world untouched
            mjw.reset_data_keyframe(self.model, self.data, self._key_ids)
        else:
            mjw.reset_data(self.model, self.data, reset=self._reset_mask)

    def _kinematics_impl(self) -> None:
        mjw.kinematics(self.model, self.data)

    def _capture(self) -> None:
        # warm-up (compiles the kernels) before capture, then capture with the GC off (see mjlab/mujoco_warp notes)
        with wp.ScopedDevice(self.wp_device), wp.ScopedStream(self._wp_stream) if self._wp_stream else _null():
            self._kinematics_impl()
            gc_was_enabled = gc.isenabled()
            gc.disable()
            try:
                for name, fn in self._phases.items():
                    with wp.ScopedCapture(device=self.wp_device, stream=self._wp_stream) as cap:
                        fn()
                    self._graphs[name] = cap.graph
            finally:
                if gc_was_enabled:
                    gc.enable()

    # ---------------------------------------------------------------- public API
    def launch(self, phase: str, stream: torch.cuda.Stream | None = None) -> None:
        """Enqueue one phase: ``"step"`` (``substeps`` physics steps then kinematics), ``"reset"`` (the worlds
        staged by :meth:`stage_reset`) or ``"kin"`` (kinematics); its captured graph, or its kernels when
        ``use_graph=False``. Asynchronous on the GPU; on ``stream`` if given, else on the block's own stream (no
        ordering with torch: see :func:`launch_all`)."""
        fn = self._phases.get(phase)
        if fn is None:
            raise ValueError(f"unknown phase {phase!r}; valid choices: {list(self._phases)}")
        wp_stream = self._wp_stream if stream is None else wp.stream_from_torch(stream)
        if self.use_graph:
            wp.capture_launch(self._graphs[phase], stream=wp_stream)
        else:
            with wp.ScopedDevice(self.wp_device), wp.ScopedStream(wp_stream) if wp_stream else _null():
                fn()

    def step(self) -> None:
        """``substeps`` physics steps then kinematics, ordered after the current torch stream's work."""
        with self._on_own_stream():
            self.launch("step")

    def stage_reset(self, mask: torch.Tensor) -> None:
        """Mark the worlds where ``mask`` (bool ``[nworld]``) is true for the next ``"reset"`` launch and clear
        their overflow flags. Torch work only (safe inside a torch CUDA graph capture)."""
        if self._has_key:  # each world's keyframe where mask, -1 (untouched) elsewhere
            self._key_ids_t.copy_(torch.where(mask, self._world_key, -1))
        else:
            self._reset_mask_t.copy_(mask)
        clean = mask & self.unhealthy()
        self._clean_mask_t.copy_(clean)
        self._clean_flag_t.copy_(clean.any().reshape(1))  # stays on the device (no host sync)
        self._overflow.masked_fill_(mask, 0)

    def reset(self, mask: torch.Tensor) -> None:
        """Reset the worlds where ``mask`` (bool ``[nworld]``) is true to the keyframe (or ``qpos0``).

        No host synchronisation: the mask is copied into a persistent device array read by a captured graph.
        """
        self.stage_reset(mask)
        with self._on_own_stream():
            self.launch("reset")

    def kinematics(self) -> None:
        """Recompute positions/orientations of bodies and sites from ``qpos`` (after writing the state)."""
        with self._on_own_stream():
            self.launch("kin")

    # ``cvel`` and ``cdof_dot`` are read by the next step before MuJoCo Warp recomputes them: without them a
    # restored world continues on a slightly different trajectory (found by comparing every Data array)
    _STATE_FIELDS = ("qpos", "qvel", "act", "ctrl", "mocap_pos", "mocap_quat", "qacc", "qacc_warmstart", "time",
                     "geom_xpos", "cvel", "cdof_dot")

    def get_state(self) -> dict[str, torch.Tensor]:
        """Copy of the simulation state of every world (enough to continue the same trajectory) and of the
        per-world model fields."""
        state = {f: wp.to_torch(getattr(self.data, f)).clone() for f in self._STATE_FIELDS}
        for name in self.batched_fields:
            state[f"model.{name}"] = self.model_field(name).clone()
        return state

    def set_state(self, state: dict[str, torch.Tensor]) -> None:
        """Restore a :meth:`get_state` copy (same model and ``nworld``) and recompute kinematics."""
        for key, value in state.items():
            dst = self.model_field(key[6:]) if key.startswith("model.") else wp.to_torch(getattr(self.data, key))
            if dst.shape != value.shape:
                raise ValueError(f"sim state {key!r}: shape {tuple(value.shape)} does not match {tuple(dst.shape)}")
            dst.copy_(value.to(dst.device))
        self.kinematics()

    def set_body_pos(self, body: int, pos: torch.Tensor, mask: torch.Tensor, worlds: slice | None = None) -> None:
        """Move a body that is fixed to the world (no joint on its path to the world) to ``pos`` ``[nworld, 3]``
        in the worlds of ``mask``; needs ``"body_pos"`` in ``batched_fields``.

        MuJoCo Warp computes the positions of world-fixed geoms once, when the data is made, so besides the
        per-world ``body_pos`` this also translates those geoms in the body's subtree (orientation unchanged).
        Jointed children, sites and the body frame follow through kinematics. ``worlds``: only these worlds
        (``pos`` and ``mask`` then have their length).
        """
        if "body_pos" not in self.batched_fields:
            raise ValueError("set_body_pos needs batched_fields=('body_pos', ...) when the WarpSim is created")
        if worlds is None:
            field = self.model_field("body_pos")[:, body]
        else:
            field = self.model_field("body_pos")[worlds, body]
        field.copy_(torch.where(mask[:, None], pos, field))
        ids, offsets = self._static_geoms[body]
        if ids.numel():  # shape metadata, no device sync
            geom_xpos = self.geom_xpos
            if worlds is not None:
                geom_xpos = geom_xpos[worlds]
            if offsets.dim() == 3:  # per world (world_models)
                offsets = offsets if worlds is None else offsets[worlds]
            current = geom_xpos.index_select(1, ids)
            geom_xpos.index_copy_(1, ids, torch.where(mask[:, None, None], pos[:, None, :] + offsets, current))

    def world_mjm(self, world: int) -> mujoco.MjModel:
        """The MjModel that world ``world`` simulates (``mjm`` unless the sim has ``world_models``)."""
        if self.world_models is None:
            return self.mjm
        start = 0
        for m, count in self.world_models:
            if start <= world < start + count:
                return m
            start += count
        raise IndexError(f"world {world} out of range for {self.nworld} worlds")

    def _stack_keyframes(self) -> None:
        """One keyframe block per world model: model ``i``'s keyframe ``k`` becomes keyframe ``i * nkey + k``."""
        nkey = self.mjm.nkey
        for name in KEY_FIELDS:
            current = getattr(self.model, name)
            per_key = tuple(current.shape[1:]) + tuple(getattr(current.dtype, "_shape_", ()))
            stacked = np.concatenate([np.asarray(getattr(m, name), dtype=np.float64).reshape((nkey,) + per_key)
                                      for m, _ in self.world_models])
            if stacked.size:
                new = wp.array(stacked, dtype=current.dtype, device=self.wp_device)
            else:
                new = wp.zeros((stacked.shape[0],) + tuple(current.shape[1:]), dtype=current.dtype,
                               device=self.wp_device)
            setattr(self.model, name, new)
        self.model.nkey = nkey * len(self.world_models)

    def _init_world_models(self, reset_key: int) -> None:
        """Write each world model's batched field values, keyframe ids, initial state and world-fixed geom offsets
        into its worlds (before the graphs are captured)."""
        key_base, start = [], 0
        offsets = {body: [] for body in self._static_geoms}
        data_fields = [f.name for f in dataclasses.fields(self.data)
                       if isinstance(getattr(self.data, f.name), wp.array)]
        for i, (m, count) in enumerate(self.world_models):
            sl = slice(start, start + count)
            for name in self.batched_fields:
                view = self.model_field(name)
                value = torch.as_tensor(np.asarray(getattr(m, name)), device=self.device)
                view[sl] = value.to(view.dtype).reshape(view.shape[1:])
            key_base.append(torch.full((count,), i * self.mjm.nkey, dtype=self._key_ids_t.dtype, device=self.device))
            # the state put_data would have made from this model (incl. the world-fixed geom poses, computed once)
            d = mujoco.MjData(m)
            if self._has_key:
                mujoco.mj_resetDataKeyframe(m, d, reset_key)
            mujoco.mj_forward(m, d)
            for name in data_fields:
                src = getattr(d, name, None)
                arr = getattr(self.data, name)
                if (not isinstance(src, np.ndarray) or arr.ndim < 1 or arr.shape[0] != self.nworld
                        or name.startswith(("efc_", "contact"))):
                    continue
                dst = wp.to_torch(arr)
                if src.size != dst[0].numel() or src.size == 0 or (src.ndim and dst.ndim > 1
                                                                   and src.shape[0] != dst.shape[1]):
                    continue
                dst[sl] = torch.as_tensor(src, device=self.device).to(dst.dtype).reshape(dst.shape[1:])
            for body, (_, offset) in self._static_geom_table(m).items():  # same bodies and geoms: one tree
                offsets[body].append(offset.expand(count, -1, -1))
            start += count
        self._static_geoms = {body: (ids, torch.cat(offsets[body])) for body, (ids, _) in self._static_geoms.items()}
        self._world_key = torch.cat(key_base)
        if self.device.type == "cuda":  # the writes above (torch's stream) before the sim's stream reads them
            torch.cuda.synchronize(self.device)

    def _static_geom_table(self, m: mujoco.MjModel | None = None) -> dict[int, tuple[torch.Tensor, torch.Tensor]]:
        """For every world-fixed body of ``m`` (default: the sim's model): its subtree's world-fixed geoms and
        their offsets from the body."""
        m = self.mjm if m is None else m
        d = mujoco.MjData(m)
        mujoco.mj_kinematics(m, d)
        table = {}
        for body in range(1, m.nbody):
            if m.body_weldid[body] != 0:
                continue
            ids = [g for g in range(m.ngeom)
                   if m.body_weldid[m.geom_bodyid[g]] == 0 and _in_subtree(m, int(m.geom_bodyid[g]), body)]
            table[body] = (
                torch.tensor(ids, dtype=torch.long, device=self.device),
                torch.tensor(d.geom_xpos[ids] - d.xpos[body], dtype=torch.float32, device=self.device).reshape(-1, 3),
            )
        return table

    def set_const(self) -> None:
        """Recompute the model constants derived from per-world masses, inertias and CoM offsets
        (``body_subtreemass``, ``body_invweight0``, ``dof_invweight0``, ...) after writing the batched fields
        through :meth:`model_field`; derived fields that are batched too get per-world values. Eager (not
        captured): call it after changing the model, not per step. The state of every world is kept."""
        with wp.ScopedDevice(self.wp_device), wp.ScopedStream(self._wp_stream) if self._wp_stream else _null():
            mjw.set_const(self.model, self.data)
        if self.stream is not None:
            self.stream.synchronize()

    @property
    def body_contact_force(self) -> torch.Tensor:
        """Zero-copy view ``[nworld, nbody, 3]``: net force of all contacts on each body (world frame, newtons) at
        the last substep of the last :meth:`step` (IsaacGym's net contact force). Needs ``contact_forces=True``."""
        if not self.contact_forces:
            raise ValueError("body_contact_force needs contact_forces=True when the WarpSim is created")
        return self._cfrc_ext[..., 3:]

    @property
    def geom_xpos(self) -> torch.Tensor:
        """Zero-copy view ``[nworld, ngeom, 3]`` of geom positions (MuJoCo Warp computes those of geoms fixed to
        the world once; moving such a body per world must move them too: see :meth:`set_body_pos`)."""
        return self._geom_xpos

    def unhealthy(self, max_abs_qvel: float = 1e4) -> torch.Tensor:
        """Bool ``[nworld]``: non-finite state, runaway velocities, or contact/constraint buffer overflow."""
        nonfinite, runaway, overflow = self.unhealthy_causes(max_abs_qvel).values()
        return nonfinite | runaway | overflow

    def unhealthy_causes(self, max_abs_qvel: float = 1e4) -> dict[str, torch.Tensor]:
        """The causes that make a world :meth:`unhealthy`, each bool ``[nworld]`` (a world may have several):
        ``"nonfinite"`` (state), ``"runaway"`` (a velocity above ``max_abs_qvel``), ``"overflow"`` (a fatal one)."""
        return {"nonfinite": ~torch.isfinite(self.qpos).all(-1) | ~torch.isfinite(self.qvel).all(-1),
                "runaway": self.qvel.abs().amax(-1) > max_abs_qvel,
                "overflow": (self._overflow & self.fatal_overflow) != 0}

    def overflowed(self, kinds: int, clear: bool = False, worlds: slice | None = None) -> torch.Tensor:
        """Bool ``[nworld]``: the world had an overflow of one of the ``mjw.OverflowType`` bits ``kinds`` since its
        last reset (or since these bits were last cleared: ``clear=True`` clears them after reading, so that a
        non-fatal overflow is counted per step; e.g. ``HFIELD_OVERFLOW`` where it is not fatal). ``worlds``: only
        these worlds (read and cleared)."""
        overflow = self._overflow if worlds is None else self._overflow[worlds]  # a view: clearing writes through
        hit = (overflow & int(kinds)) != 0
        if clear:
            overflow.bitwise_and_(~int(kinds))
        return hit

    def _on_own_stream(self):
        if self.stream is None:
            return _null()
        return _StreamJoin(self.stream)


def _in_subtree(m: mujoco.MjModel, body: int, root: int) -> bool:
    while body != 0:
        if body == root:
            return True
        body = int(m.body_parentid[body])
    return root == 0


class _null:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


class _StreamJoin:
    """Run a block of work on ``stream`` ordered after, and joined back into, the current torch stream."""

    def __init__(self, stream: torch.cuda.Stream) -> None:
        self.stream = stream

    def __enter__(self):
        self.main = torch.cuda.current_stream(self.stream.device)
        self.stream.wait_stream(self.main)
        self.ctx = torch.cuda.stream(self.stream)
        self.ctx.__enter__()
        return self

    def __exit__(self, *exc):
        self.ctx.__exit__(*exc)
        self.main.wait_stream(self.stream)
        return False


def launch_all(sims: Sequence[WarpSim], phase: str = "step", *, parallel_streams: bool = True) -> None:
    """Launch one phase (``"step"``, ``"reset"``, ``"kin"``: see :meth:`WarpSim.launch`) of several blocks,
    ordered after and joined back into the current torch stream. On the GPU each block runs on its own CUDA
    stream (concurrently); ``parallel_streams=False`` launches every block's graph on the current stream."""
    if not sims:
        return
    if sims[0].stream is None:
        for sim in sims:
            sim.launch(phase)
        return
    main = torch.cuda.current_stream(sims[0].device)
    if not parallel_streams:
        for sim in sims:
            sim.launch(phase, stream=main)
        return
    for sim in sims:
        sim.stream.wait_stream(main)
        sim.launch(phase)
    for sim in sims:
        main.wait_stream(sim.stream)
