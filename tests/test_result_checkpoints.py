"""The trained policies shipped in docs/results/checkpoints are what their README says they are."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from mtbench.trainer.checkpoint import load_checkpoint

FOLDER = Path(__file__).resolve().parent.parent / "docs" / "results" / "checkpoints"


def _rows() -> list[list[str]]:
    rows = []
    for line in (FOLDER / "README.md").read_text().splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 6 and cells[0].startswith("`") and cells[0].endswith(".pt`"):
            rows.append(cells)
    return rows


def test_readme_lists_every_checkpoint_file():
    listed = sorted(row[0].strip("`") for row in _rows())
    assert listed and listed == sorted(p.name for p in FOLDER.glob("*.pt"))


@pytest.mark.parametrize("row", _rows(), ids=lambda row: row[0].strip("`"))
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
