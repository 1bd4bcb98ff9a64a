"""Bad inputs give ONE clear message naming the parameter and its valid range or choices (config, resume, env
construction, env.step / env.reset, the logs CLI); the logs CLI works as the docs write it."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path
from typing import Any, Callable

import pytest
import torch
from hydra import compose, initialize_config_dir

from envs_for_tests import SyntheticMTEnv
from mtbench.trainer.config import LOSSES
from mtbench.trainer import build_trainer

ROOT = Path(__file__).resolve().parents[1]
CONF = str(ROOT / "conf")
N = 2  # worlds of the physics env used below


def _cfg(tmp: Path, *overrides: str):
    base = ["device=cpu", "arch.kwargs.hidden=[16]", "loss.horizon=4", "loss.minibatch_size=48", "max_iterations=1",
            f"checkpoint.dir={tmp / 'ckpt'}", f"logging.log_dir={tmp / 'runs'}", "logging.progress=none"]
    with initialize_config_dir(config_dir=CONF, version_base="1.3"):
        return compose("config", overrides=[*base, *overrides])


def _build(tmp: Path, *overrides: str) -> None:
    build_trainer(_cfg(tmp, *overrides), env=SyntheticMTEnv([4, 4, 4]))


@pytest.fixture(scope="module")
def physics_env() -> Any:
    from mtbench.envs import make_env

    return make_env(["reach", "push"], num_envs=N, device="cpu", random_start_progress=False)


def _step(env: Any, action: torch.Tensor | None) -> None:
    td = env.reset()
    if action is not None:
        td["action"] = action
    env.step(td)


def _reset(env: Any, mask: torch.Tensor) -> None:
    td = env.reset()
    td["_reset"] = mask
    env.reset(td)


def _make_env(**kwargs: Any) -> None:
    from mtbench.envs import make_env

    make_env(["reach", "push"], **kwargs)


@pytest.fixture(scope="module")
def parkour_env() -> Any:
    from mtbench.envs import make_env

    return make_env(["flat", "balance_beam"], num_envs=N, device="cpu", num_rows=2, random_start_progress=False)


def _make_parkour_env(**kwargs: Any) -> None:
    from mtbench.envs import make_env

    make_env(["flat", "balance_beam"], **{"num_rows": 2, **kwargs})


def _logs_cli(*args: str) -> None:
    """``python -m mtbench.logs ARGS`` in a subprocess; raises ``ValueError(stderr)`` on a non-zero exit."""
    out = subprocess.run([sys.executable, "-m", "mtbench.logs", *args], capture_output=True, text=True, cwd=ROOT)
    if out.returncode:
        lines = [line for line in out.stderr.splitlines() if line.strip()]
        assert len(lines) == 1 and out.returncode == 2, out.stderr  # one message, no traceback
        raise ValueError(lines[0])


def _mcap_run(directory: Path) -> Path:
    from mtbench.logging import MCAPLogger

    logger = MCAPLogger("exp", directory, compression="none")
    for i in range(20):
        logger.log_metrics({"frames": 10.0 * i, "success/reach": 0.5, "loss/critic": 1.0}, step=i)
    logger.close()
    return directory / "exp.mcap"


def _corrupted_mcap(tmp: Path) -> str:
    data = bytearray(_mcap_run(tmp / "logs").read_bytes())
    pos = data.index(b'"name"', len(data) // 2)  # inside a JSON message in the middle of the file
    data[pos + 1] ^= 0xFF
    path = tmp / "corrupted.mcap"
    path.write_bytes(bytes(data))
    return str(path)


def _random_bytes(tmp: Path) -> str:
    path = tmp / "random.pt"
    path.write_bytes(torch.randint(0, 256, (4096,), generator=torch.Generator().manual_seed(0), dtype=torch.uint8)
                     .numpy().tobytes())
    return str(path)


# (id, action(tmp, env) -> None, exception type, message regex); {tmp} in the regex is the test's directory
CASES: list[tuple[str, Callable[[Path, Any], Any], type[Exception], str]] = [
    ("total_frames=0", lambda t, e: _build(t, "total_frames=0"), ValueError,
     r"^total_frames must be an integer >= 1 or null \(null: use max_iterations\); got 0$"),
    ("total_frames=-100", lambda t, e: _build(t, "total_frames=-100"), ValueError,
     r"^total_frames must be an integer >= 1 or null \(null: use max_iterations\); got -100$"),
    ("max_iterations=0", lambda t, e: _build(t, "max_iterations=0"), ValueError,
     r"^max_iterations must be an integer >= 1; got 0$"),
    ("max_iterations=-3", lambda t, e: _build(t, "max_iterations=-3"), ValueError,
     r"^max_iterations must be an integer >= 1; got -3$"),
    ("checkpoint.every=-1", lambda t, e: _build(t, "checkpoint.every=-1"), ValueError,
     r"^checkpoint\.every must be an integer >= 0 \(0: only the final checkpoint\); got -1$"),
    ("torch_threads=0", lambda t, e: _build(t, "torch_threads=0"), ValueError,
     r"^torch_threads must be an integer >= 1 or null \(null: torch's default\); got 0$"),
    ("matmul_precision=tf32", lambda t, e: _build(t, "matmul_precision=tf32"), ValueError,
     r"^unknown matmul_precision 'tf32'; valid choices: \['highest', 'high', 'medium'\]$"),
    ("seed=abc", lambda t, e: _build(t, "seed=abc"), ValueError, r"^seed must be an integer; got 'abc'$"),
    ("resume=<directory>", lambda t, e: _build(t, f"resume={t}"), ValueError,
     r"^resume={tmp} is a directory; give a checkpoint file written by mtbench \(e\.g\. {tmp}/checkpoints/last\.pt\)$"),
    ("resume=<random bytes>", lambda t, e: _build(t, f"resume={_random_bytes(t)}"), ValueError,
     r"^resume={tmp}/random\.pt: not an mtbench checkpoint \(the file does not start with the mtbench checkpoint "
     r"header\)$"),
    ("trainer device=tpu", lambda t, e: _build(t, "device=tpu"), ValueError,
     r"^device='tpu' is not supported; valid choices: 'auto', 'cpu', 'cuda' or 'cuda:<index>'$"),
    ("loss.lr_schedule=cosine", lambda t, e: _build(t, "loss.lr_schedule=cosine"), ValueError,
     r"^unknown loss\.lr_schedule 'cosine'; valid choices: \['fixed', 'adaptive'\]$"),
    ("loss.clip_actions=yes", lambda t, e: _build(t, "loss.clip_actions=yes"), ValueError,
     r"^loss\.clip_actions must be true or false; got 'yes'$"),
    ("loss=pqn loss.clip_actions=true", lambda t, e: _build(t, "loss=pqn", "+loss.clip_actions=true"), ValueError,
     r"^loss\.clip_actions=true applies to loss=ppo\|grpo \(Gaussian policies\); loss=pqn acts within its bounds "
     r"already \(sac: tanh-squashed, pqn: discrete bins\)$"),
    ("loss.name=dqn", lambda t, e: _build(t, "loss.name=dqn"), ValueError,
     r"^unknown loss\.name 'dqn'; valid choices: \[" + ", ".join(f"'{n}'" for n in LOSSES) + r"\]$"),
    ("loss.minibatch_size=20", lambda t, e: _build(t, "loss.minibatch_size=20"), ValueError,
     r"^loss\.minibatch_size=20 must divide the batch num_envs\*horizon = 12\*4 = 48 \(or be >= it: one minibatch\)$"),
    ("cudagraph_update=true on CPU", lambda t, e: _build(t, "cudagraph_update=true"), ValueError,
     r"^cudagraph_update=true needs a CUDA device \(device=cpu\); use auto or false$"),
    ("make_env num_envs=2.5", lambda t, e: _make_env(num_envs=2.5, device="cpu"), ValueError,
     r"^num_envs must be a positive integer \(split over the tasks\) or a list of one positive integer per task; "
     r"got 2\.5$"),
    ("make_env unknown override", lambda t, e: _make_env(num_envs=2, device="cpu", num_rows=2), ValueError,
     r"^unknown Meta-World env overrides \['num_rows'\]; valid: \[.*'reward_version'.*\]$"),
    ("make_env device=tpu", lambda t, e: _make_env(num_envs=2, device="tpu"), ValueError,
     r"^device='tpu' is not supported; valid choices: 'cpu', 'cuda', 'cuda:<index>'$"),
    ("action [N,3]", lambda t, e: _step(e, torch.zeros(N, 3)), ValueError,
     r"^env\.step needs tensordict\['action'\] of shape \[num_envs, 4\] = \[2, 4\] \(values in \[-1, 1\]\); "
     r"got shape \[2, 3\]$"),
    ("action [N]", lambda t, e: _step(e, torch.zeros(N)), ValueError, r"; got shape \[2\]$"),
    ("action [N,4,1]", lambda t, e: _step(e, torch.zeros(N, 4, 1)), ValueError, r"; got shape \[2, 4, 1\]$"),
    ("no action", lambda t, e: _step(e, None), ValueError,
     r"^env\.step needs tensordict\['action'\] of shape \[num_envs, 4\] = \[2, 4\] \(values in \[-1, 1\]\); "
     r"got no 'action' entry$"),
    ("float _reset", lambda t, e: _reset(e, torch.ones(N, 1)), ValueError,
     r"^env\.reset: '_reset' must be a bool mask of shape \[num_envs\] or \[num_envs, 1\] = \[2\] or \[2, 1\]; "
     r"got torch\.float32 of shape \[2, 1\]$"),
    ("int _reset", lambda t, e: _reset(e, torch.ones(N, dtype=torch.long)), ValueError,
     r"^env\.reset: '_reset' must be a bool mask .* got torch\.int64 of shape \[2\]$"),
    ("logs CLI: corrupted MCAP", lambda t, e: _logs_cli(_corrupted_mcap(t), "--out", str(t / "plots")), ValueError,
     r"^error: {tmp}/corrupted\.mcap: damaged MCAP file: a message on /scalars is not valid JSON \(.*\)$"),
    ("logs CLI: summary subcommand", lambda t, e: _logs_cli("summary", "runs/x.mcap"), ValueError,
     r"^error: python -m mtbench\.logs has no 'summary' subcommand; usage: python -m mtbench\.logs RUN\.mcap "
     r"\[--out DIR\] \[--last N\] \(prints the summary tables and writes the plots\)$"),
]


# the env inputs again, for the Parkour family (same messages, Go1 shapes)
PARKOUR_CASES = [
    ("make_env num_envs=2.5", lambda e: _make_parkour_env(num_envs=2.5, device="cpu"), ValueError,
     r"^parkour settings take a total num_envs \(an int, split over the 2 columns\), got 2\.5$"),
    ("make_env device=tpu", lambda e: _make_parkour_env(num_envs=2, device="tpu"), ValueError,
     r"^device='tpu' is not supported; valid choices: 'cpu', 'cuda', 'cuda:<index>'$"),
    ("make_env unknown override", lambda e: _make_parkour_env(num_envs=2, device="cpu", rand=True), ValueError,
     r"^unknown Parkour env overrides \['rand'\]; valid: \[.*'terrain_collision'.*\]$"),
    ("make_env terrain_collision=x", lambda e: _make_parkour_env(num_envs=2, device="cpu", terrain_collision="x"),
     ValueError, r"^unknown terrain_collision 'x'; valid choices: feet, legs, all$"),
    ("action [N,3]", lambda e: _step(e, torch.zeros(N, 3)), ValueError,
     r"^env\.step needs tensordict\['action'\] of shape \[num_envs, 12\] = \[2, 12\] \(joint-position offsets, "
     r"clipped to \+-5\); got shape \[2, 3\]$"),
    ("action [N]", lambda e: _step(e, torch.zeros(N)), ValueError, r"; got shape \[2\]$"),
    ("action [N,12,1]", lambda e: _step(e, torch.zeros(N, 12, 1)), ValueError, r"; got shape \[2, 12, 1\]$"),
    ("no action", lambda e: _step(e, None), ValueError, r"; got no 'action' entry$"),
    ("float _reset", lambda e: _reset(e, torch.ones(N, 1)), ValueError,
     r"^env\.reset: '_reset' must be a bool mask .* got torch\.float32 of shape \[2, 1\]$"),
    ("int _reset", lambda e: _reset(e, torch.ones(N, dtype=torch.long)), ValueError,
     r"^env\.reset: '_reset' must be a bool mask .* got torch\.int64 of shape \[2\]$"),
]


@pytest.mark.parametrize("action, error, pattern", [c[1:] for c in PARKOUR_CASES], ids=[c[0] for c in PARKOUR_CASES])
def test_bad_parkour_env_input_gives_one_clear_message(
    parkour_env: Any, action: Callable[[Any], Any], error: type[Exception], pattern: str
) -> None:
    with pytest.raises(error) as info:
        action(parkour_env)
    message = str(info.value)
    assert "\n" not in message
    assert re.search(pattern, message), message


@pytest.mark.parametrize("action, error, pattern", [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_bad_input_gives_one_clear_message(
    tmp_path: Path, physics_env: Any, action: Callable[[Path, Any], Any], error: type[Exception], pattern: str
) -> None:
    with pytest.raises(error) as info:
        action(tmp_path, physics_env)
    message = str(info.value)
    assert "\n" not in message
    assert re.search(pattern.replace("{tmp}", re.escape(str(tmp_path))), message), message


def test_the_logs_commands_the_docs_write_work(tmp_path: Path) -> None:
    """Every ``python -m mtbench.logs ...`` command in README.md and docs/ runs (placeholders filled in)."""
    run = _mcap_run(tmp_path / "runs")
    commands = []
    for doc in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        commands += re.findall(r"python -m mtbench\.logs ([^`\n|]*)", doc.read_text())
    assert any("summary" not in c for c in commands) and len(commands) >= 3, commands
    for command in commands:
        args = re.sub(r"\[[^\]]*\]", "", command).split()  # optional arguments dropped
        args = [str(run) if a.endswith(".mcap") else a for a in args]
        out = subprocess.run([sys.executable, "-m", "mtbench.logs", *args, "--out", str(tmp_path / "plots")],
                             capture_output=True, text=True, cwd=ROOT)
        assert out.returncode == 0, (command, out.stderr)
        assert "per task" in out.stdout and "reach" in out.stdout, command


def test_matmul_precision_is_applied_by_the_builder(tmp_path: Path) -> None:
    """``matmul_precision`` reaches ``torch.set_float32_matmul_precision`` (TF32 / bf16 matmuls on CUDA)."""
    before = torch.get_float32_matmul_precision()
    try:
        _build(tmp_path / "a", "matmul_precision=highest")
        assert torch.get_float32_matmul_precision() == "highest"
        _build(tmp_path / "b")  # the default: TF32 matmuls on CUDA
        assert torch.get_float32_matmul_precision() == "high"
    finally:
        torch.set_float32_matmul_precision(before)
