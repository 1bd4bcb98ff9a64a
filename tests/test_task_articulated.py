"""Known-answer tests of the articulated-fixture tasks (drawer_open, drawer_close, window_open, window_close).

No env is built. The rewards are checked against the paper-era MTBench formulas (``task_fns/*.py`` of
Viraj-Joshi/MTBench ed2e2b5), recomputed per state in float64 NumPy with Meta-World's own ``tolerance`` and
``hamacher_product`` (compiled from the installed metaworld source); success rules and the geometric offsets the
tasks use are checked against the Meta-World XMLs (plain MuJoCo on the CPU) and against hand-set states.
"""

from __future__ import annotations

import importlib.util
import types
from functools import lru_cache
from pathlib import Path

import mujoco
import numpy as np
import pytest
import torch

from mtbench.envs.metaworld.tasks import _drawer, _window
from mtbench.envs.metaworld.tasks import drawer_close as close_task
from mtbench.envs.metaworld.tasks import drawer_open as open_task
from mtbench.envs.metaworld.tasks.drawer_close import drawer_close_reward, drawer_close_success
from mtbench.envs.metaworld.tasks.drawer_open import drawer_open_reward, drawer_open_success
from mtbench.envs.metaworld.tasks._window import window_reward, window_success
from mtbench.envs.metaworld.tasks.drawer_open import DrawerOpen
from mtbench.envs.metaworld.tasks.window_close import WindowClose
from mtbench.envs.metaworld.tasks.window_open import WindowOpen

T = torch.float64


def _t(x) -> torch.Tensor:
    return torch.as_tensor(np.asarray(x, dtype=np.float64), dtype=T)


# --------------------------------------------------------------------------------------------------------------
# Meta-World reference (compiled from the installed source files; skipped when metaworld is not installed)
# --------------------------------------------------------------------------------------------------------------
@lru_cache(maxsize=1)
def _reference() -> types.SimpleNamespace | str:
    spec = importlib.util.find_spec("metaworld")
    if spec is None or not spec.submodule_search_locations:
        return "metaworld is not installed"
    root = Path(next(iter(spec.submodule_search_locations)))
    ru_spec = importlib.util.spec_from_file_location("_mtbench_ref_mw_reward_utils_artic", root / "utils" /
                                                     "reward_utils.py")
    ru = importlib.util.module_from_spec(ru_spec)
    ru_spec.loader.exec_module(ru)
    return types.SimpleNamespace(tolerance=ru.tolerance, hamacher=ru.hamacher_product)


@pytest.fixture(scope="module")
def ref() -> types.SimpleNamespace:
    r = _reference()
    if isinstance(r, str):
        pytest.skip(r)
    return r


def _obs(hand: np.ndarray, obj: np.ndarray) -> np.ndarray:
    obs = np.zeros(39)
    obs[:3], obs[4:7] = hand, obj
    return obs


# --------------------------------------------------------------------------------------------------------------
# drawer_open
# --------------------------------------------------------------------------------------------------------------
CABINET = np.array([0.05, 0.9, 0.0])
HANDLE_CLOSED = CABINET + np.array([0.0, -0.17, 0.09])  # drawer_open's observed handle point, slide 0


def test_drawer_open_maximum_and_success() -> None:
    goal = _t(CABINET + np.array(open_task.GOAL_OFFSET))[None]
    torch.testing.assert_close(goal, _t(HANDLE_CLOSED + [0.0, -0.16, 0.0])[None])  # the fully open handle point
    init_tcp = _t([[0.0, 0.6, 0.2]])
    dense, caging, opening = drawer_open_reward(goal, goal, goal, init_tcp)  # tcp at the handle, handle at goal
    torch.testing.assert_close(dense, _t([2.0]))
    # the env's non-success reward at the maximum: 2 * 0.05 * reward_scale 100 = 10
    assert float(dense * DrawerOpen.dense_scale * 100.0) == pytest.approx(10.0)
    # success: handle within 3.5 cm of the fully open handle point
    slides = np.array([0.0, -0.05, -0.12, -0.126, -0.16, -0.19])
    handles = _t(HANDLE_CLOSED[None] + np.outer(slides, [0.0, 1.0, 0.0]))
    success = drawer_open_success(handles, goal.expand(len(slides), 3))
    assert success.tolist() == [False, False, False, True, True, True]
    far, _, _ = drawer_open_reward(init_tcp, _t(HANDLE_CLOSED)[None], goal, init_tcp)
    assert 0.25 < float(far) < 0.4  # both terms near their margin value (0.1 each) or a little above


