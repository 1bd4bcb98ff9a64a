"""mtbench.paper: row configs compose with the paper's values, `run --dry-run` lists every row, the runner's
skip / resume logic, the report from synthetic MCAP logs, and the bootstrap CIs against known answers."""

from __future__ import annotations

import json
import math
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rliable", reason="the paper reports need rliable: pip install 'mtbench[paper]'")

from mtbench.paper import APPENDIX_HPARAMS, PAPER_LABELS, PAPER_VALUES, load_table, table_names  # noqa: E402
from mtbench.paper.__main__ import main as paper_main  # noqa: E402
from mtbench.paper.availability import Library, row_problems  # noqa: E402
from mtbench.paper.rows import CONF_DIR, REPO_ROOT, compose_row, group_overrides  # noqa: E402
from mtbench.paper.runner import command, execute, plan_runs  # noqa: E402
from mtbench.paper.stats import curve_intervals, interval_estimates, iqm  # noqa: E402

TABLES = ("mt10_rand", "mt50_rand", "parkour", "efficiency", "cosine")


@pytest.fixture(scope="module")
def tables() -> dict:
    """Every row of every table, composed once."""
    return {t: {r.name: r for r in load_table(t)} for t in table_names()}


def _everything(tables: dict, conf_dir: Path = CONF_DIR, **missing: set[str]) -> Library:
    """A library that has every env, loss, architecture, gradient method and trainer option the rows of ``tables``
    name, less ``missing`` (e.g. ``losses={"sac"}``)."""
    names: dict[str, set[str]] = {"settings": set(), "losses": set(), "archs": set(), "grads": set()}
    for rows in tables.values():
        for row in rows.values():
            names["settings"].add(row.cfg.env.name)
            names["losses"].add(row.cfg.loss.name)
            names["archs"].add(row.cfg.arch.name)
            names["grads"].add(row.cfg.grad.name)
    return Library(**{k: frozenset(v - missing.get(k, set())) for k, v in names.items()},
                   config_keys=frozenset({"pretrained", "resume", "seed"}) - missing.get("config_keys", set()),
                   conf_dir=conf_dir)


# ------------------------------------------------------------------------------------------------ configs
def test_tables_and_rows_match_the_paper(tables):
    assert tuple(tables) == TABLES
    # Table 5: the 12 MT-PPO variants with the tex's exact names, for MT10-rand and MT50-rand
    for t in ("mt10_rand", "mt50_rand"):
        assert set(tables[t]) == set(PAPER_VALUES[t]) and len(tables[t]) == 12
        for name, row in tables[t].items():
            assert row.label == PAPER_LABELS[t][name]
    assert [r.label for r in tables["mt10_rand"].values()] == [
        "Vanilla", "Multihead", "GRPO-Vanilla", "PCGrad", "CAGrad", "FAMO", "PaCo", "SH-MOORE", "MH-MOORE",
        "SH-CARE", "MH-CARE", "Soft-Modularization"]
    # Table 2: 8 variants x easy / hard / hard-CL, plus the flat-ground pre-training rows they start from
    main = {n for n, r in tables["parkour"].items() if not r.is_pretrain}
    assert main == set(PAPER_VALUES["parkour"]) and len(main) == 24
    for name in main:
        row = tables["parkour"][name]
        assert row.pretrain in tables["parkour"] and tables["parkour"][row.pretrain].is_pretrain
        assert row.requires == ["pretrained"] and row.metric == "progress"
    assert {r.label for r in tables["efficiency"].values()} == {"MT-PPO", "MT-GRPO", "MT-SAC", "MT-PQN"}
    for t in TABLES:
        for row in tables[t].values():
            assert row.seeds == list(range(42, 52)) and row.meta["table"] == t and row.meta["row"] == row.name


