"""Group-d Meta-World tasks (assembly, basketball, bin_picking, box_close, disassemble, soccer, stick_pull,
stick_push, sweep_into_goal, sweep): rewards and success rules against the paper-era MTBench formulas, scene
facts in MuJoCo C, and the scripted policies.

Reward parity: every task's pure reward and success functions are evaluated (torch, float64) on hand-built states
in this repository's frame and compared with an independent numpy transcription of MTBench's ``compute_reward``
(``isaacgymenvs/tasks/franka/vec_task/task_fns/<task>.py`` at ed2e2b5) evaluated on the same states mapped into
MTBench's own frame (``x_mtb = y - 0.6``, ``y_mtb = -x``, ``z_mtb = z + 1.027``; its pads separate along x_mtb,
its "xz" plane is (y_mtb, z); quaternions xyzw). MTBench's dense term is compared before its final ``* .01``.
One deliberate difference: MTBench's torch ``tolerance`` returns 0 *inside* the bounds whenever the margin is
positive (``value = where(margin > 0 & in_bounds, value, ...)`` keeps the 0 it initialised), which would zero every
in-place term at its optimum; the framework's ``tolerance`` is Meta-World's (1 inside the bounds), and so is the
reference here. Known answers (maxima at the goal, far states, each conditional branch, success thresholds on
both sides) are checked explicitly as well.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
import torch

from mtbench.assets import metaworld_assets_dir
from mtbench.envs.metaworld import TASKS
from mtbench.envs.metaworld.models import compiled_task
from mtbench.envs.metaworld.tasks import _nut, _stick
from mtbench.envs.metaworld.tasks import assembly as assembly_task
from mtbench.envs.metaworld.tasks import basketball as basketball_task
from mtbench.envs.metaworld.tasks import bin_picking as bin_task
from mtbench.envs.metaworld.tasks import box_close as box_task
from mtbench.envs.metaworld.tasks import disassemble as disassemble_task
from mtbench.envs.metaworld.tasks import soccer as soccer_task
from mtbench.envs.metaworld.tasks import stick_pull as pull_task
from mtbench.envs.metaworld.tasks import stick_push as push_task
from mtbench.envs.metaworld.tasks import sweep as sweep_task
from mtbench.envs.metaworld.tasks import sweep_into_goal as into_task

GROUP_D = {"assembly": 0, "basketball": 1, "bin_picking": 2, "box_close": 3, "disassemble": 12, "soccer": 43,
           "stick_pull": 44, "stick_push": 45, "sweep_into_goal": 46, "sweep": 47}
DESCRIPTIONS = {
    "assembly": "Pick up a round nut by its handle and fit it down over a vertical peg.",
    "basketball": "Grasp a basketball and drop it through the hoop.",
    "bin_picking": "Pick a small cube out of one bin and place it into the other bin.",
    "box_close": "Pick up the box lid and put it on top of the box to close it.",
    "disassemble": "Grasp the nut by its handle and lift it up and off the peg.",
    "soccer": "Kick a soccer ball into the goal.",
    "stick_pull": "Grasp a stick and use it to pull a container to the goal.",
    "stick_push": "Grasp a stick and use it to push a container to the goal.",
    "sweep_into_goal": "Sweep a puck across the table into a hole.",
    "sweep": "Sweep a puck off the edge of the table.",
}
MTB_TABLE_Z = 1.027
ATOL = 1e-9


# ------------------------------------------------------------------------------------------------ MTBench frame
def to_mtb(p) -> np.ndarray:
    """A point of this repository's (Meta-World's) frame in MTBench's frame."""
    p = np.asarray(p, dtype=np.float64)
    return np.array([p[1] - 0.6, -p[0], p[2] + MTB_TABLE_Z])


def quat_to_mtb(q_wxyz) -> np.ndarray:
    """An orientation (wxyz, this frame) as MTBench's xyzw quaternion in its frame (a -90 degree turn about z)."""
    c = np.array([math.cos(-math.pi / 4), 0.0, 0.0, math.sin(-math.pi / 4)])
    w1, x1, y1, z1 = c
    w2, x2, y2, z2 = np.asarray(q_wxyz, dtype=np.float64)
    q = np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                  w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])
    return np.array([q[1], q[2], q[3], q[0]])


def tol(x: float, lo: float, hi: float, margin: float) -> float:
    """Long-tail tolerance with Meta-World's semantics (1 inside the bounds; value 0.1 at ``margin``)."""
    if lo <= x <= hi:
        return 1.0
    if margin <= 0:
        return 0.0
    d = (lo - x if x < lo else x - hi) / margin
    return 1.0 / ((3.0 * d) ** 2 + 1.0)  # long_tail scale sqrt(1/0.1 - 1) = 3


def ham(a: float, b: float) -> float:
    den = a + b - a * b
    return a * b / den if den > 0 else 0.0


def nrm(v) -> float:
    return float(np.linalg.norm(v))


def caging_mtb(obj, lpad, rpad, init_tcp, a3, obj_init, obj_radius, pad_thresh, reach_radius, xz_thresh) -> float:
    """MTBench's ``_gripper_caging_reward`` (medium density), in its frame: pads along x_mtb, "xz" = (y_mtb, z)."""
    tcp = (lpad + rpad) / 2.0
    caging_lr = []
    for pad in (lpad, rpad):
        margin = abs(abs(pad[0] - obj_init[0]) - pad_thresh)
        caging_lr.append(tol(abs(pad[0] - obj[0]), obj_radius, pad_thresh, margin))
    caging_y = ham(*caging_lr)
    xz_margin = nrm(obj_init[1:] - init_tcp[1:]) - xz_thresh
    caging_xz = tol(nrm(tcp[1:] - obj[1:]), 0.0, xz_thresh, xz_margin)
    closed = min(max(0.0, a3), 1.0)
    caging = ham(caging_y, caging_xz)
    gripping = closed if caging > 0.97 else 0.0
    caging_and_gripping = ham(caging, gripping)
    reach = tol(nrm(obj - tcp), 0.0, reach_radius, abs(nrm(obj_init - init_tcp) - reach_radius))
    return (caging_and_gripping + reach) / 2.0


def opened_mtb(lpad, rpad) -> float:
    return min(max(nrm(rpad - lpad) / 0.095, 0.0), 1.0)


