"""The Parkour MuJoCo model: the Go1 of ``robot.py`` and the terrain grid of ``terrain.py`` as heightfields.

Terrain representation (``representation``). Both keep every terrain's exact shape (heights at every grid vertex;
MuJoCo's heightfield surface is the triangulation through them, as IsaacGym's "grid" trimesh):

* ``"tiles"`` (the env's default): one heightfield per tile (the tile plus ``tile_margin`` metres of its neighbours,
  cut from the grid) and one heightfield geom whose per-world ``geom_dataid`` selects the world's tile. Each world
  lives in its tile's local frame (physics position = world position - ``tile_offset[row, col]``), so every robot
  stays within about 10 m of its heightfield's centre.
* ``"grid"``: one heightfield holding the whole grid (190 m x 94 m for 10 x 21 tiles), shared by every world; each
  robot is spawned on its own tile, in world coordinates. MuJoCo Warp 4.0.0's heightfield narrowphase (float32
  GJK/EPA in the heightfield frame) returns wrong penetration depths, up to tens of metres, for geoms more than
  about 20 m from the heightfield centre (measured: ``docs/parkour.md``); such a contact launches the robot. Kept
  for comparison (``benchmarks/parkour_collision.py``); use it only for grids of a few tiles.

Both give MuJoCo Warp one static heightfield geom per world and the same narrowphase work (each robot geom is tested
against the prisms under its bounding box). Which robot geoms touch the terrain is ``terrain_collision``
(``robot.TERRAIN_COLLISIONS``).

Heights are written into the compiled model directly (MuJoCo would otherwise rescale each heightfield to its own
[0, 1] range): ``hfield_data = (h - h_min) / (h_max - h_min)`` with one ``h_min``/``h_max`` for the whole grid, the
geom sits at ``z = h_min`` and ``hfield_size[2] = h_max - h_min``, so every tile heightfield has the grid's scale.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from . import robot

TERRAIN_REPRESENTATIONS = ("tiles", "grid")
HFIELD_BASE_DEPTH = 1.0  # m of solid below the lowest terrain point
TERRAIN_FRICTION = 1.0  # the original's terrain material (robot geoms have priority; see env domain randomization)
# MuJoCo solver settings: Newton with mjlab's iteration counts for legged robots (it converges in a few iterations;
# on the GPU the solver exits early through a conditional graph node)
SOLVER_ITERATIONS = 10
LS_ITERATIONS = 20
# MuJoCo's own cap on GJK/EPA iterations, which the heightfield collisions (most of a Parkour step's GPU time) run per
# prism; 12 and 6 were measured no faster on the GPU (docs/parkour.md, "Contact stiffness")
CCD_ITERATIONS = 35
SUN_DIRECTION = (0.4, 0.3, -1.0)  # the scene's directional light (rendering only)


@dataclass(frozen=True)
class ParkourScene:
    """A compiled Parkour model and how its terrain is laid out.

    Attributes:
        mjm: the compiled model (robot free joint first: ``qpos[:7]`` base pose, ``qpos[7:]`` the 12 joints).
        representation: ``"tiles"`` or ``"grid"``.
        terrain_collision: which robot geoms touch the terrain (``robot.TERRAIN_COLLISIONS``).
        robot_inertia: the robot's inertial model (``robot.INERTIAL_MODELS``).
        robot_armature: the joints' rotor armature (kg m^2).
        robot_integrator: the physics integrator (``robot.INTEGRATORS``).
        robot_contact_timeconst: the time constant (s) of the robot's terrain contacts (None: MuJoCo's own 0.02).
        robot_collision_pieces: pieces per box and long capsule of the robot's collision set (``robot.go1_spec``).
        hfield_geom: id of the terrain heightfield geom.
        tile_offset: float32 ``[num_rows, num_cols, 3]`` world position of each tile's physics frame origin (zeros for
            ``"grid"``: physics coordinates are world coordinates).
        tile_hfield: int ``[num_rows, num_cols]`` heightfield id of each tile (all 0 for ``"grid"``).
        tile_margin: metres of neighbouring terrain around each tile heightfield (``"tiles"``).
    """

    mjm: mujoco.MjModel
    representation: str
    terrain_collision: str
    hfield_geom: int
    tile_offset: np.ndarray
    tile_hfield: np.ndarray
    tile_margin: float
    robot_inertia: str = robot.DEFAULT_INERTIAL_MODEL
    robot_armature: float = robot.JOINT_ARMATURE
    robot_integrator: str = robot.DEFAULT_INTEGRATOR
    robot_contact_timeconst: float | None = robot.DEFAULT_CONTACT_TIMECONST
    robot_collision_pieces: int = robot.DEFAULT_COLLISION_PIECES

    @property
    def contact_pairs(self) -> int:
        """Robot geoms that can touch the terrain (one heightfield pair each per world)."""
        m = self.mjm
        return int(np.sum((m.geom_contype & robot.ROBOT_BIT) != 0))


def _tile_grid_shape(terrain) -> tuple[int, int]:
    return terrain.tile_origins.shape[0], terrain.tile_origins.shape[1]


def build_scene(terrain, terrain_collision: str = robot.DEFAULT_TERRAIN_COLLISION, representation: str = "tiles",
                tile_margin: float = 1.0, robot_inertia: str = robot.DEFAULT_INERTIAL_MODEL,
                robot_armature: float | None = None, robot_integrator: str = robot.DEFAULT_INTEGRATOR,
                robot_contact_timeconst: float | None = robot.DEFAULT_CONTACT_TIMECONST,
                robot_collision_pieces: int = robot.DEFAULT_COLLISION_PIECES) -> ParkourScene:
    """Compile the Go1 and ``terrain`` (a ``terrain.Terrain``) into one MuJoCo model.

    Args:
        terrain: the generated terrain grid (heights in metres, cell ``(a, b)`` at world
            ``(-border + a*hs, -border + b*hs)``, ``border = terrain.border``).
        terrain_collision: robot geoms colliding with the terrain, one of ``robot.TERRAIN_COLLISIONS``.
        representation: one of ``TERRAIN_REPRESENTATIONS``.
        tile_margin: ``"tiles"`` only: metres of the neighbouring grid kept around each tile (less than the
            border).
        robot_inertia: the robot's masses and inertias, one of ``robot.INERTIAL_MODELS`` (``"menagerie"`` or
            ``"urdf"``: the original's; ``robot.py``).
        robot_armature: the joints' rotor armature (kg m^2); None: the inertial model's.
        robot_integrator: ``"euler"`` or ``"implicitfast"`` (``robot.INTEGRATORS``).
        robot_contact_timeconst: the time constant (s) of the robot's terrain contacts
            (``robot.DEFAULT_CONTACT_TIMECONST`` by default, None: MuJoCo's own 0.02;
            ``robot.CONTACT_TIMECONST_RANGE``).
        robot_collision_pieces: each box and long capsule of the robot's collision set as this many pieces (the same
            solids in shorter GPU heightfield-collision threads; ``robot.COLLISION_PIECES_RANGE``).
    """
    if representation not in TERRAIN_REPRESENTATIONS:
        raise ValueError(f"unknown terrain representation {representation!r}; valid choices: "
                         f"{', '.join(TERRAIN_REPRESENTATIONS)}")
    cfg = terrain.config
    hs, border = float(cfg.horizontal_scale), float(terrain.border)
    heights = np.asarray(terrain.heights, dtype=np.float64)
    nrows, ncols = _tile_grid_shape(terrain)
    h_min, h_max = float(heights.min()), float(heights.max())
    h_range = max(h_max - h_min, 1e-3)

    if representation == "grid":
        pieces = [heights]
        origin = (-border, -border)  # world position of cell (0, 0)
        tile_offset = np.zeros((nrows, ncols, 3), dtype=np.float32)
        tile_hfield = np.zeros((nrows, ncols), dtype=np.int32)
    else:
        margin = int(round(tile_margin / hs))
        lx, ly = int(round(cfg.tile_length / hs)), int(round(cfg.tile_width / hs))
        b = int(round(border / hs))
        if not 0 <= margin < b:
            raise ValueError(f"tile_margin must be in [0, {(b - 1) * hs:g}] m (less than the border of {border:g} m), "
                             f"got {tile_margin}")
        pieces, offsets = [], np.zeros((nrows, ncols, 3), dtype=np.float32)
        for i in range(nrows):
            for j in range(ncols):
                a0, b0 = b + i * lx - margin, b + j * ly - margin
                pieces.append(heights[a0: a0 + lx + 2 * margin + 1, b0: b0 + ly + 2 * margin + 1])
                offsets[i, j, :2] = (i * cfg.tile_length, j * cfg.tile_width)
        origin = (-margin * hs, -margin * hs)
        tile_offset = offsets
        tile_hfield = np.arange(nrows * ncols, dtype=np.int32).reshape(nrows, ncols)

    spec = robot.go1_spec(terrain_collision, robot_inertia, robot_armature, robot_integrator, robot_contact_timeconst,
                          robot_collision_pieces)
    spec.option.iterations = SOLVER_ITERATIONS
    spec.option.ls_iterations = LS_ITERATIONS
    spec.option.ccd_iterations = CCD_ITERATIONS
    nx, ny = pieces[0].shape
    rx, ry = 0.5 * (nx - 1) * hs, 0.5 * (ny - 1) * hs
    for k, piece in enumerate(pieces):
        # MuJoCo heightfield rows run along y, columns along x: data[r * ncol + c] = heights[c, r]
        spec.add_hfield(name=f"terrain_{k}", nrow=ny, ncol=nx, size=[rx, ry, h_range, HFIELD_BASE_DEPTH],
                        userdata=np.zeros(nx * ny).tolist())
    spec.worldbody.add_geom(
        name="terrain", type=mujoco.mjtGeom.mjGEOM_HFIELD, hfieldname="terrain_0",
        pos=[origin[0] + rx, origin[1] + ry, h_min], contype=0, conaffinity=robot.ROBOT_BIT, condim=3,
        friction=[TERRAIN_FRICTION, 0.005, 0.0001], group=0, rgba=[0.55, 0.5, 0.45, 1.0],
    )
    # for rendering only (evaluation videos): a sun from above and behind (the robot walks along +x); no physics
    spec.worldbody.add_light(name="sun", type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL, pos=[0.0, 0.0, 10.0],
                             dir=list(SUN_DIRECTION), diffuse=[0.8, 0.8, 0.8], ambient=[0.3, 0.3, 0.3],
                             specular=[0.1, 0.1, 0.1], castshadow=True)
    mjm = spec.compile()
    for k, piece in enumerate(pieces):
        adr = mjm.hfield_adr[k]
        mjm.hfield_data[adr: adr + nx * ny] = ((piece.T - h_min) / h_range).astype(np.float32).ravel()
    hfield_geom = mujoco.mj_name2id(mjm, mujoco.mjtObj.mjOBJ_GEOM, "terrain")
    return ParkourScene(mjm=mjm, representation=representation, terrain_collision=terrain_collision,
                        hfield_geom=hfield_geom, tile_offset=tile_offset, tile_hfield=tile_hfield,
                        tile_margin=float(tile_margin) if representation == "tiles" else 0.0,
                        robot_inertia=robot_inertia,
                        robot_armature=robot.joint_armature(robot_inertia, robot_armature),
                        robot_integrator=robot_integrator,
                        robot_contact_timeconst=robot_contact_timeconst,  # checked by go1_spec
                        robot_collision_pieces=int(robot_collision_pieces))