def test_paper_numbers_transcribed():
    v = PAPER_VALUES
    assert (v["mt10_rand"]["vanilla"]["success"].value, v["mt10_rand"]["vanilla"]["success"].lo,
            v["mt10_rand"]["vanilla"]["success"].hi) == (87.51, 86.99, 87.97)
    assert v["mt50_rand"]["mh_moore"]["success"].value == 79.46
    assert v["mt50_rand"]["mh_moore"]["return"].hi == 1048.88
    assert (v["parkour"]["hard_cl_famo"]["progress"].value, v["parkour"]["hard_cl_famo"]["progress"].std) == (68.57,
                                                                                                             0.76)
    for t in ("mt10_rand", "mt50_rand"):
        for row, metrics in v[t].items():
            for m in metrics.values():
                assert m.lo <= m.value <= m.hi, (t, row)


def _tex() -> Path | None:
    for base in (REPO_ROOT / "shared", REPO_ROOT.parent / "shared", Path("/work/shared")):
        path = base / "reference" / "mtbench-paper.tex"
        if path.is_file():
            return path
    return None


@pytest.mark.skipif(_tex() is None, reason="shared/reference/mtbench-paper.tex not found")
def test_paper_numbers_against_the_tex():
    """Every number of Table 5 and Table 2 equals the tex's, row by row."""
    tex = _tex().read_text()
    t5 = tex[tex.index(r"\multicolumn{2}{c}{MT10-rand}"):
             tex.index(r"\label{table:main_table_results_metaworld}")]
    for name, label in PAPER_LABELS["mt10_rand"].items():
        line = next(x for x in t5.splitlines() if x.strip().startswith(label + " &"))
        numbers = [float(x) for x in re.findall(r"\d+\.\d+", line)]
        ours = []
        for t in ("mt10_rand", "mt50_rand"):
            for m in ("success", "return"):
                pv = PAPER_VALUES[t][name][m]
                ours += [pv.value, pv.lo, pv.hi]
        assert numbers == ours, label
    t2 = tex[tex.index(r"Parkour-easy & Parkour-hard"):tex.index(r"\label{table:main_result_parkour}")]
    for name, label in PAPER_LABELS["parkour"].items():
        if not name.startswith("easy_"):
            continue
        variant = name[len("easy_"):]
        line = next(x for x in t2.splitlines() if x.strip().startswith(label + " &"))
        numbers = [float(x) for x in re.findall(r"\d+\.\d+", line)]
        ours = []
        for setting in ("easy", "hard", "hard_cl"):
            pv = PAPER_VALUES["parkour"][f"{setting}_{variant}"]["progress"]
            ours += [pv.value, pv.std]
        assert numbers == ours, label