# MTBench's compute_reward of each task, transcribed in its frame (all points MTBench-frame numpy arrays)
def ref_assembly(lpad, rpad, init_tcp, a3, target, wrench, center, quat_xyzw, obj_init):
    tcp = (lpad + rpad) / 2.0
    threshed = wrench.copy()
    if abs(wrench[1] - tcp[1]) < 0.01:
        threshed[1] = tcp[1]
    grab = caging_mtb(threshed, lpad, rpad, init_tcp, a3, obj_init, 0.02, 0.05, 0.0, 0.005)
    pos_error = target - center
    radius = nrm(pos_error[:2])
    success = radius < 0.02 and pos_error[2] > 0.0
    threshold = 0.02 if success else 0.01
    height = 0.02 * math.log(radius - threshold) + MTB_TABLE_Z + 0.2 if radius > threshold else MTB_TABLE_Z
    pos_error[2] = 3.0 * (height - center[2])
    lifted = center[2] > MTB_TABLE_Z + 0.02 or radius < threshold
    in_place = 0.1 * lifted + 0.9 * tol(nrm(pos_error), 0.0, 0.02, 0.4)
    quat = max(1.0 - nrm(quat_xyzw - np.array([0.0, 0.0, 0.0, 1.0])) / 4.0, 0.0)
    return (2.0 * grab + 8.0 * in_place) * quat, success


def ref_disassemble(lpad, rpad, init_tcp, a3, target, wrench, center, obj_init):
    tcp = (lpad + rpad) / 2.0
    threshed = wrench.copy()
    if abs(wrench[1] - tcp[1]) < 0.01:
        threshed[1] = tcp[1]
    grab = caging_mtb(threshed, lpad, rpad, init_tcp, a3, obj_init, 0.02, 0.05, 0.0, 0.005)
    pos_error = target - center
    pos_error[2] += 0.1
    lifted = center[2] > MTB_TABLE_Z + 0.02
    in_place = 0.1 * lifted + 0.9 * tol(nrm(pos_error), 0.0, 0.02, 0.2)
    return 2.0 * grab + 6.0 * in_place, abs(center[2] - target[2]) < 0.05


def ref_basketball(lpad, rpad, init_tcp, a3, target, obj, obj_init):
    tcp = (lpad + rpad) / 2.0
    target_to_obj = nrm(obj - target)
    in_place = tol(target_to_obj, 0.0, 0.08, nrm(obj_init - target))
    grasped = caging_mtb(obj, lpad, rpad, init_tcp, a3, obj_init, 0.025, 0.06, 0.01, 0.005)
    reward = ham(grasped, in_place)
    if nrm(obj - tcp) < 0.02 and opened_mtb(lpad, rpad) > 0 and obj[2] - 0.01 > obj_init[2]:
        reward += 1.0 + 5.0 * in_place
    return reward, target_to_obj < 0.08


def ref_bin_picking(lpad, rpad, init_tcp, a3, target, obj, obj_init):
    tcp = (lpad + rpad) / 2.0
    target_to_obj = nrm(obj - target)
    in_place = tol(target_to_obj, 0.0, 0.05, nrm(obj_init - target))
    grasped = caging_mtb(obj, lpad, rpad, init_tcp, a3, obj_init, 0.02, 0.05, 0.0, 0.005)
    reward = ham(grasped, in_place)
    grasp_success = nrm(obj - tcp) < 0.04 and obj[2] - 0.02 > obj_init[2] and opened_mtb(lpad, rpad) > 0
    if grasp_success:
        reward += 1.0 + 5.0 * in_place
    return reward, target_to_obj < 0.05


def ref_box_close(tcp, a3, target, lid, lid_base):
    radius = nrm(tcp[:2] - lid[:2])
    floor = MTB_TABLE_Z if radius <= 0.02 else 0.04 * math.log(radius - 0.02) + MTB_TABLE_Z + 0.4
    margin = 0.0 if floor < 0 else floor / 2.0
    above_floor = 1.0 if tcp[2] >= floor else tol(max(floor - tcp[2], 0.0), 0.0, 0.01, margin)
    in_place = tol(nrm(tcp - lid), 0.0, 0.02, 0.5)
    grab = (min(max(a3, -1.0), 1.0) + 1.0) / 2.0
    ready = ham(above_floor, in_place)
    pos_error = nrm((target - lid) * np.array([1.0, 1.0, 3.0]))
    lifted = 0.2 * (lid[2] > MTB_TABLE_Z + 0.106) + 0.8 * tol(pos_error, 0.0, 0.05, 0.25)
    return 2.0 * ham(grab, ready) + 8.0 * lifted, nrm(lid_base - target) < 0.08


def ref_soccer(lpad, rpad, init_tcp, a3, target, obj, obj_init):
    scale = np.array([1.0, 3.0, 1.0])
    target_to_obj = nrm((obj - target) * scale)
    in_place = tol(target_to_obj, 0.0, 0.07, nrm((obj - obj_init) * scale))
    goal_line = target[0]
    if obj[0] >= goal_line and abs(obj[1] - target[1]) > 0.1:
        in_place = min(max(in_place - 2.0 * ((obj[0] - goal_line) / (1.0 - goal_line)), 0.0), 1.0)
    grasped = caging_mtb(obj, lpad, rpad, init_tcp, a3, obj_init, 0.013, 0.05, 0.01, 0.005)
    return 3.0 * grasped + 6.5 * in_place, target_to_obj < 0.07


def ref_stick_pull(lpad, rpad, init_tcp, a3, target, stick, stick_init, handle, handle_init, end):
    tcp = (lpad + rpad) / 2.0
    yz = np.array([1.0, 1.0, 2.0])
    stick_in_place = tol(nrm((stick - handle) * yz), 0.0, 0.05, nrm((stick_init - handle_init) * yz))
    stick_in_place_2 = tol(nrm(stick - target), 0.0, 0.05, nrm(stick_init - target))
    container_in_place = tol(nrm(handle - target), 0.0, 0.05, nrm(handle_init - target))
    grasped = caging_mtb(stick, lpad, rpad, init_tcp, a3, stick_init, 0.02, 0.05, 0.0, 0.005)
    grasp_success = nrm(stick - tcp) < 0.03 and opened_mtb(lpad, rpad) > 0 and stick[2] - 0.01 > stick_init[2]
    if grasp_success:
        grasped = 1.0
    h = ham(grasped, stick_in_place)
    inserted = end[1] <= handle[1] and abs(end[0] - handle[0]) <= 0.04 and abs(end[2] - handle[2]) <= 0.02
    reward = h
    if grasp_success:
        reward = 1.0 + h + 5.0 * stick_in_place
    if grasp_success and inserted:
        reward = 1.0 + h + 5.0 + 10.0 * stick_in_place_2 + 10.0 * container_in_place
    return reward, nrm(handle - target) <= 0.12 and grasp_success and inserted


def ref_stick_push(lpad, rpad, init_tcp, a3, target, stick, stick_init, container_xy, obj_init):
    tcp = (lpad + rpad) / 2.0
    stick_margin = max(nrm(stick_init - target) - 0.1, 0.0)
    stick_in_place = tol(nrm(stick - target), 0.0, 0.1, stick_margin)
    container_to_target = nrm(container_xy - target[:2])
    container_margin = max(nrm(obj_init[:2] - target[:2]) - 0.1, 0.0)
    container_in_place = tol(container_to_target, 0.0, 0.1, container_margin)
    grasped = caging_mtb(stick, lpad, rpad, init_tcp, a3, obj_init, 0.02, 0.05, 0.0, 0.005)
    grasp_success = nrm(stick - tcp) < 0.03 and opened_mtb(lpad, rpad) > 0 and stick[2] - 0.01 > stick_init[2]
    reward = grasped + (5.0 * stick_in_place + 3.0 * container_in_place if grasp_success else 0.0)
    return reward, grasp_success and container_to_target <= 0.1


