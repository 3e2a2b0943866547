"""The user's train in the crash commands: ``railgym evaluate --env crash --scenario FILE``
runs their masses, never railgym's default train silently, and a policy trained on another
train is refused by name."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from agents.commands.cli import main
from agents.evaluation.evaluate import evaluate_crash
from railgym._checks import resolve_yaml


@pytest.fixture
def heavy_train(tmp_path):
    """The paper's scenario with heavier cars (another train, another name)."""
    text, _ = resolve_yaml("paper", "scenario", "railgym", ("configs", "crash"))
    doc = yaml.safe_load(text)
    doc["crash"]["name"] = "my_train"
    doc["crash"]["cars"]["lead"]["mass_t"] = 45.0
    doc["crash"]["cars"]["passenger"]["mass_t"] = 50.0
    path = tmp_path / "my_train.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def test_evaluate_runs_the_users_train(heavy_train):
    """The same passive absorbers at the same speed crush further on the heavier train:
    the kinetic energy is (45 + 50) / (30.39 + 34.45) = 1.47 times the paper's."""
    ours = evaluate_crash(["passive"], "reference", [40.0])[0]
    theirs = evaluate_crash(
        ["passive"], "reference", [40.0], env_kwargs={"scenario": str(heavy_train)}
    )[0]
    assert np.max(theirs["max_crush_m"]) > 1.2 * np.max(ours["max_crush_m"])


def test_scenario_flag_is_for_the_crash_env_only(heavy_train, capsys):
    assert main(["evaluate", "passive", "--scenario", str(heavy_train)]) == 2
    assert "--scenario: only for --env crash" in capsys.readouterr().err
    assert main(["evaluate", "passive", "--env", "crash", "--vehicle", "x.yaml"]) == 2
    assert "--vehicle: only for --env vertical and vehicle" in capsys.readouterr().err


def test_a_policy_trained_on_another_train_is_refused(heavy_train, capsys):
    args = ["evaluate", "ppo-crash", "--env", "crash", "--scenario", str(heavy_train)]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "policy" in err and "trained with scenario=" in err and "my_train" in err