def test_row_configs_carry_the_appendix_values(tables):
    ppo, grpo = APPENDIX_HPARAMS["mt_ppo"], APPENDIX_HPARAMS["mt_grpo"]

    def iterations(row) -> int:
        c = row.cfg
        return math.ceil(int(c.total_frames) / (int(c.env.num_envs) * int(c.loss.horizon)))

    for i, t in enumerate(("mt10_rand", "mt50_rand")):
        rows = tables[t]
        van = rows["vanilla"].cfg
        assert (van.env.name, van.loss.name, van.arch.name, van.grad.name) == (t, "ppo", "mlp", "none")
        assert van.env.num_envs == ppo["num_envs"][i] and van.loss.minibatch_size == ppo["minibatch_size"][i]
        assert van.loss.horizon == ppo["horizon"] and van.loss.epochs == ppo["mini_epochs"]
        assert van.loss.lr == ppo["learning_rate"] and van.loss.entropy_coeff == ppo["entropy_coef"]
        assert van.loss.lmbda == ppo["tau"] and van.loss.gamma == ppo["gamma"]
        assert van.loss.normalize_input is True and van.loss.normalize_value is True
        assert list(van.arch.kwargs.hidden) == ppo["network.mlp.units"]
        assert iterations(rows["vanilla"]) == ppo["max_epochs"][i] and rows["vanilla"].frames == 1_000_000_000
        g = rows["grpo_vanilla"].cfg
        assert g.loss.name == "grpo" and g.env.num_envs == grpo["num_envs"][i] and g.loss.horizon == 150
        assert iterations(rows["grpo_vanilla"]) == grpo["max_epochs"][i]
        assert rows["pcgrad"].cfg.env.num_envs == APPENDIX_HPARAMS["pcgrad"]["num_envs"][i]
        assert rows["cagrad"].cfg.env.num_envs == APPENDIX_HPARAMS["cagrad"]["num_envs"][i]
        assert rows["pcgrad"].cfg.grad.params == "critic" and rows["cagrad"].cfg.grad.params == "critic"
        assert rows["cagrad"].cfg.grad.c == APPENDIX_HPARAMS["cagrad"]["c"]
        famo = rows["famo"].cfg.grad
        assert (famo.name, famo.gamma, famo.w_lr, famo.epsilon, famo.norm_w_grad) == (
            "famo", *(APPENDIX_HPARAMS["famo"][k] for k in ("gamma", "w_lr", "epsilon", "norm_w_grad")))
        for name in ("sh_moore", "mh_moore"):
            assert rows[name].cfg.arch.kwargs.num_experts == APPENDIX_HPARAMS["moore"]["moore.num_experts"][i]
            assert rows[name].cfg.arch.kwargs.hidden_dim == APPENDIX_HPARAMS["moore"]["moore.D"]
        assert rows["mh_moore"].cfg.arch.name == "moore_mh" and rows["sh_moore"].cfg.arch.name == "moore"
        assert rows["paco"].cfg.arch.kwargs.num_sets == APPENDIX_HPARAMS["paco"]["paco.K"][i]
        care = rows["mh_care"].cfg.arch
        assert care.name == "care_mh" and care.kwargs.num_experts == 6 and list(care.kwargs.hidden) == [400, 400, 400]
        sm = rows["soft_modularization"].cfg.arch.kwargs
        assert (sm.num_experts, sm.num_layers, list(sm.state_encoder)) == (2, 4, [256, 256])
        for row in rows.values():  # every minibatch size divides the batch
            c = row.cfg
            assert (c.env.num_envs * c.loss.horizon) % c.loss.minibatch_size == 0, row.name

    park, pk = tables["parkour"], APPENDIX_HPARAMS["parkour_ppo"]
    for name, row in park.items():
        c = row.cfg
        assert c.loss.lr_schedule == pk["lr_schedule"] and c.loss.minibatch_size == pk["minibatch_size"]
        assert c.loss.normalize_input is False and c.loss.normalize_value is False
        assert c.loss.clip_actions is True  # rl_games clip_actions of MTBench's Go1 configs
        assert c.loss.lr_schedule_type == "standard"
        assert c.loss.kl_threshold == (0.01 if "moore" in name else 0.008)  # go1-mt-moore-SHPPO.yaml: 0.01
        if not row.is_pretrain:
            assert iterations(row) == pk["max_epochs"][0 if name.startswith("easy") else 1]
            assert c.env.name == "parkour_" + row.meta["setting"]
    assert park["hard_cl_famo"].cfg.grad.w_lr == pk["famo.w_lr"] and park["easy_famo"].cfg.grad.gamma == 1e-4
    assert park["hard_sh_moore"].cfg.arch.kwargs.num_experts == pk["moore.num_experts"]
    assert list(park["easy_soft_modularization"].cfg.arch.kwargs.task_encoder) == [128]

    sac, pqn = tables["efficiency"]["mt10_rand_sac"].cfg, tables["efficiency"]["mt10_rand_pqn"].cfg
    s = APPENDIX_HPARAMS["mt_sac"]
    assert (sac.loss.name, sac.env.num_envs, sac.loss.batch_size, sac.loss.nstep,
            sac.loss.gradient_steps_per_iteration) == ("sac", s["num_envs"], s["batch_size"], s["nstep"],
                                                      s["gradient_steps_per_itr"])
    assert list(sac.arch.kwargs.hidden) == s["network.mlp.units"]
    q = APPENDIX_HPARAMS["mt_pqn"]
    assert (pqn.loss.name, pqn.env.num_envs, pqn.loss.horizon, pqn.loss.epochs, pqn.loss.lmbda) == (
        "pqn", q["num_envs"], q["horizon"], q["mini_epochs"], q["q_lambda"])
    assert pqn.loss.minibatch_size * q["num_minibatches"] == q["num_envs"] * q["horizon"]
    assert tables["cosine"]["vanilla_diagnostics"].cfg.grad.diagnostics_every > 0