def ref_sweep(lpad, rpad, init_tcp, a3, target, obj, obj_init):
    in_place = tol(nrm(obj - target), 0.0, 0.05, nrm(obj_init - target))
    grasped = caging_mtb(obj, lpad, rpad, init_tcp, a3, obj_init, 0.02, 0.05, 0.0, 0.005)
    return 8.0 * ham(grasped, in_place) + 2.0 * in_place, nrm(obj - target) < 0.05


def ref_sweep_into_goal(lpad, rpad, init_tcp, a3, target, obj, obj_init):
    reward, success = ref_sweep(lpad, rpad, init_tcp, a3, target, obj, obj_init)
    return reward, success and nrm(obj - (lpad + rpad) / 2.0) < 0.03


# ------------------------------------------------------------------------------------------------ states
def _t(x) -> torch.Tensor:
    return torch.as_tensor(np.asarray(x, dtype=np.float64))


def _b(x) -> torch.Tensor:
    """One state as a batch of one."""
    return _t(x)[None]


class State(dict):
    """One hand-built state in this repository's frame (numpy float64); pads around the TCP along y."""

    @classmethod
    def make(cls, rng: np.random.Generator, *, obj_init, obj, goal, near: bool, init_tcp=(0.0, 0.6, 0.2),
             **extra) -> "State":
        obj = np.asarray(obj, dtype=np.float64)
        tcp = obj + (rng.normal(0.0, 0.006, 3) if near else rng.normal(0.0, 0.08, 3))
        half = rng.uniform(0.012, 0.045)
        s = cls(obj_init=np.asarray(obj_init, np.float64), obj=obj, goal=np.asarray(goal, np.float64), tcp=tcp,
                left=tcp + [0.0, half, 0.0], right=tcp - [0.0, half, 0.0],
                init_tcp=np.asarray(init_tcp, np.float64) + rng.normal(0.0, 0.01, 3),
                action=np.array([0.0, 0.0, 0.0, rng.uniform(-1.0, 1.0)]))
        s.update({k: np.asarray(v, np.float64) for k, v in extra.items()})
        return s

    @property
    def opened(self) -> float:
        return min(nrm(self["right"] - self["left"]) / 0.1, 1.0)

    def mtb(self, key: str) -> np.ndarray:
        return to_mtb(self[key])


def _ours(fn, *arrays):
    return fn(*(_b(a) for a in arrays))


def _check(ours_reward, ours_success, ref) -> None:
    ref_reward, ref_success = ref
    assert float(ours_reward) == pytest.approx(ref_reward, abs=ATOL)
    assert bool(ours_success) is bool(ref_success)


def _sample_modes(rng, n, obj_init_fn, goal_fn, lift=0.05):
    """Object states covering the reward branches: at its start, lifted in the hand, near the goal, random."""
    out = []
    for i in range(n):
        obj_init, goal = obj_init_fn(), goal_fn()
        mode = i % 4
        if mode == 0:
            obj = obj_init
        elif mode == 1:
            obj = obj_init + [0.0, 0.0, lift]
        elif mode == 2:
            obj = goal + rng.normal(0.0, 0.03, 3)
        else:
            obj = obj_init + rng.normal(0.0, 0.1, 3)
        out.append((obj_init, obj, goal, mode in (1, 2) or i % 3 == 0))
    return out


# ------------------------------------------------------------------------------------------------ registry
def test_group_d_tasks_are_registered() -> None:
    for name, tid in GROUP_D.items():
        cls = TASKS[name]
        assert cls.mtbench_id == tid and cls.name == name
        assert cls.description == DESCRIPTIONS[name]
        assert cls.success_bonus == (20.0 if name in ("stick_pull", "sweep", "sweep_into_goal") else 10.0)
        assert cls.dense_scale == 0.01
        assert len(cls.reset_low) == len(cls.reset_high)
        assert all(lo <= hi for lo, hi in zip(cls.reset_low, cls.reset_high))


# ------------------------------------------------------------------------------------------------ sweep
def _free_task_check(rng, ours_reward, ours_success, ref, obj_init_fn, goal_fn, n=48, **kw):
    branches = set()
    for obj_init, obj, goal, near in _sample_modes(rng, n, obj_init_fn, goal_fn, **kw):
        s = State.make(rng, obj_init=obj_init, obj=obj, goal=goal, near=near)
        r, ok = ours_reward(s), ours_success(s)
        expected = ref(s.mtb("left"), s.mtb("right"), s.mtb("init_tcp"), s["action"][3], s.mtb("goal"), s.mtb("obj"),
                       s.mtb("obj_init"))
        _check(r, ok, expected)
        branches.add(bool(ok))
    return branches


def test_sweep_matches_mtbench() -> None:
    rng = np.random.default_rng(0)
    ours_r = lambda s: _ours(sweep_task.sweep_reward, s["action"], s["obj"], s["tcp"], s["left"], s["right"],  # noqa
                             s["goal"], s["obj_init"], s["init_tcp"])
    ours_s = lambda s: _ours(sweep_task.sweep_success, s["obj"], s["goal"])  # noqa: E731
    init = lambda: np.array([rng.uniform(-0.1, 0.1), rng.uniform(0.6, 0.7), 0.02])  # noqa: E731
    seen = _free_task_check(rng, ours_r, ours_s, ref_sweep, init, lambda: np.array([0.4, 0.65, 0.02]))
    assert seen == {True, False}


def test_sweep_known_answers() -> None:
    goal = np.array([0.4, 0.65, 0.02])
    obj_init = np.array([0.0, 0.65, 0.02])
    init_tcp = np.array([0.0, 0.6, 0.2])
    # block at the goal, caged by the pads (3 cm either side), TCP at the block, gripper closed:
    # caging = 1, gripping = 1, reach = 1 -> grasp = 1; in_place = 1 -> 8·1 + 2·1
    r = sweep_task.sweep_reward(_b([0, 0, 0, 1.0]), _b(goal), _b(goal), _b(goal + [0, 0.03, 0]), _b(goal - [0, 0.03, 0]),
                                _b(goal), _b(obj_init), _b(init_tcp))
    assert float(r) == pytest.approx(10.0, abs=1e-12)
    # block untouched at its start, hand at its start: in_place = long_tail((0.4 − 0.05)/0.4); the caging term
    # is MTBench's (its reach part is at its margin value 0.1)
    left, right = init_tcp + [0, 0.045, 0], init_tcp - [0, 0.045, 0]
    r = sweep_task.sweep_reward(_b([0, 0, 0, -1.0]), _b(obj_init), _b(init_tcp), _b(left), _b(right), _b(goal),
                                _b(obj_init), _b(init_tcp))
    in_place = 1.0 / (1.0 + (3.0 * 0.35 / 0.4) ** 2)
    grasp = caging_mtb(to_mtb(obj_init), to_mtb(left), to_mtb(right), to_mtb(init_tcp), -1.0, to_mtb(obj_init), 0.02,
                       0.05, 0.0, 0.005)
    assert grasp == pytest.approx(0.05)  # gripper open: (0 + reach 0.1)/2
    assert float(r) == pytest.approx(8.0 * ham(grasp, in_place) + 2.0 * in_place, abs=1e-12)
    for d, ok in ((0.049, True), (0.051, False)):
        assert bool(sweep_task.sweep_success(_b(goal + [0, d, 0]), _b(goal))) is ok


