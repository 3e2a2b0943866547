"""rl-zoo3 loads the shipped rl-zoo3 config and trains on it (needs rl_zoo3; skipped without)."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

pytest.importorskip("rl_zoo3", reason="needs rl_zoo3 (pip install 'railgym[zoo]')")

ROOT = Path(__file__).resolve().parents[3]
CONFIGS = ROOT / "railgym" / "configs" / "agents"
ENV = "railgym/VerticalSuspension-v3"


def test_rlzoo_config_has_the_settings_of_the_agents_train_config():
    zoo = yaml.safe_load((CONFIGS / "rlzoo_vertical.yml").read_text())[ENV]
    ours = yaml.safe_load((CONFIGS / "ppo_vertical.yaml").read_text())[ENV]
    kwargs = dict(zoo.pop("policy_kwargs"))
    assert kwargs == {"net_arch": [64, 64], "log_std_init": -1.0}
    assert ours["policy_kwargs"]["activation_fn"] == "tanh"  # SB3's default for MlpPolicy
    assert zoo == {k: ours[k] for k in zoo}


def test_rlzoo_trains_a_few_hundred_steps_on_the_shipped_config(tmp_path):
    cmd = [
        sys.executable,
        "-m",
        "rl_zoo3.train",
        "--algo",
        "ppo",
        "--gym-packages",
        "railgym",
        "--env",
        ENV,
        "-conf",
        str(CONFIGS / "rlzoo_vertical.yml"),
        "-n",
        "256",
        "--seed",
        "1",
        "-params",
        "n_envs:2",
        "--eval-freq",
        "128",
        "--eval-episodes",
        "1",
        "--n-eval-envs",
        "1",
        "--eval-env-kwargs",
        "backend:'reference'",
        "duration:0.5",
        "-f",
        str(tmp_path),
    ]
    done = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    run = tmp_path / "ppo" / "railgym-VerticalSuspension-v3_1"
    assert (run / "railgym-VerticalSuspension-v3.zip").is_file()
    saved = (run / ENV.replace("/", "-") / "config.yml").read_text()  # not plain YAML
    assert "surrogate" in saved and "n_steps" in saved
    evals = np.load(run / "evaluations.npz")
    assert evals["timesteps"].tolist() == [128, 256]
    assert np.all(evals["ep_lengths"] == 50)  # the evaluation env's 0.5 s at control_dt 0.01 s
    # and railgym evaluate takes rl-zoo3's model as it is (--trust: rl-zoo3 writes no manifest)
    from agents.commands.cli import main

    argv = ["evaluate", str(run / "railgym-VerticalSuspension-v3.zip"), "--trust", "--quiet"]
    with pytest.warns(UserWarning, match="--trust"):
        assert main([*argv, "--backend", "linear", "--episodes", "1", "--track-class", "6"]) == 0