# ------------------------------------------------------------------------------------------------ availability
def test_availability_is_read_from_the_library(tables):
    lib = _everything(tables)
    for t, rows in tables.items():
        for row in rows.values():  # with everything built, every row is runnable (its values fit the library)
            assert row_problems(row, lib, rows) == [], (t, row.name)
    no_sac = _everything(tables, losses={"sac"}, settings={"parkour_flat"}, config_keys={"pretrained"})
    eff, park = tables["efficiency"], tables["parkour"]
    assert any("loss 'sac'" in p for p in row_problems(eff["mt10_rand_sac"], no_sac, eff))
    problems = row_problems(park["hard_cl_vanilla"], no_sac, park)
    assert any("'pretrained'" in p for p in problems)
    assert any(p.startswith("pre-training row flat_vanilla: env 'parkour_flat'") for p in problems)
    assert row_problems(park["hard_cl_vanilla"], lib, park) == []


def test_pending_group_is_selected_once_the_library_has_it(tmp_path, tables):
    """A row whose loss is inline (conf/loss/sac.yaml missing) picks the library's config up once it exists: the
    library's keys underneath, the row's values on top; keys the library lacks are reported."""
    conf = tmp_path / "conf"
    shutil.copytree(CONF_DIR, conf)
    (conf / "loss" / "sac.yaml").unlink(missing_ok=True)  # a library without loss=sac: the row gives it inline
    row_file = conf / "paper" / "efficiency" / "mt10_rand_sac.yaml"
    row_file.write_text(row_file.read_text().replace("override /loss: sac", "override /loss: null"))
    row = load_table("efficiency", conf, rows=["mt10_rand_sac"])[0]
    assert "loss=sac" not in group_overrides(row, conf)
    (conf / "loss" / "sac.yaml").write_text("name: sac\nhorizon: 1\nbatch_size: 256\ntau_extra: 3\nactor_lr: 1.0\n")
    assert "loss=sac" in group_overrides(row, conf)
    cfg = compose_row("efficiency", "mt10_rand_sac", group_overrides(row, conf), conf)
    assert cfg.loss.tau_extra == 3 and cfg.loss.batch_size == 8192  # library key kept, the paper's value wins
    lib = _everything(tables, conf)
    assert any("conf/loss/sac.yaml does not have" in p and "loss.nstep" in p for p in row_problems(row, lib))


def test_dry_run_lists_every_row_of_every_table(tmp_path, capsys, tables):
    assert paper_main(["run", "all", "--dry-run", "--seeds", "1", "--frames", "1e6", "--out", str(tmp_path)]) == 0
    text = capsys.readouterr().out
    lib = Library.current()
    for t, rows in tables.items():
        assert f"== {t}: {len(rows)} rows" in text
        for row in rows.values():
            line = next(x for x in text.splitlines() if x.startswith("[") and f"] {t}/{row.name} s42:" in x)
            problems = row_problems(row, lib, rows)
            if problems:
                assert "not available: " + "; ".join(problems) in line
            else:
                assert "new (1,000,000 frames)" in line
                idx = text.splitlines().index(line)
                cmd = text.splitlines()[idx + 1]
                assert f"--config-dir conf/paper/{t} --config-name {row.name}" in cmd and "total_frames=1000000" in cmd
    assert all(not row_problems(r, lib, tables["mt10_rand"]) for r in tables["mt10_rand"].values())


# ------------------------------------------------------------------------------------------------ runner
def _fake_trainer(calls: list, rc: int = 0, final: bool = True):
    def run(cmd, cwd, env, stdout, stderr):
        calls.append(cmd)
        args = dict(a.split("=", 1) for a in cmd if "=" in a and not a.startswith("-"))
        ck = Path(args["checkpoint.dir"])
        ck.mkdir(parents=True, exist_ok=True)
        (ck / "last.pt").write_text("x")
        if final:
            (ck / "final.pt").write_text("x")
        return subprocess.CompletedProcess(cmd, rc)
    return run