def test_drawer_open_reward_matches_mtbench(ref) -> None:
    """MTBench: opening = tol(‖handle − target‖, (0, .02), margin .2); caging = tol(‖handle − tcp‖, (0, .01),
    margin ‖(target + .2 pull axis) − tcp_init‖), scale (1, 1, 1); r = caging + opening."""
    rng = np.random.default_rng(0)
    goal = CABINET + np.array(open_task.GOAL_OFFSET)
    init_tcp = np.array([0.01, 0.6, 0.2])
    for _ in range(20):
        tcp = rng.uniform([-0.2, 0.4, 0.05], [0.2, 0.8, 0.3])
        handle = HANDLE_CLOSED + np.array([0.0, rng.uniform(-0.17, 0.0), 0.0])
        opening = ref.tolerance(np.linalg.norm(handle - goal), bounds=(0.0, 0.02), margin=0.2, sigmoid="long_tail")
        handle_init = goal + np.array([0.0, 0.2, 0.0])
        caging = ref.tolerance(np.linalg.norm(handle - tcp), bounds=(0.0, 0.01),
                               margin=np.linalg.norm(handle_init - init_tcp), sigmoid="long_tail")
        dense, ours_caging, ours_opening = drawer_open_reward(_t(tcp)[None], _t(handle)[None], _t(goal)[None],
                                                              _t(init_tcp)[None])
        assert float(dense) == pytest.approx(caging + opening, abs=1e-9)
        assert float(ours_caging) == pytest.approx(caging, abs=1e-9)
        assert float(ours_opening) == pytest.approx(opening, abs=1e-9)


# --------------------------------------------------------------------------------------------------------------
# drawer_close
# --------------------------------------------------------------------------------------------------------------
def test_drawer_close_known_answers() -> None:
    goal = _t(CABINET + np.array(close_task.GOAL_OFFSET))[None]
    handle_closed = CABINET + np.array([0.0, -0.17, 0.14])
    torch.testing.assert_close(goal, _t(handle_closed)[None])
    slides = np.array([-0.15, -0.06, -0.054, 0.0])
    handles = _t(handle_closed[None] + np.outer(slides, [0.0, 1.0, 0.0]))
    assert drawer_close_success(handles, goal.expand(4, 3)).tolist() == [False, False, True, True]
    # tcp at the handle, gripper closed, handle inside the 2.5 cm target radius: maximal reward 1
    handle = goal + _t([[0.0, 0.02, 0.0]])
    dense, reach, in_place = drawer_close_reward(handle, handle, goal, _t(handle_closed)[None] + _t([[0, -0.15, 0]]),
                                                 _t([[0.0, 0.6, 0.2]]), _t([1.0]))
    torch.testing.assert_close(dense, _t([1.0]))
    # 3 cm from the target (outside MTBench's 2.5 cm): in_place < 1
    _, _, in_place = drawer_close_reward(handle, goal + _t([[0.0, 0.03, 0.0]]), goal, handle, _t([[0.0, 0.6, 0.2]]),
                                         _t([1.0]))
    assert float(in_place) < 1.0
    # gripper open: the reach term needs a closing action, so the reward is 0
    dense_open, _, _ = drawer_close_reward(handle, handle, goal, handle, _t([[0.0, 0.6, 0.2]]), _t([-1.0]))
    torch.testing.assert_close(dense_open, _t([0.0]))