def test_sweep_into_goal_matches_mtbench() -> None:
    rng = np.random.default_rng(1)
    ours_r = lambda s: _ours(into_task.sweep_into_goal_reward, s["action"], s["obj"], s["tcp"], s["left"],  # noqa
                             s["right"], s["goal"], s["obj_init"], s["init_tcp"])
    ours_s = lambda s: _ours(into_task.sweep_into_goal_success, s["obj"], s["tcp"], s["goal"])  # noqa: E731
    init = lambda: np.array([rng.uniform(-0.1, 0.1), rng.uniform(0.6, 0.7), 0.07])  # noqa: E731
    seen = _free_task_check(rng, ours_r, ours_s, ref_sweep_into_goal, init, lambda: np.array([0.0, 0.84, 0.0325]))
    assert seen == {True, False}


def test_sweep_into_goal_success_needs_the_hand() -> None:
    goal = np.array([0.0, 0.84, 0.0325])
    block = np.array([0.0, 0.84, 0.02])  # resting on the hole's floor, 1.25 cm below the goal
    assert bool(into_task.sweep_into_goal_success(_b(block), _b(block + [0, 0, 0.029]), _b(goal)))
    assert not bool(into_task.sweep_into_goal_success(_b(block), _b(block + [0, 0, 0.031]), _b(goal)))
    edge = block + [0.0, math.sqrt(0.05 ** 2 - 0.0125 ** 2) + 1e-4, 0.0]
    assert not bool(into_task.sweep_into_goal_success(_b(edge), _b(edge), _b(goal)))
    assert bool(into_task.sweep_into_goal_success(_b(edge - [0, 2e-4, 0]), _b(edge), _b(goal)))


# ------------------------------------------------------------------------------------------------ bin picking
def test_bin_picking_matches_mtbench() -> None:
    rng = np.random.default_rng(2)
    ours_r = lambda s: _ours(bin_task.bin_picking_reward, s["action"], s["obj"], s.opened, s["tcp"],  # noqa
                             s["left"], s["right"], s["goal"], s["obj_init"], s["init_tcp"])
    ours_s = lambda s: _ours(bin_task.bin_picking_success, s["obj"], s["goal"])  # noqa: E731
    init = lambda: np.array([-0.15, rng.uniform(0.65, 0.75), 0.02])  # noqa: E731
    seen = _free_task_check(rng, ours_r, ours_s, ref_bin_picking, init, lambda: np.array([0.12, 0.7, 0.05]))
    assert seen == {True, False}


def test_bin_picking_grasp_branch() -> None:
    obj_init, goal, init_tcp = np.array([-0.15, 0.7, 0.02]), np.array([0.12, 0.7, 0.05]), np.array([0, 0.6, 0.2])
    held = obj_init + [0.0, 0.0, 0.025]  # 2.5 cm up: lifted (> 2 cm)
    args = lambda obj, opened: (_b([0, 0, 0, 1.0]), _b(obj), _t([opened]), _b(obj), _b(obj + [0, 0.022, 0]),  # noqa
                                _b(obj - [0, 0.022, 0]), _b(goal), _b(obj_init), _b(init_tcp))
    base = bin_task.bin_picking_reward(*args(obj_init + [0, 0, 0.015], 0.44))  # 1.5 cm: not lifted
    lifted = bin_task.bin_picking_reward(*args(held, 0.44))
    in_place = 1.0 / (1.0 + (3.0 * (nrm(held - goal) - 0.05) / nrm(obj_init - goal)) ** 2)
    assert float(base) < 1.0
    assert float(lifted) - 1.0 - 5.0 * in_place == pytest.approx(
        float(bin_task.bin_picking_reward(*args(held, 0.0))), abs=1e-12)  # the closed-on-nothing state has no bonus


# ------------------------------------------------------------------------------------------------ basketball
def test_basketball_matches_mtbench() -> None:
    rng = np.random.default_rng(3)
    ours_r = lambda s: _ours(basketball_task.basketball_reward, s["action"], s["obj"], s.opened, s["tcp"],  # noqa
                             s["left"], s["right"], s["goal"], s["obj_init"], s["init_tcp"])
    ours_s = lambda s: _ours(basketball_task.basketball_success, s["obj"], s["goal"])  # noqa: E731
    init = lambda: np.array([rng.uniform(-0.1, 0.1), rng.uniform(0.6, 0.7), 0.03])  # noqa: E731
    goal = lambda: np.array([rng.uniform(-0.1, 0.1), rng.uniform(0.85, 0.9) - 0.083, 0.25])  # noqa: E731
    seen = _free_task_check(rng, ours_r, ours_s, ref_basketball, init, goal)
    assert seen == {True, False}


def test_basketball_hoop_is_the_goal_and_success_radius() -> None:
    base = np.array([0.05, 0.88, 0.0])
    hoop = base + np.array(basketball_task.HOOP_FROM_BASE)
    for d, ok in ((0.079, True), (0.081, False)):
        assert bool(basketball_task.basketball_success(_b(hoop + [0, 0, d]), _b(hoop))) is ok
    # held and lifted at the hoop: hamacher(grasp, 1) + 1 + 5
    r = basketball_task.basketball_reward(_b([0, 0, 0, 1.0]), _b(hoop), _t([0.6]), _b(hoop), _b(hoop + [0, 0.03, 0]),
                                          _b(hoop - [0, 0.03, 0]), _b(hoop), _b([0.0, 0.65, 0.03]), _b([0, 0.6, 0.2]))
    assert 6.0 < float(r) <= 7.0 + 1e-12