def test_runner_skips_finished_runs_and_resumes_unfinished(tmp_path, tables):
    rows = [tables["mt10_rand"]["vanilla"]]
    quiet = {"echo": lambda s: None}
    launches = plan_runs(rows, out=tmp_path, seeds=2, frames=1000)
    assert [(x.seed, x.state) for x in launches] == [(42, "new"), (43, "new")]
    cmd = command(launches[0])
    for part in ("--config-name", "vanilla", "env=mt10_rand", "seed=42", "total_frames=1000",
                 "logging.exp_name=mt10_rand-vanilla-s42", f"checkpoint.dir={tmp_path.resolve()}/vanilla/s42/checkpoints"):
        assert part in cmd
    (tmp_path / "vanilla" / "s43").mkdir(parents=True)
    (tmp_path / "vanilla" / "s43" / "stale.mcap").write_text("partial")  # killed before its first checkpoint
    calls: list = []
    assert execute(launches, runner=_fake_trainer(calls), **quiet) == 0
    assert len(calls) == 2 and not (tmp_path / "vanilla" / "s43" / "stale.mcap").exists()
    assert json.loads((tmp_path / "vanilla" / "s42" / "done.json").read_text())["frames"] == 1000
    # finished: skipped
    again = plan_runs(rows, out=tmp_path, seeds=2, frames=1000)
    assert [x.state for x in again] == ["done", "done"]
    assert execute(again, runner=_fake_trainer(calls), **quiet) == 0 and len(calls) == 2
    # more frames than finished: continues from the last checkpoint
    more = plan_runs(rows, out=tmp_path, seeds=1, frames=5000)
    assert more[0].state == "resume" and f"resume={more[0].resume.resolve()}" in command(more[0])
    # an unfinished run (checkpoint, no marker) resumes; a failing run is counted and gets no marker
    (tmp_path / "vanilla" / "s44" / "checkpoints").mkdir(parents=True)
    (tmp_path / "vanilla" / "s44" / "checkpoints" / "last.pt").write_text("x")
    third = plan_runs(rows, out=tmp_path, seeds=3, frames=1000)
    assert [x.state for x in third] == ["done", "done", "resume"]
    assert execute(third, runner=_fake_trainer(calls, rc=1, final=False), **quiet) == 1
    assert "resume=" in " ".join(calls[-1]) and not (tmp_path / "vanilla" / "s44" / "done.json").exists()


def test_runner_starts_parkour_rows_from_their_pretraining(tmp_path, tables):
    park = tables["parkour"]
    launches = plan_runs([park["hard_pcgrad"], park["flat_vanilla"]], out=tmp_path, seeds=1, frames=100)
    assert [x.row.name for x in launches] == ["flat_vanilla", "hard_pcgrad"]  # pre-training first
    assert launches[1].pretrained == tmp_path / "flat_vanilla" / "s42" / "checkpoints" / "final.pt"
    calls: list = []
    # the pre-training run fails: the row that starts from it is blocked, not launched without its weights
    assert execute(launches, runner=_fake_trainer(calls, rc=1, final=False), echo=lambda s: None) == 2
    assert len(calls) == 1
    launches = plan_runs([park["flat_vanilla"], park["hard_pcgrad"]], out=tmp_path, seeds=1, frames=100)
    assert execute(launches, runner=_fake_trainer(calls), echo=lambda s: None) == 0
    assert any(a.startswith("pretrained=") and a.endswith("flat_vanilla/s42/checkpoints/final.pt") for a in calls[-1])
    # the row's env option when conf/env/parkour_hard.yaml exists, else its inline env (and never the CPU preset)
    conf_env = Path(__file__).resolve().parents[1] / "conf" / "env" / "parkour_hard.yaml"
    assert ("env=parkour_hard" if conf_env.exists() else "env=null") in calls[-1]


