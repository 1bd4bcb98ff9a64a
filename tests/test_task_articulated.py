"""Known-answer tests of the articulated-fixture tasks (drawer_open, drawer_close, window_open, window_close).

No env is built. The rewards are compared with Meta-World's own ``compute_reward`` methods, compiled from the
installed metaworld source files and called on a stand-in ``self`` (numpy, float64); success rules and the
geometric offsets the tasks use are checked against the Meta-World XMLs (plain MuJoCo on the CPU) and against
hand-set states.
"""

from __future__ import annotations

import __future__
import ast
import importlib.util
import types
from functools import lru_cache
from pathlib import Path
from typing import Any, Callable

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
def _compile_method(path: Path, class_name: str, func_name: str, namespace: dict[str, Any]) -> Callable[..., Any]:
    tree = ast.parse(path.read_text(), filename=str(path))
    cls = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == class_name)
    func = next(n for n in cls.body if isinstance(n, ast.FunctionDef) and n.name == func_name)
    func.decorator_list = []
    code = compile(ast.Module(body=[func], type_ignores=[]), str(path), "exec",
                   flags=__future__.annotations.compiler_flag, dont_inherit=True)
    exec(code, namespace)
    return namespace[func_name]


def _class_constant(path: Path, class_name: str, attr: str) -> Any:
    tree = ast.parse(path.read_text(), filename=str(path))
    cls = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == class_name)
    for node in cls.body:
        if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name) and node.target.id == attr:
            return ast.literal_eval(node.value)
        if isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == attr for t in node.targets):
            return ast.literal_eval(node.value)
    raise KeyError(attr)


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
    import numpy.typing as npt

    ns = {"np": np, "npt": npt, "Any": Any, "reward_utils": ru}
    envs = root / "envs"
    return types.SimpleNamespace(
        drawer_open=_compile_method(envs / "sawyer_drawer_open_v3.py", "SawyerDrawerOpenEnvV3", "compute_reward",
                                    dict(ns)),
        drawer_close=_compile_method(envs / "sawyer_drawer_close_v3.py", "SawyerDrawerCloseEnvV3",
                                     "compute_reward", dict(ns)),
        window_open=_compile_method(envs / "sawyer_window_open_v3.py", "SawyerWindowOpenEnvV3", "compute_reward",
                                    dict(ns)),
        window_close=_compile_method(envs / "sawyer_window_close_v3.py", "SawyerWindowCloseEnvV3",
                                     "compute_reward", dict(ns)),
        base_target_radius=_class_constant(root / "sawyer_xyz_env.py", "SawyerXYZEnv", "TARGET_RADIUS"),
        window_target_radius=_class_constant(envs / "sawyer_window_open_v3.py", "SawyerWindowOpenEnvV3",
                                             "TARGET_RADIUS"),
    )


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


def _drawer_open_goal(cabinet: np.ndarray) -> np.ndarray:
    return cabinet + np.array(open_task.GOAL_OFFSET)


def test_drawer_open_maximum_and_success() -> None:
    goal = _t(_drawer_open_goal(CABINET))[None]
    init_tcp = _t([[0.0, 0.6, 0.2]])
    dense, caging, opening = drawer_open_reward(goal, goal, goal, init_tcp)  # tcp at the handle, handle at goal
    torch.testing.assert_close(dense, _t([2.0]))
    # the env's non-success reward at the maximum equals Meta-World's maximum dense reward (10)
    assert float(dense * DrawerOpen.dense_scale * 100.0) == pytest.approx(10.0)
    # success: handle within 3.5 cm of the fully open handle point (slide at -0.16)
    handle_closed = CABINET + np.array([0.0, -0.17, 0.09])
    slides = np.array([0.0, -0.05, -0.12, -0.126, -0.16, -0.19])
    handles = _t(handle_closed[None] + np.outer(slides, [0.0, 1.0, 0.0]))
    success = drawer_open_success(handles, goal.expand(len(slides), 3))
    assert success.tolist() == [False, False, False, True, True, True]
    # far away: small reward
    far, _, _ = drawer_open_reward(init_tcp, _t(handle_closed)[None], goal, init_tcp)
    assert 0.15 < float(far) < 0.3  # both terms near their value at the margin (0.1)