# ------------------------------------------------------------------------------------------------ soccer
def test_soccer_matches_mtbench() -> None:
    rng = np.random.default_rng(4)
    ours_r = lambda s: _ours(soccer_task.soccer_reward, s["action"], s["obj"], s["tcp"], s["left"], s["right"],  # noqa
                             s["goal"], s["obj_init"], s["init_tcp"])
    ours_s = lambda s: _ours(soccer_task.soccer_success, s["obj"], s["goal"])  # noqa: E731
    init = lambda: np.array([rng.uniform(-0.1, 0.1), rng.uniform(0.6, 0.7), 0.03])  # noqa: E731
    goal = lambda: np.array([rng.uniform(-0.1, 0.1), rng.uniform(0.8, 0.9) - 0.1, 0.013])  # noqa: E731
    seen = _free_task_check(rng, ours_r, ours_s, ref_soccer, init, goal)
    assert seen == {True, False}
    # the "past the goal line, wide of the target" penalty
    for _ in range(12):
        s = State.make(rng, obj_init=init(), obj=np.zeros(3), goal=goal(), near=False)
        s["obj"] = s["goal"] + [rng.choice([-1, 1]) * rng.uniform(0.11, 0.2), rng.uniform(0.0, 0.1), 0.013]
        r = ours_r(s)
        expected = ref_soccer(s.mtb("left"), s.mtb("right"), s.mtb("init_tcp"), s["action"][3], s.mtb("goal"),
                              s.mtb("obj"), s.mtb("obj_init"))
        _check(r, ours_s(s), expected)


def test_soccer_success_weights_the_lateral_error() -> None:
    target = np.array([0.0, 0.75, 0.013])
    ball = target + [0.0, 0.0, 0.013]
    assert bool(soccer_task.soccer_success(_b(ball + [0.0, 0.06, 0.0]), _b(target)))  # √(0.06² + 0.013²) < 0.07
    assert not bool(soccer_task.soccer_success(_b(ball + [0.023, 0.0, 0.0]), _b(target)))  # 3·0.023 ⊕ 0.013
    assert bool(soccer_task.soccer_success(_b(ball + [0.02, 0.0, 0.0]), _b(target)))


# ------------------------------------------------------------------------------------------------ box close
def _lid_states(rng, n):
    states = []
    for i in range(n):
        goal = np.array([rng.uniform(-0.1, 0.1), rng.uniform(0.75, 0.85), 0.133])
        top_init = np.array([rng.uniform(-0.05, 0.05), rng.uniform(0.45, 0.5), 0.016])
        mode = i % 4
        top = (top_init, top_init + [0, 0, 0.05], goal + rng.normal(0, 0.04, 3), goal - [0, 0, 0.073])[mode]
        lid = top + [0.0, 0.0, box_task.LID_POINT]
        tcp = lid + (rng.normal(0, 0.01, 3) if i % 3 else rng.normal(0, 0.15, 3))
        states.append((tcp, lid, top, goal, rng.uniform(-1.0, 1.0)))
    return states


def test_box_close_matches_mtbench() -> None:
    seen = set()
    for tcp, lid, top, goal, a3 in _lid_states(np.random.default_rng(5), 64):
        r = box_task.box_close_reward(_b([0, 0, 0, a3]), _b(lid), _b(tcp), _b(goal))
        ok = box_task.box_close_success(_b(top), _b(goal))
        _check(r, ok, ref_box_close(to_mtb(tcp), a3, to_mtb(goal), to_mtb(lid), to_mtb(top)))
        seen.add(bool(ok))
    assert seen == {True, False}


def test_box_close_known_answers() -> None:
    goal = np.array([0.0, 0.8, 0.133])
    lid = goal.copy()  # the handle point at the target height over the box
    # hand at the lid (above the funnel's floor), gripper closed, lid at the goal: 2·1 + 8·(0.2 + 0.8)
    assert float(box_task.box_close_reward(_b([0, 0, 0, 1.0]), _b(lid), _b(lid), _b(goal))) == pytest.approx(10.0)
    # gripper open: the grab term is 0 -> 8
    assert float(box_task.box_close_reward(_b([0, 0, 0, -1.0]), _b(lid), _b(lid), _b(goal))) == pytest.approx(8.0)
    # a lid closed on the box (top_link at 0.06) counts within 3.3 cm of the centre
    closed = goal - [0.0, 0.0, 0.073]
    assert bool(box_task.box_close_success(_b(closed + [0.03, 0, 0]), _b(goal)))
    assert not bool(box_task.box_close_success(_b(closed + [0.034, 0, 0]), _b(goal)))


# ------------------------------------------------------------------------------------------------ nut tasks
def _nut_states(rng, n, ring_init_fn, goal_fn):
    q0 = np.array(_nut.NUT_QUAT)
    states = []
    for i in range(n):
        ring_init, goal = ring_init_fn(), goal_fn()
        mode = i % 4
        ring = (ring_init, ring_init + [0, 0, 0.06], goal - [0, 0, rng.uniform(0.0, 0.1)] + [*rng.normal(0, 0.015, 2), 0],
                ring_init + rng.normal(0, 0.08, 3))[mode]
        angle = rng.normal(0.0, 0.3) * (i % 2)
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        dq = np.array([math.cos(angle / 2), *(math.sin(angle / 2) * axis)])
        w1, x1, y1, z1 = dq
        w2, x2, y2, z2 = q0
        quat = np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                         w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])
        handle = ring + [_nut.HANDLE_OFFSET, 0.0, 0.0]
        states.append((ring_init, ring, handle, quat, goal))
    return states


def test_assembly_matches_mtbench() -> None:
    rng = np.random.default_rng(6)
    seen = set()
    ring0 = lambda: np.array([0.0, 0.6, 0.02])  # noqa: E731
    goal = lambda: np.array([rng.uniform(-0.1, 0.1), rng.uniform(0.75, 0.85), 0.15])  # noqa: E731
    for i, (ring_init, ring, handle, quat, target) in enumerate(_nut_states(rng, 64, ring0, goal)):
        obj_init = ring_init - [_nut.HANDLE_OFFSET, 0.0, 0.0]  # MTBench's obj_init_pos (see Assembly)
        s = State.make(rng, obj_init=obj_init, obj=handle, goal=target, near=i % 3 != 0)
        if i % 5 == 0:  # the TCP within 1 cm of the handle in x: the snapped branch
            s["tcp"][0] = handle[0] + rng.uniform(-0.009, 0.009)
            s["left"][0] = s["right"][0] = s["tcp"][0]
        r = assembly_task.assembly_reward(_b(s["action"]), _b(handle), _b(ring), _b(quat), _b(_nut.NUT_QUAT),
                                          _b(s["tcp"]), _b(s["left"]), _b(s["right"]), _b(target), _b(obj_init),
                                          _b(s["init_tcp"]))
        ok = assembly_task.assembly_success(_b(ring), _b(target))
        expected = ref_assembly(s.mtb("left"), s.mtb("right"), s.mtb("init_tcp"), s["action"][3], to_mtb(target),
                                to_mtb(handle), to_mtb(ring), quat_to_mtb(quat), to_mtb(obj_init))
        _check(r, ok, expected)
        seen.add(bool(ok))
    assert seen == {True, False}