# ------------------------------------------------------------------------------------------------ report
def _write_run(out: Path, row: str, seed: int, finals: float, *, cosine: bool = False, frames_per_it: int = 1000,
               iters: int = 6, ret: float = 900.0) -> None:
    from mtbench.logging import MCAPLogger

    d = out / row / f"s{seed}"
    d.mkdir(parents=True)
    logger = MCAPLogger(f"t-{row}-s{seed}", str(d), flush_interval_s=None)
    for it in range(1, iters + 1):
        frames = it * frames_per_it
        m = {"frames": frames, "iteration": it, "time/collect_s": 0.5, "time/update_s": 0.25,
             "success/mean": finals * it / iters, "return/mean": ret * it / iters}
        if it == 1:
            m["success/mean"] = math.nan  # no episode finished yet
        if cosine:
            m.update({"train/grad_cos_actor_mean": 0.3, "train/grad_cos_actor_min": 0.1,
                      "train/grad_cos_actor_max": 0.5, "train/grad_cos_critic_mean": 0.1,
                      "train/grad_cos_critic_min": -0.4, "train/grad_cos_critic_max": 0.6})
        logger.log_metrics(m, step=frames)
    logger.close()
    (d / "done.json").write_text(json.dumps({"frames": iters * frames_per_it}))