def test_drawer_open_reward_matches_metaworld(ref) -> None:
    rng = np.random.default_rng(0)
    goal = _drawer_open_goal(CABINET)
    init_tcp = np.array([0.01, 0.6, 0.2])
    for _ in range(20):
        tcp = rng.uniform([-0.2, 0.4, 0.05], [0.2, 0.8, 0.3])
        handle = CABINET + np.array([0.0, -0.17 + rng.uniform(-0.17, 0.0), 0.09])
        me = types.SimpleNamespace(_target_pos=goal, reward_function_version="v2", maxDist=0.2, init_tcp=init_tcp)
        expected = ref.drawer_open(me, np.zeros(4), _obs(tcp, handle))
        dense, caging, opening = drawer_open_reward(_t(tcp)[None], _t(handle)[None], _t(goal)[None],
                                                    _t(init_tcp)[None])
        assert float(dense) * 5.0 == pytest.approx(expected[0], abs=1e-9)
        assert float(caging) == pytest.approx(expected[4], abs=1e-9)
        assert float(opening) == pytest.approx(expected[5], abs=1e-9)


# --------------------------------------------------------------------------------------------------------------
# drawer_close
# --------------------------------------------------------------------------------------------------------------
def test_drawer_close_radius_is_metaworlds(ref) -> None:
    # compute_reward reads self.TARGET_RADIUS (the base class's), not the class's unused _TARGET_RADIUS
    assert close_task.TARGET_RADIUS == ref.base_target_radius


def test_drawer_close_known_answers() -> None:
    goal = _t(CABINET + np.array(close_task.GOAL_OFFSET))[None]
    handle_closed = CABINET + np.array([0.0, -0.17, 0.14])
    slides = np.array([-0.15, -0.06, -0.054, 0.0])
    handles = _t(handle_closed[None] + np.outer(slides, [0.0, 1.0, 0.0]))
    assert drawer_close_success(handles, goal.expand(4, 3)).tolist() == [False, False, True, True]
    # tcp at the handle, gripper closed, handle inside the target radius: maximal reward (no success override)
    handle = goal + _t([[0.0, 0.0, 0.04]])
    dense, reach, in_place = drawer_close_reward(handle, handle, goal, _t(handle_closed)[None] + _t([[0, -0.15, 0]]),
                                                 _t([[0.0, 0.6, 0.2]]), _t([1.0]))
    torch.testing.assert_close(dense, _t([10.0]))
    # gripper open: Meta-World's reach term needs a closing action, so the reward is 0
    dense_open, _, _ = drawer_close_reward(handle, handle, goal, handle, _t([[0.0, 0.6, 0.2]]), _t([-1.0]))
    torch.testing.assert_close(dense_open, _t([0.0]))


def test_drawer_close_reward_matches_metaworld(ref) -> None:
    rng = np.random.default_rng(1)
    goal = CABINET + np.array(close_task.GOAL_OFFSET)
    handle_init = CABINET + np.array([0.0, -0.17 - 0.15, 0.14])
    init_tcp = np.array([0.0, 0.6, 0.2])
    checked = 0
    for _ in range(40):
        handle = CABINET + np.array([0.0, -0.17 + rng.uniform(-0.16, 0.0), 0.14])
        tcp = handle + rng.normal(0.0, 0.03, 3)
        grip = rng.uniform(-1.0, 1.0)
        me = types.SimpleNamespace(_target_pos=goal, hand_init_pos=init_tcp, reward_function_version="v2",
                                   tcp_center=tcp, obj_init_pos=handle_init, init_tcp=init_tcp,
                                   TARGET_RADIUS=ref.base_target_radius)
        expected = ref.drawer_close(me, np.array([0.0, 0.0, 0.0, grip]), _obs(tcp, handle))
        dense, reach, in_place = drawer_close_reward(_t(tcp)[None], _t(handle)[None], _t(goal)[None],
                                                     _t(handle_init)[None], _t(init_tcp)[None], _t([grip]))
        assert float(reach) == pytest.approx(expected[4], abs=1e-9)
        assert float(in_place) == pytest.approx(expected[5], abs=1e-9)
        if expected[3] > ref.base_target_radius + 0.015:  # Meta-World's success override does not apply
            assert float(dense) == pytest.approx(expected[0], abs=1e-9)
            checked += 1
    assert checked >= 10


# --------------------------------------------------------------------------------------------------------------
# window_open / window_close
# --------------------------------------------------------------------------------------------------------------
WINDOW = np.array([-0.05, 0.8, 0.16])