def test_assembly_known_answers() -> None:
    target = np.array([0.05, 0.8, 0.15])  # 5 cm above the peg's top
    q0 = _b(_nut.NUT_QUAT)
    # ring threaded on the peg half way down: aligned and hooked, in_place = 0.1 + 0.9·tol(3·|0 − 0.05|) ...
    ring = target - [0.0, 0.0, 0.1]
    in_place, success = assembly_task.assembly_in_place(_b(ring), _b(target))
    assert bool(success)
    assert float(in_place) == pytest.approx(0.1 + 0.9 / (1.0 + (3.0 * (0.15 - 0.02) / 0.4) ** 2))
    # ... and at the funnel's bottom (ring on the table inside the threshold) in_place = 1
    in_place, _ = assembly_task.assembly_in_place(_b([0.05, 0.8, 0.0]), _b(target))
    assert float(in_place) == pytest.approx(1.0)
    # success boundaries: 2 cm from the axis, below the target
    for offset, ok in (([0.019, 0, -0.01], True), ([0.021, 0, -0.01], False), ([0, 0, 0.001], False)):
        assert bool(assembly_task.assembly_success(_b(target + offset), _b(target))) is ok
    # the quaternion term: a nut turned by 180 degrees about x has ‖q − q0‖ = √2 → factor 1 − √2/4
    flipped = _b([0.0, 0.7071067811865476, 0.7071067811865476, 0.0])
    handle = target + [0.13, 0.0, -0.1]

    def reward(quat: torch.Tensor) -> float:
        return float(assembly_task.assembly_reward(
            _b([0, 0, 0, 1.0]), _b(handle), _b(ring), quat, q0, _b(handle), _b(handle + [0, 0.03, 0]),
            _b(handle - [0, 0.03, 0]), _b(target), _b([-0.13, 0.6, 0.02]), _b([0.0, 0.6, 0.2])))

    assert reward(flipped) == pytest.approx(reward(q0) * (1.0 - math.sqrt(2.0) / 4.0))
    assert reward(q0) == pytest.approx(2.0 * 1.0 + 8.0 * (0.1 + 0.9 / (1.0 + (3.0 * 0.13 / 0.4) ** 2)))


def test_disassemble_matches_mtbench() -> None:
    rng = np.random.default_rng(7)
    seen = set()
    ring0 = lambda: np.array([rng.uniform(0.0, 0.1), rng.uniform(0.6, 0.75), 0.025])  # noqa: E731
    for i, (ring_init, ring, handle, quat, _) in enumerate(_nut_states(rng, 64, ring0, lambda: np.zeros(3))):
        target = ring_init + [0.0, 0.0, 0.15]
        if i % 4 == 2:  # lifted towards the target
            ring = target + rng.normal(0.0, 0.04, 3)
            handle = ring + [_nut.HANDLE_OFFSET, 0.0, 0.0]
        obj_init = ring_init + [_nut.HANDLE_OFFSET, 0.0, 0.0]
        s = State.make(rng, obj_init=obj_init, obj=handle, goal=target, near=i % 3 != 0, init_tcp=(0.0, 0.4, 0.2))
        r = disassemble_task.disassemble_reward(_b(s["action"]), _b(handle), _b(ring), _b(s["tcp"]), _b(s["left"]),
                                                _b(s["right"]), _b(target), _b(obj_init), _b(s["init_tcp"]))
        ok = disassemble_task.disassemble_success(_b(ring), _b(target))
        expected = ref_disassemble(s.mtb("left"), s.mtb("right"), s.mtb("init_tcp"), s["action"][3], to_mtb(target),
                                   to_mtb(handle), to_mtb(ring), to_mtb(obj_init))
        _check(r, ok, expected)
        seen.add(bool(ok))
    assert seen == {True, False}


def test_disassemble_known_answers() -> None:
    target = np.array([0.05, 0.7, 0.175])
    for dz, ok in ((-0.049, True), (-0.051, False), (0.049, True), (0.051, False)):
        assert bool(disassemble_task.disassemble_success(_b(target + [0, 0, dz]), _b(target))) is ok
    # ring 10 cm above the target (MTBench's in-place point): in_place = 0.1 + 0.9
    ring = target + [0.0, 0.0, 0.1]
    r = disassemble_task.disassemble_reward(_b([0, 0, 0, -1.0]), _b(ring + [0.13, 0, 0]), _b(ring), _b([0, 0.4, 0.2]),
                                            _b([0, 0.445, 0.2]), _b([0, 0.355, 0.2]), _b(target),
                                            _b(target + [0.13, 0, -0.15]), _b([0, 0.4, 0.2]))
    assert 6.0 <= float(r) < 6.2  # 6·1 plus a small caging term (the hand is far)


# ------------------------------------------------------------------------------------------------ stick tasks
def _stick_states(rng, n, stick_init_fn, goal_fn, handle_fn):
    out = []
    for i in range(n):
        stick_init, goal = stick_init_fn(), goal_fn()
        handle_init = handle_fn(stick_init, goal)
        mode = i % 4
        stick = (stick_init, stick_init + [0, 0, 0.05], handle_init + [-0.09, 0, 0] + rng.normal(0, 0.01, 3),
                 stick_init + rng.normal(0, 0.1, 3))[mode]
        handle = handle_init + (rng.normal(0, [0.05, 0.05, 0.0]) if mode >= 2 else 0.0)
        if mode == 2 and i % 8 == 2:  # dragged close to the goal
            handle = goal + rng.normal(0, [0.05, 0.05, 0.0])
            stick = handle + [-0.09, rng.normal(0, 0.01), rng.normal(0, 0.01)]
        end = stick + [_stick.STICK_HALF_LENGTH, 0.0, 0.0]
        s = State.make(rng, obj_init=handle_init, obj=stick, goal=goal, near=mode != 3 and i % 5 != 0,
                       stick=stick, stick_init=stick_init, handle=handle, end=end)
        if mode in (1, 2):  # holding the stick: TCP within 1 cm of it
            s["tcp"] = stick + rng.normal(0, 0.005, 3)
            s["left"], s["right"] = s["tcp"] + [0, 0.021, 0], s["tcp"] - [0, 0.021, 0]
        out.append(s)
    return out