def test_report_from_synthetic_logs(tmp_path, tables):
    out, docs = tmp_path / "runs" / "mt10_rand", tmp_path / "docs"
    finals = {"vanilla": [0.80, 0.90, 0.85], "pcgrad": [0.70, 0.75], "grpo_vanilla": [0.95]}
    for row, values in finals.items():
        for i, v in enumerate(values):
            _write_run(out, row, 42 + i, v, cosine=row == "pcgrad")
    from mtbench.paper.report import build_report

    lib = _everything(tables, losses={"sac", "pqn"})
    path = build_report("mt10_rand", out=out, docs_dir=docs, lib=lib, reps=300)
    text = path.read_text()
    est = interval_estimates(np.asarray(finals["vanilla"]) * 100, reps=300)
    line = next(x for x in text.splitlines() if x.startswith("| Vanilla (`vanilla`) | 87.51 [86.99, 87.97]"))
    assert f"{est['mean'].fmt()} | {est['iqm'].fmt()} | {85.0 - 87.51:+.2f} | 3 | 6k |" in line
    assert "| GRPO-Vanilla (`grpo_vanilla`) | 91.12 [88.32, 93.96] | 95.00 [95.00, 95.00]" in text
    assert "| PaCo (`paco`) | 84.37 [81.61, 86.61] | – |" in text  # a row without runs keeps the paper's number
    assert "no runs under" in text and "6k frames per run (0.0006% of the paper's 1B)" in text
    assert "MT-SAC (mt10_rand): not available: loss 'sac'" in text
    assert "| PCGrad (n=2) | 0.300 | 0.100 | 0.100 | -0.400 | yes |" in text  # O3: critic conflicts more
    assert re.search(r"\| MT-PPO \| 6k \| 0\.1 \| 1,333 \| 85\.00 \|", text)  # O1: 6 x 0.75 s, 6000 frames
    for png in ("curves.png", "curve_vanilla.png", "o1_wallclock_mt10_rand.png", "o3_cosine.png"):
        assert (docs / "mt10_rand" / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_parkour_report_checks_the_curriculum(tmp_path):
    out, docs = tmp_path / "runs" / "parkour", tmp_path / "docs"
    for i, (hard, cl) in enumerate([(0.50, 0.66), (0.54, 0.70)]):
        _write_run(out, "hard_vanilla", 42 + i, hard)
        _write_run(out, "hard_cl_vanilla", 42 + i, cl)
    from mtbench.paper.report import build_report

    text = build_report("parkour", out=out, docs_dir=docs, lib=None, reps=300).read_text()
    assert "| Vanilla (`hard_vanilla`) | 54.51 ± 0.82 | 52.00 [50.00, 54.00] |" in text
    assert re.search(r"\| Vanilla \| 52\.00 \[50\.00, 54\.00\] \| 68\.00 \[66\.00, 70\.00\] \| \+16\.00 \| \+13\.61 \|",
                     text)
    assert (docs / "parkour" / "o4_curriculum.png").exists()


# ------------------------------------------------------------------------------------------------ bootstrap
def _direct_bootstrap(scores: np.ndarray, reps: int, seed: int) -> np.ndarray:
    """The stratified percentile bootstrap written out with NumPy: each resample draws, independently for every
    task column, num_runs run indices with replacement from the global generator; 2.5 / 97.5 percentiles."""
    from scipy.stats import trim_mean

    n, m = scores.shape
    rng_state = np.random.get_state()
    np.random.seed(seed)
    stats = np.empty((reps, 2))
    for r in range(reps):
        idx = np.random.choice(n, (n, m), replace=True)
        sample = scores[idx, np.arange(m)[None, :]]
        stats[r] = [sample.mean(axis=0).mean(), trim_mean(sample, 0.25, axis=None)]
    np.random.set_state(rng_state)
    return np.percentile(stats, [2.5, 97.5], axis=0)


def test_bootstrap_matches_a_direct_numpy_computation():
    scores = np.array([[0.2, 0.9], [0.5, 0.7], [0.9, 0.8], [0.4, 0.1], [0.6, 0.65]])
    state = np.random.get_state()
    est = interval_estimates(scores, reps=2000, seed=7)
    assert np.array_equal(np.random.get_state()[1], state[1])  # the global generator is left as it was
    ci = _direct_bootstrap(scores, 2000, 7)
    assert est["mean"].value == pytest.approx(scores.mean())
    assert (est["mean"].lo, est["mean"].hi) == pytest.approx((ci[0, 0], ci[1, 0]), abs=1e-12)
    assert (est["iqm"].lo, est["iqm"].hi) == pytest.approx((ci[0, 1], ci[1, 1]), abs=1e-12)
    assert interval_estimates(scores, reps=2000, seed=7) == est  # fixed seed: same interval


def test_bootstrap_degenerate_and_known_cases():
    one = interval_estimates(np.array([73.5]), reps=200)
    assert (one["mean"].value, one["mean"].lo, one["mean"].hi) == (73.5, 73.5, 73.5)
    same = interval_estimates(np.array([0.4, 0.4, 0.4]), reps=200)
    assert (same["iqm"].value, same["iqm"].lo, same["iqm"].hi) == pytest.approx((0.4, 0.4, 0.4))
    assert iqm(np.arange(1.0, 9.0)) == pytest.approx(4.5)  # mean of 3, 4, 5, 6
    three = np.array([10.0, 20.0, 60.0])
    e = interval_estimates(three, reps=500)
    assert e["iqm"].value == pytest.approx(30.0) == e["mean"].value  # 3 runs: 25% trimming drops none
    assert 10.0 <= e["mean"].lo < 30.0 < e["mean"].hi <= 60.0
    # large sample: the percentile interval of the mean is mean +- 1.96 sd / sqrt(n)
    x = np.random.default_rng(0).normal(50.0, 10.0, 400)
    e = interval_estimates(x, reps=4000, seed=1)
    half = 1.96 * x.std(ddof=1) / math.sqrt(len(x))
    assert (e["mean"].hi - e["mean"].lo) / 2 == pytest.approx(half, rel=0.1)
    with pytest.raises(ValueError, match="finite"):
        interval_estimates(np.array([1.0, math.nan]))


def test_curve_intervals_are_pointwise():
    curves = np.array([[0.0, 0.2, 0.5], [0.0, 0.4, 0.7], [0.0, 0.3, 0.9]])
    mean, lo, hi = curve_intervals(curves, reps=500)
    assert mean == pytest.approx(curves.mean(axis=0))
    assert (lo[0], hi[0]) == (0.0, 0.0) and np.all(lo <= mean) and np.all(mean <= hi)
    assert lo[1] >= 0.2 and hi[2] <= 0.9
