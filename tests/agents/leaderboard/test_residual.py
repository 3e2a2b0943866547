"""Residual entries of the leaderboard: ``railgym leaderboard run --algo A --residual C``
trains the agent on the task's classical controller and evaluates the saved residual policy
as ``railgym evaluate`` runs it; with its output zeroed it scores as the controller's
baseline row; a controller the task has no residual form of is one error naming the flag."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from agents.commands.cli import main
from agents.leaderboard.results import load_entries, table_rows
from agents.leaderboard.run import (
    RESIDUAL_BASES,
    check_residual,
    policy_entry,
    residual_controllers,
    training_config,
)
from railgym import _checks as val
from railgym.tasks import TASKS

TASK, ALGO, BASE, STEPS = "bogie-payload", "sac", "lqg", 256


def _iqm_ci(entry: dict) -> tuple[float, float, float]:
    (row,) = table_rows([entry])
    return row["iqm"], row["ci_low"], row["ci_high"]


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory) -> Path:
    """A residual SAC run of 256 steps through the command (no gradient step: SAC starts
    learning after 2000), its entry stored in the returned results folder."""
    pytest.importorskip("stable_baselines3")
    results = tmp_path_factory.mktemp("results")
    argv = ["leaderboard", "run", "--task", TASK, "--algo", ALGO, "--residual", BASE]
    argv += ["--seeds", "1", "--steps", str(STEPS), "--results", str(results)]
    assert main([*argv, "--runs", str(results / "runs"), "--quiet"]) == 0
    return results


def test_tiny_residual_run_through_the_cli_stores_a_learned_entry(tiny_run):
    (entry,) = load_entries(tiny_run, [TASK])
    assert (entry["name"], entry["kind"]) == (f"{ALGO}-residual-{BASE}", "learned")
    assert entry["seeds"] == [0] and entry["steps"] == STEPS
    config = entry["provenance"]["config"][TASKS[TASK].env_id]
    assert (config["algo"], config["residual"], config["n_timesteps"]) == (ALGO, BASE, STEPS)
    assert config["env_kwargs"]["observation"] == "sensors"  # what the LQG needs
    assert set(entry["metric"]) == set(TASKS[TASK].case_labels)
    assert all(len(v) == 1 and 0 < v[0] < 1 for v in entry["metric"].values())  # a_w, m/s²
    assert entry["provenance"]["wall_s"] > 0 and entry["eval_wall_s"] > 0
    assert entry["curves"]["0"]["steps"][-1] <= STEPS


def test_zeroed_residual_scores_as_its_baseline_row(tiny_run):
    """The run's policy with its output layer zeroed is the nominal LQG itself: every case's
    metric and the row equal those of the controller evaluated as a policy (bit for bit) and
    the shipped ``lqg`` baseline row's; the untrained policy's do not."""
    import torch
    from stable_baselines3 import SAC

    from agents.policies.policy_io import write_manifest

    (untrained,) = load_entries(tiny_run, [TASK])
    run = tiny_run / "runs" / TASK / f"{ALGO}-residual-{BASE}" / "seed0"
    model = SAC.load(run / "model.zip", device="cpu")
    with torch.no_grad():
        model.actor.mu.weight.zero_()
        model.actor.mu.bias.zero_()
    model.save(run / "model.zip")
    write_manifest(run)
    zeroed = policy_entry(TASK, str(run / "model.zip"), "zeroed", results=tiny_run)
    baseline = policy_entry(TASK, BASE, "baseline", results=tiny_run)  # the controller alone
    assert zeroed["metric"] == baseline["metric"]  # bit for bit
    assert _iqm_ci(zeroed) == _iqm_ci(baseline)
    (shipped,) = [e for e in load_entries(tasks=[TASK]) if e["name"] == BASE]
    np.testing.assert_allclose(_iqm_ci(zeroed), _iqm_ci(shipped), rtol=1e-12)
    assert untrained["metric"] != baseline["metric"]
    assert not np.allclose(_iqm_ci(untrained), _iqm_ci(baseline), atol=1e-3)


@pytest.mark.parametrize(
    ("task", "residual", "message"),
    [
        ("bogie-active", "nothing", r"--residual must be a classical controller of task "
         r"bogie-active \(skyhook, groundhook, lqg\), got 'nothing'"),
        ("bogie-payload", "lqg-scheduled", r"--residual must be .* \(skyhook, lqg\)"),
        ("bogie-active", "passive", r"--residual must be"),
        ("crash-adaptive", "lqg", r"--residual 'lqg': task crash-adaptive has no residual form"),
    ],
)  # fmt: skip
def test_bad_residual_is_one_error_naming_the_flag(task, residual, message, tmp_path, capsys):
    argv = ["leaderboard", "run", "--task", task, "--algo", "ppo", "--residual", residual]
    assert main([*argv, "--results", str(tmp_path), "--runs", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("railgym leaderboard run: error: --residual") and "\n" not in err
    assert re.search(message, err), err
    assert not any(tmp_path.iterdir())  # refused before anything ran


def test_residual_with_policy_is_refused(tmp_path, capsys):
    argv = ["leaderboard", "run", "--task", "bogie-active", "--policy", "lqg"]
    assert main([*argv, "--residual", "lqg", "--results", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "--residual goes with --algo (it trains), not --policy" in err
    assert not any(tmp_path.iterdir())


def test_every_residual_base_is_a_residual_controller_of_its_task():
    assert set(RESIDUAL_BASES) == {n for n, t in TASKS.items() if residual_controllers(t)}
    assert residual_controllers(TASKS["crash-adaptive"]) == ()
    for name, base in RESIDUAL_BASES.items():
        assert check_residual(TASKS[name], base) == base
        assert base in TASKS[name].baselines
    with pytest.raises(val.FieldError, match="^residual must be"):
        check_residual(TASKS["vehicle-preview"], "modal-skyhook")


def test_training_config_adds_the_controller_and_what_it_needs():
    task = TASKS["bogie-semi-active"]
    plain = training_config(task, "td3", 1000, 3)[task.env_id]
    res = training_config(task, "td3", 1000, 3, "clipped-lqg")[task.env_id]
    assert "residual" not in plain and res["residual"] == "clipped-lqg"
    assert res["env_kwargs"] == {**plain["env_kwargs"], "observation": "sensors"}
    assert {k: v for k, v in res.items() if k not in ("residual", "env_kwargs")} == {
        k: v for k, v in plain.items() if k != "env_kwargs"
    }