def test_stick_pull_matches_mtbench() -> None:
    rng = np.random.default_rng(8)
    init = lambda: np.array([rng.uniform(-0.1, 0.0), rng.uniform(0.65, 0.75), 0.02])  # noqa: E731
    goal = lambda: np.array([rng.uniform(0.35, 0.45), rng.uniform(0.5, 0.55), 0.11])  # noqa: E731
    handle0 = lambda stick, goal: stick + [0.3, -0.09, 0.09]  # noqa: E731  # thermos + (0, -0.09, 0.11)
    branches = set()
    for s in _stick_states(rng, 96, init, goal, handle0):
        args = [s[k] for k in ("stick", "end", "handle")]
        r = pull_task.stick_pull_reward(_b(s["action"]), *map(_b, args), _t([s.opened]), _b(s["tcp"]), _b(s["left"]),
                                        _b(s["right"]), _b(s["goal"]), _b(s["obj_init"]), _b(s["stick_init"]),
                                        _b(s["init_tcp"]))
        ok = pull_task.stick_pull_success(*map(_b, args), _t([s.opened]), _b(s["tcp"]), _b(s["stick_init"]),
                                          _b(s["goal"]))
        expected = ref_stick_pull(s.mtb("left"), s.mtb("right"), s.mtb("init_tcp"), s["action"][3], s.mtb("goal"),
                                  s.mtb("stick"), s.mtb("stick_init"), s.mtb("handle"), s.mtb("obj_init"),
                                  s.mtb("end"))
        _check(r, ok, expected)
        grasp = bool(push_task.stick_grasped(_b(s["stick"]), _t([s.opened]), _b(s["tcp"]), _b(s["stick_init"])))
        branches.add((grasp, bool(pull_task.stick_inserted(_b(s["handle"]), _b(s["end"]))), bool(ok)))
    assert {(False, False, False), (True, False, False), (True, True, False), (True, True, True)} <= branches


def test_stick_pull_insertion_rule() -> None:
    handle = np.array([0.4, 0.56, 0.11])
    cases = (([0.0, 0, 0], True), ([-0.001, 0, 0], False), ([0.05, 0.0399, 0.0199], True), ([0.05, 0.041, 0], False),
             ([0.05, 0, -0.021], False))
    for offset, ok in cases:
        assert bool(pull_task.stick_inserted(_b(handle), _b(handle + offset))) is ok


def test_stick_push_matches_mtbench() -> None:
    rng = np.random.default_rng(9)
    init = lambda: np.array([rng.uniform(-0.08, -0.03), rng.uniform(0.58, 0.62), 0.02])  # noqa: E731
    goal = lambda: np.array([0.4, rng.uniform(0.55, 0.6), 0.132])  # noqa: E731
    thermos0 = lambda stick, goal: np.array([0.2, goal[1], 0.0])  # noqa: E731
    seen = set()
    for i, s in enumerate(_stick_states(rng, 96, init, goal, thermos0)):
        container = s["obj_init"] + [0.0, 0.0, 0.132] + ([rng.uniform(0.0, 0.2), rng.normal(0, 0.02), 0.0]
                                                          if i % 2 else 0.0)
        args = (_b(s["stick"]), _b(container), _t([s.opened]), _b(s["tcp"]))
        r = push_task.stick_push_reward(_b(s["action"]), *args, _b(s["left"]), _b(s["right"]), _b(s["goal"]),
                                        _b(s["obj_init"]), _b(s["stick_init"]), _b(s["init_tcp"]))
        ok = push_task.stick_push_success(*args, _b(s["stick_init"]), _b(s["goal"]))
        expected = ref_stick_push(s.mtb("left"), s.mtb("right"), s.mtb("init_tcp"), s["action"][3], s.mtb("goal"),
                                  s.mtb("stick"), s.mtb("stick_init"), to_mtb(container)[:2], s.mtb("obj_init"))
        _check(r, ok, expected)
        seen.add(bool(ok))
    assert seen == {True, False}


def test_stick_push_success_needs_the_grasp() -> None:
    goal, stick_init = np.array([0.4, 0.58, 0.132]), np.array([-0.05, 0.6, 0.02])
    stick = np.array([0.2, 0.58, 0.1])
    held = (_b(stick), _t([0.4]), _b(stick + [0.029, 0, 0]))
    for dx, ok in ((-0.099, True), (-0.101, False)):
        container = _b(goal + [dx, 0.0, 0.0])
        assert bool(push_task.stick_push_success(held[0], container, *held[1:], _b(stick_init), _b(goal))) is ok
    container = _b(goal)
    assert not bool(push_task.stick_push_success(_b(stick), container, _t([0.4]), _b(stick + [0.031, 0, 0]),
                                                 _b(stick_init), _b(goal)))  # hand 3.1 cm away
    assert not bool(push_task.stick_push_success(_b(stick_init + [0, 0, 0.009]), container, _t([0.4]),
                                                 _b(stick_init + [0, 0, 0.009]), _b(stick_init), _b(goal)))


# ------------------------------------------------------------------------------------------------ scenes (C)
def _data(name: str) -> tuple[mujoco.MjModel, mujoco.MjData]:
    _, model = compiled_task(name)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    return model, data


def _free_qpos(model: mujoco.MjModel, body: str) -> int:
    return int(model.jnt_qposadr[model.body_jntadr[model.body(body).id]])


def _settle(model, data, steps: int = 150) -> None:
    for _ in range(steps):
        mujoco.mj_step(model, data)


def test_nut_scene_offsets() -> None:
    model, data = _data("assembly")
    ring, handle = data.site("RoundNut").xpos, data.site("RoundNut-8").xpos
    np.testing.assert_allclose(handle - ring, [_nut.HANDLE_OFFSET, 0.0, 0.0], atol=1e-6)
    np.testing.assert_allclose(model.body("RoundNut").quat, _nut.NUT_QUAT, atol=1e-9)
    capsules = [g for g in range(model.ngeom) if model.geom_bodyid[g] == model.body("asmbly_peg").id
                and model.geom_type[g] == mujoco.mjtGeom.mjGEOM_CAPSULE]
    radii = {round(float(model.geom_size[g][0]), 4) for g in capsules}
    ring_radius = min(np.linalg.norm(model.geom_pos[g][:2]) for g in capsules)
    peg = next(g for g in range(model.ngeom) if model.geom_bodyid[g] == model.body("peg").id)
    assert radii == {_nut.RING_RADIUS}
    assert model.geom_size[peg][1] == pytest.approx(_nut.PEG_HALF_HEIGHT)
    assert ring_radius - _nut.RING_RADIUS - model.geom_size[peg][0] == pytest.approx(0.009, abs=1e-3)
    # a nut placed flat on the table (ring centre at 0.02) settles with the ring centre at 1.9 cm
    nut = _free_qpos(model, "RoundNut")
    data.qpos[nut:nut + 7] = [0.0, 0.6, 0.02, *_nut.NUT_QUAT]
    _settle(model, data)
    assert data.site("RoundNut").xpos[2] == pytest.approx(_nut.RING_RADIUS, abs=1.5e-3)