def test_drawer_close_reward_matches_mtbench(ref) -> None:
    """MTBench: in_place = tol(‖handle − target‖, (0, .025), margin |‖init − target‖ − .025|); reach = H(tol(
    ‖handle − tcp‖, (0, .005), margin |‖init − tcp_init‖ − .005|, gaussian), clip(a3, 0, 1)); r = H(reach, in_place)."""
    rng = np.random.default_rng(1)
    goal = CABINET + np.array(close_task.GOAL_OFFSET)
    handle_init = goal + np.array([0.0, -0.15, 0.0])
    init_tcp = np.array([0.0, 0.6, 0.2])
    for _ in range(40):
        handle = goal + np.array([0.0, rng.uniform(-0.16, 0.0), 0.0])
        tcp = handle + rng.normal(0.0, 0.01, 3)
        grip = rng.uniform(-1.0, 1.0)
        in_place = ref.tolerance(np.linalg.norm(handle - goal), bounds=(0.0, 0.025),
                                 margin=abs(np.linalg.norm(handle_init - goal) - 0.025), sigmoid="long_tail")
        reach = ref.tolerance(np.linalg.norm(handle - tcp), bounds=(0.0, 0.005),
                              margin=abs(np.linalg.norm(handle_init - init_tcp) - 0.005), sigmoid="gaussian")
        reach = ref.hamacher(reach, min(max(grip, 0.0), 1.0))
        dense, ours_reach, ours_in_place = drawer_close_reward(_t(tcp)[None], _t(handle)[None], _t(goal)[None],
                                                               _t(handle_init)[None], _t(init_tcp)[None], _t([grip]))
        assert float(ours_reach) == pytest.approx(reach, abs=1e-9)
        assert float(ours_in_place) == pytest.approx(in_place, abs=1e-9)
        assert float(dense) == pytest.approx(ref.hamacher(reach, in_place), abs=1e-9)


# --------------------------------------------------------------------------------------------------------------
# window_open / window_close
# --------------------------------------------------------------------------------------------------------------
WINDOW = np.array([-0.05, 0.8, 0.16])


def test_window_success_known_answers() -> None:
    handle_init = _t(WINDOW + np.array([-0.04, -0.095, 0.0]))[None]  # handleOpenStart, slide 0
    goal = handle_init + _t([[0.2, 0.0, 0.0]])  # MTBench's target: the handle at the end of the travel
    slides = np.array([0.0, 0.185, 0.191, 0.2, 0.209])
    handles = handle_init + _t(np.outer(slides, [1.0, 0.0, 0.0]))
    assert window_success(handles, goal.expand(5, 3)).tolist() == [False, False, True, True, True]
    # closing: from the open handle back to slide 0
    handle_open = _t(WINDOW + np.array([0.01 + 0.2, -0.095, 0.0]))[None]  # handleCloseStart, slide 0.2
    goal = handle_open - _t([[0.2, 0.0, 0.0]])
    slides = np.array([0.2, 0.05, 0.011, 0.005, 0.0])
    handles = handle_open + _t(np.outer(slides - 0.2, [1.0, 0.0, 0.0]))
    assert window_success(handles, goal.expand(5, 3)).tolist() == [False, False, False, True, True]
    # a handle displaced sideways (3-D rule) is not a success
    assert not bool(window_success(goal + _t([[0.0, 0.02, 0.0]]), goal))


def test_window_reward_maximum() -> None:
    handle_init = _t(WINDOW + np.array([-0.04, -0.095, 0.0]))[None]
    goal = handle_init + _t([[0.2, 0.0, 0.0]])
    dense, reach, in_place = window_reward(goal, goal, goal, handle_init, _t([[0, 0.4, 0.2]]))
    torch.testing.assert_close(dense, _t([1.0]))
    # at the start both terms sit at their margins (0.1 each): H(0.1, 0.1) = 0.01 / 0.19
    far, _, _ = window_reward(_t([[0, 0.4, 0.2]]), handle_init, goal, handle_init, _t([[0, 0.4, 0.2]]))
    assert float(far) == pytest.approx(0.01 / 0.19, abs=1e-12)


