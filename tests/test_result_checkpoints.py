"""The trained policies shipped in docs/results/checkpoints are what their README says they are; the MT-PQN policy
still solves MT10-rand on the CPU (greedy, fresh worlds)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from hydra import compose, initialize_config_dir
from omegaconf import OmegaConf

from mtbench.evaluation import evaluate, parse_args
from mtbench.trainer.checkpoint import load_checkpoint

ROOT = Path(__file__).resolve().parent.parent
FOLDER = ROOT / "docs" / "results" / "checkpoints"
PQN = "mt10_rand_pqn_s42.pt"


def _rows(prefix: str = "") -> list[list[str]]:
    """The README's table rows (cells) whose first cell is a checkpoint file starting with ``prefix``."""
    rows = []
    for line in (FOLDER / "README.md").read_text().splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 6 and cells[0].startswith(f"`{prefix}") and cells[0].endswith(".pt`"):
            rows.append(cells)
    return rows


def test_readme_lists_every_checkpoint_file():
    listed = sorted(row[0].strip("`") for row in _rows())
    assert listed and listed == sorted(p.name for p in FOLDER.glob("*.pt"))


@pytest.mark.parametrize("row", _rows("parkour_"), ids=lambda row: row[0].strip("`"))
def test_checkpoint_matches_its_readme_row(row):
    name, command, _code, counts, total, _progress = row
    state = load_checkpoint(FOLDER / name.strip("`"))  # verifies the checksum
    cfg, counters = state["config"], state["counters"]
    args = dict(a.split("=", 1) for a in command.strip("`").split()[2:])
    assert cfg["env"]["name"] == args["env"] and cfg["loss"]["name"] == args["loss"]
    assert cfg["arch"]["name"] == args["arch"] and cfg["seed"] == int(args.get("seed", 42))
    assert cfg["max_iterations"] == int(args["max_iterations"])
    assert cfg["pretrain"]["iterations"] == int(args["pretrain.iterations"])
    iterations, frames = (int(x.replace(",", "")) for x in counts.split("/"))
    assert counters["iteration"] == iterations and counters["frames"] == frames
    per_iteration = cfg["env"]["num_envs"] * cfg["loss"]["horizon"]
    assert frames == iterations * per_iteration
    # a flat pre-training stage (env=parkour_flat) is stage 1 itself: no stage before it
    flat = 0 if cfg["env"]["name"] == "parkour_flat" else cfg["pretrain"]["iterations"] * per_iteration
    assert float(re.match(r"([\d.]+) M", total).group(1)) == pytest.approx((frames + flat) / 1e6, abs=0.05)
    # networks only: what evaluation and ``pretrained=`` read, nothing of the full run state
    assert any(k.startswith("actor_network_params.") for k in state["loss"])
    assert any(k.startswith("critic_network_params.") for k in state["loss"])
    assert not {"optimizer", "env", "rollout"} & set(state)


def test_pqn_checkpoint_is_the_default_mt10_rand_recipe_as_its_readme_row_says():
    (row,) = _rows("mt10_rand_pqn")
    state = load_checkpoint(FOLDER / PQN)
    cfg, counters = state["config"], state["counters"]
    iterations, frames = (int(x.replace(",", "")) for x in row[3].split("/"))
    assert (counters["iteration"], counters["frames"]) == (iterations, frames)
    assert frames == iterations * cfg["env"]["num_envs"] * cfg["loss"]["horizon"]
    # the settings of ``env=mt10_rand loss=pqn arch=residual_mlp`` (what the README says)
    with initialize_config_dir(config_dir=str(ROOT / "conf"), version_base="1.3"):
        recipe = OmegaConf.to_container(compose("config", overrides=["env=mt10_rand", "loss=pqn",
                                                                     "arch=residual_mlp"]))
    assert cfg["loss"] == recipe["loss"] and cfg["arch"] == recipe["arch"] and cfg["seed"] == recipe["seed"] == 42
    env = dict(cfg["env"], overrides={k: v for k, v in cfg["env"]["overrides"].items()
                                      if (k, v) not in {("episode_length", 150), ("action_scale", 0.01)}})
    assert env == recipe["env"]  # the run named the env's default episode length and action scale explicitly
    assert cfg["total_frames"] == recipe["max_iterations"] * recipe["env"]["num_envs"] * recipe["loss"]["horizon"]
    # networks and statistics only
    assert any(k.startswith("value_network_params.") for k in state["loss"])
    assert any(k.startswith("_value_estimator.value_norm.") for k in state["loss"]) and "obs_norm" in state
    assert not {"optimizer", "env", "rollout"} & set(state)


def test_pqn_checkpoint_solves_mt10_rand_greedily_on_the_cpu(tmp_path: Path):
    """Two fresh worlds per task, one greedy 150-step episode each: the policy that scored 90.0% on 200 worlds
    (door_open 0%, every other task 100%) must still score >= 70% here -- a change of the physics, the rewards'
    success rules, the observation or the PQN evaluation path that breaks the trained policy fails this."""
    args = parse_args([f"checkpoint={FOLDER / PQN}", "device=cpu", "num_envs=20", "episodes=1", "seed=43",
                       "deterministic=true", f"out={tmp_path}"])
    (greedy,) = evaluate(args, logger="none").results
    print(dict(zip(greedy.task_names, greedy.success)))
    assert greedy.mode == "deterministic" and greedy.episodes == [2] * 10
    assert sum(greedy.success) / len(greedy.success) >= 0.7, dict(zip(greedy.task_names, greedy.success))