def test_box_scene_lid_point_and_rest_heights() -> None:
    model, data = _data("box_close")
    top = data.body("top_link").xpos
    np.testing.assert_allclose(data.site("lid_point").xpos - top, [0.0, 0.0, box_task.LID_POINT], atol=1e-9)
    bar = next(g for g in range(model.ngeom) if model.geom_bodyid[g] == model.body("top_link").id
               and model.geom_type[g] == mujoco.mjtGeom.mjGEOM_CAPSULE and model.geom_contype[g]
               and abs(model.geom_pos[g][2] - 0.082) < 1e-6)
    assert data.geom_xpos[bar][2] - top[2] == pytest.approx(0.082)
    lid = _free_qpos(model, "boxbodytop")
    for pos, rest in (([0.0, 0.47, box_task.TOP_LINK_REST_Z], box_task.TOP_LINK_REST_Z), ([0.0, 0.8, 0.07], 0.06)):
        data.qpos[lid:lid + 7] = [pos[0], pos[1], pos[2] - box_task.TOP_LINK_FROM_BODY, *box_task.LID_QUAT]
        data.qvel[:] = 0.0
        _settle(model, data)
        assert data.body("top_link").xpos[2] == pytest.approx(rest, abs=2e-3)  # on the table / closed on the box


def test_stick_scene_is_mtbench_length() -> None:
    model, data = _data("stick_pull")
    stick = data.body("stick").xpos
    np.testing.assert_allclose(data.site("stick_end").xpos - stick, [_stick.STICK_HALF_LENGTH, 0, 0], atol=1e-9)
    box = model.geom("objGeom")
    np.testing.assert_allclose(box.size, [_stick.STICK_HALF_LENGTH, _stick.STICK_HALF, _stick.STICK_HALF])
    thermos = data.body("object").xpos
    np.testing.assert_allclose(data.site("insertion").xpos - thermos, _stick.INSERTION, atol=1e-9)
    for joint in ("obj_slidex", "obj_slidey"):
        np.testing.assert_allclose(model.joint(joint).range, [-0.2, 0.2])
    # the handle's opening: between the body (radius 6 cm) and the bar's inner face (13 cm out), above the lower
    # arm (top at 6.9 + 0.5 cm): a 4 cm stick fits around MTBench's handle point (y -0.09, z 0.11)
    child = next(b for b in range(model.nbody) if model.body_parentid[b] == model.body("object").id)
    boxes = [g for g in range(model.ngeom) if model.geom_bodyid[g] == child and model.geom_type[g] == 6]
    bar = next(g for g in boxes if model.geom_size[g][2] > 0.05)
    lower = min((g for g in boxes if g != bar), key=lambda g: model.geom_pos[g][2])
    assert model.geom_pos[bar][1] + model.geom_size[bar][1] == pytest.approx(-0.13)
    assert model.geom_pos[lower][2] + model.geom_size[lower][2] == pytest.approx(0.074)
    assert -0.13 + _stick.STICK_HALF < -0.09 < -0.06 - _stick.STICK_HALF
    assert 0.074 + _stick.STICK_HALF < pull_task.HANDLE_Z


def test_sweep_into_goal_table_is_metaworlds() -> None:
    model, data = _data("sweep_into_goal")
    reference = mujoco.MjModel.from_xml_path(str(metaworld_assets_dir() / "sawyer_xyz" / "sawyer_table_with_hole.xml"))

    def raised_boxes(m: mujoco.MjModel) -> list[tuple[float, ...]]:
        table = m.body("tablelink").id
        return sorted(tuple(np.round(np.r_[m.geom_pos[g], m.geom_size[g]], 6)) for g in range(m.ngeom)
                      if m.geom_bodyid[g] == table and m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX
                      and m.geom_conaffinity[g] and m.geom_pos[g][2] == 0.0)

    assert raised_boxes(model) == raised_boxes(reference) and len(raised_boxes(model)) == 4
    # the block rests on the raised surface (centre 7 cm up) and, in the hole, on its floor (centre 2 cm up)
    obj = _free_qpos(model, "obj")
    for xy, rest in (((0.0, 0.65), into_task.SURFACE_Z + into_task.BLOCK_HALF), ((0.0, 0.84), into_task.BLOCK_HALF)):
        data.qpos[obj:obj + 7] = [xy[0], xy[1], rest - into_task.BLOCK_HALF + 0.005, 1, 0, 0, 0]
        data.qvel[:] = 0.0
        _settle(model, data)
        assert data.site("obj").xpos[2] == pytest.approx(rest, abs=2e-3)


def test_basketball_and_soccer_targets() -> None:
    model, data = _data("basketball")
    np.testing.assert_allclose(data.site("goal").xpos - data.body("basket_goal").xpos,
                               basketball_task.HOOP_FROM_BASE, atol=1e-9)
    ring = [g for g in range(model.ngeom) if model.geom_bodyid[g] == model.body("hooplink").id
            and model.geom_type[g] == mujoco.mjtGeom.mjGEOM_CAPSULE]
    inner = min(np.linalg.norm(model.geom_pos[g][:2]) for g in ring) - max(model.geom_size[g][0] for g in ring)
    assert inner > basketball_task.BALL_RADIUS  # the ball fits through the ring
    model, data = _data("soccer")
    goal = model.body("soccer_goal").id
    front = min(_mesh_world_vertices(model, data, g)[:, 1].min() for g in range(model.ngeom)
                if model.geom_bodyid[g] == goal and model.geom_contype[g])
    mouth_from_frame = front - data.body("goal_whole").xpos[1]
    assert mouth_from_frame == pytest.approx(-0.064, abs=2e-3)
    assert soccer_task.TARGET_FROM_GOAL[1] < mouth_from_frame  # MTBench's target lies in front of the mouth


def _mesh_world_vertices(model: mujoco.MjModel, data: mujoco.MjData, geom: int) -> np.ndarray:
    mesh = model.geom_dataid[geom]
    verts = model.mesh_vert[model.mesh_vertadr[mesh]:model.mesh_vertadr[mesh] + model.mesh_vertnum[mesh]]
    return verts @ data.geom_xmat[geom].reshape(3, 3).T + data.geom_xpos[geom]


@pytest.mark.parametrize("point", [(0.42, 0.5, 0.11), (0.3, 0.6, 0.1), (0.41, 0.7, 0.03), (-0.1, 0.817, 0.335),
                                   (0.1, 0.85, 0.235), (0.12, 0.7, 0.06), (-0.165, 0.75, 0.03)])
def test_hand_reaches_the_task_workspace(point) -> None:
    """The TCP follows the mocap to the extreme points the group-d policies use (stick tasks' pull and shove, sweep's
    goal, basketball's drop point, box_close's carry height over the far box, the bins)."""
    model, data = _data("sweep")
    block = _free_qpos(model, "obj")
    data.qpos[block:block + 3] = [-0.5, 0.9, 0.0]  # out of the way
    start = data.mocap_pos[0].copy()
    goal = np.asarray(point) + [0.0, 0.0, 0.1034]
    for i in range(250):
        data.mocap_pos[0] = start + (goal - start) * min(1.0, i / 150)
        mujoco.mj_step(model, data)
    tcp = 0.5 * (data.site("panda/leftpad").xpos + data.site("panda/rightpad").xpos)
    assert np.linalg.norm(tcp - point) < 0.01