@pytest.mark.parametrize("direction", [1.0, -1.0])
def test_window_reward_matches_mtbench(ref, direction: float) -> None:
    """MTBench (both windows): in_place = tol(‖handle − target‖, (0, .01), margin |‖init − target‖ − .01|);
    reach = tol(‖handle − tcp‖, (0, .02), margin |‖init − tcp_init‖ − .02|, gaussian); r = H(reach, in_place)."""
    rng = np.random.default_rng(2)
    init_tcp = np.array([0.0, 0.4, 0.2])
    for _ in range(20):
        window = rng.uniform([-0.1, 0.7, 0.16], [0.1, 0.9, 0.2])
        handle_init = window + np.array([-0.04 if direction > 0 else 0.21, -0.095, 0.0])
        goal = handle_init + np.array([0.2 * direction, 0.0, 0.0])
        handle = handle_init + np.array([rng.uniform(0.0, 0.2) * direction, 0.0, 0.0])
        tcp = handle + rng.normal(0.0, 0.03, 3)
        in_place = ref.tolerance(np.linalg.norm(handle - goal), bounds=(0.0, 0.01),
                                 margin=abs(np.linalg.norm(handle_init - goal) - 0.01), sigmoid="long_tail")
        reach = ref.tolerance(np.linalg.norm(handle - tcp), bounds=(0.0, 0.02),
                              margin=abs(np.linalg.norm(handle_init - init_tcp) - 0.02), sigmoid="gaussian")
        dense, ours_reach, ours_in_place = window_reward(_t(tcp)[None], _t(handle)[None], _t(goal)[None],
                                                         _t(handle_init)[None], _t(init_tcp)[None])
        assert float(dense) == pytest.approx(ref.hamacher(reach, in_place), abs=1e-9)
        assert float(ours_reach) == pytest.approx(reach, abs=1e-9)
        assert float(ours_in_place) == pytest.approx(in_place, abs=1e-9)


# --------------------------------------------------------------------------------------------------------------
# geometry: the offsets the tasks use, measured on Meta-World's XMLs
# --------------------------------------------------------------------------------------------------------------
def _mw_model(xml: str) -> mujoco.MjModel:
    from mtbench.assets import metaworld_assets_dir

    return mujoco.MjModel.from_xml_path(str(metaworld_assets_dir() / "sawyer_xyz" / xml))


def test_drawer_geometry_matches_xml() -> None:
    m = _mw_model(DrawerOpen.scene.xml)
    d = mujoco.MjData(m)
    m.body("drawer").pos = CABINET
    adr = m.joint("goal_slidey").qposadr[0]
    assert tuple(m.jnt_range[m.joint("goal_slidey").id]) == (-_drawer.SLIDE_TRAVEL, 0.0)
    handle_open = {}
    for slide in (0.0, -0.16, -0.15):
        d.qpos[adr] = slide
        mujoco.mj_kinematics(m, d)
        link = d.body("drawer_link").xpos
        handle_open[slide] = (link + open_task.HANDLE_OFFSET, link + close_task.HANDLE_OFFSET)
    open_goal = CABINET + open_task.GOAL_OFFSET
    close_goal = CABINET + close_task.GOAL_OFFSET
    # drawer_open: the goal is the fully open handle point; drawer_close: the goal is the closed handle point
    np.testing.assert_allclose(handle_open[-0.16][0], open_goal, atol=1e-9)
    np.testing.assert_allclose(handle_open[0.0][1], close_goal, atol=1e-9)


def test_window_geometry_matches_xml() -> None:
    m = _mw_model(WindowOpen.scene.xml)
    d = mujoco.MjData(m)
    m.body("window").pos = WINDOW
    jid = m.joint("window_slide").id
    assert tuple(m.jnt_range[jid]) == (0.0, _window.SLIDE_TRAVEL)
    d.qpos[m.jnt_qposadr[jid]] = 0.0
    mujoco.mj_kinematics(m, d)
    np.testing.assert_allclose(d.site(WindowOpen.handle_site_name).xpos, WINDOW + (-0.04, -0.095, 0.0), atol=1e-9)
    np.testing.assert_allclose(d.site(WindowClose.handle_site_name).xpos, WINDOW + (0.01, -0.095, 0.0), atol=1e-9)