def test_window_success_known_answers() -> None:
    handle_init = _t(WINDOW + np.array([-0.04, -0.095, 0.0]))[None]  # handleOpenStart, slide 0
    slides = np.array([0.0, 0.185, 0.191, 0.2, 0.209])
    handles = handle_init + _t(np.outer(slides, [1.0, 0.0, 0.0]))
    assert window_success(handles, handle_init.expand(5, 3), +1.0).tolist() == [False, False, True, True, True]
    # closing: from the open handle back to slide 0
    handle_open = _t(WINDOW + np.array([0.01 + 0.2, -0.095, 0.0]))[None]  # handleCloseStart, slide 0.2
    slides = np.array([0.2, 0.05, 0.011, 0.005, 0.0])
    handles = handle_open + _t(np.outer(slides - 0.2, [1.0, 0.0, 0.0]))
    assert window_success(handles, handle_open.expand(5, 3), -1.0).tolist() == [False, False, False, True, True]
    # a handle displaced sideways (3-D rule) is not a success
    assert not bool(window_success(handle_init + _t([[0.2, 0.02, 0.0]]), handle_init, +1.0))


def test_window_reward_maximum() -> None:
    goal = _t(WINDOW + np.array([0.2, 0.0, 0.0]))[None]
    handle = _t(WINDOW + np.array([0.16, -0.095, 0.0]))[None]  # open handle: 4 cm from the goal in x
    dense, reach, in_place = window_reward(handle, handle, goal, handle - _t([[0.2, 0, 0]]), _t([[0, 0.4, 0.2]]),
                                           0.2, "long_tail")
    torch.testing.assert_close(dense, _t([10.0]))
    far, _, _ = window_reward(_t([[0, 0.4, 0.2]]), handle - _t([[0.2, 0, 0]]), goal, handle - _t([[0.2, 0, 0]]),
                              _t([[0, 0.4, 0.2]]), 0.2, "long_tail")
    assert float(far) < 0.5


@pytest.mark.parametrize("task", ["window_open", "window_close"])
def test_window_reward_matches_metaworld(ref, task: str) -> None:
    rng = np.random.default_rng(2)
    assert _window.TARGET_RADIUS == ref.window_target_radius
    init_tcp = np.array([0.0, 0.4, 0.2])
    for _ in range(20):
        window = rng.uniform([-0.1, 0.7, 0.16], [0.1, 0.9, 0.2])
        if task == "window_open":
            goal, site, slide0 = window + np.array([0.2, 0.0, 0.0]), np.array([-0.04, -0.095, 0.0]), 0.0
        else:
            goal, site, slide0 = window.copy(), np.array([0.01, -0.095, 0.0]), 0.2
        handle_init = window + site + np.array([slide0, 0.0, 0.0])
        handle = window + site + np.array([rng.uniform(0.0, 0.2), 0.0, 0.0])
        tcp = handle + rng.normal(0.0, 0.05, 3)
        me = types.SimpleNamespace(_target_pos=goal, obj_init_pos=window, tcp_center=tcp, init_tcp=init_tcp,
                                   reward_function_version="v2", TARGET_RADIUS=ref.window_target_radius,
                                   _get_pos_objects=lambda h=handle: h)
        if task == "window_open":
            me.window_handle_pos_init = handle_init
            expected = ref.window_open(me, np.zeros(4), _obs(tcp, handle))
            x_error_init, sigmoid = abs(window[0] - goal[0]), "long_tail"
        else:
            # Meta-World: window_handle_pos_init = (site before the kinematics update, slide 0) + (0.2, 0, 0)
            me.window_handle_pos_init = handle_init
            expected = ref.window_close(me, np.zeros(4), _obs(tcp, handle))
            x_error_init, sigmoid = abs(handle_init[0] - goal[0]), "gaussian"
        dense, reach, in_place = window_reward(_t(tcp)[None], _t(handle)[None], _t(goal)[None],
                                               _t(handle_init)[None], _t(init_tcp)[None], _t([x_error_init]),
                                               sigmoid)
        assert float(dense) == pytest.approx(expected[0], abs=1e-9)
        assert float(reach) == pytest.approx(expected[4], abs=1e-9)
        assert float(in_place) == pytest.approx(expected[5], abs=1e-9)


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
    # drawer_open: the success target is the fully open handle point; Meta-World's handle_pos_init is the closed one
    np.testing.assert_allclose(handle_open[-0.16][0], open_goal + open_task.SUCCESS_FROM_GOAL, atol=1e-9)
    np.testing.assert_allclose(handle_open[0.0][0][:2], (open_goal + (0, open_task.MAX_DIST, 0))[:2] -
                               (0, 0.01), atol=1e-9)
    # drawer_close: the success target is the closed handle point
    np.testing.assert_allclose(handle_open[0.0][1], close_goal + close_task.SUCCESS_FROM_GOAL, atol=1e-9)


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
