"""The pairs of sources that name the same quantity (docs/cli.md, *When two sources name the
same quantity*) not tested elsewhere: each agrees, or the explicit value wins with a note, or
the combination is an error."""

from __future__ import annotations

import warnings
from pathlib import Path

import gymnasium as gym
import pytest
import yaml

from agents.commands.benchmark import build_parser as benchmark_parser
from agents.training.train import train
from agents.training.train_config import load_config
from railgym.wrappers import ReferenceShadow, RideComfort

ENV_ID = "railgym/VerticalSuspension-v1"
TINY = {
    "algo": "ppo",
    "n_timesteps": 64,
    "n_envs": 1,
    "seed": 3,
    "n_steps": 32,
    "batch_size": 32,
    "n_epochs": 1,
    "eval_freq": 1000,
    "n_eval_episodes": 1,
    "env_kwargs": {"duration": 1.0},
}


def _make(**kwargs: object) -> gym.Env:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return gym.make(ENV_ID, **kwargs)


def test_shadow_vehicle_must_be_the_wrapped_envs(tmp_path: Path) -> None:
    car = {"m1": 1800.0, "m2": 8000.0, "k1": 2.4e6, "c1": 3.0e4, "k2": 4.3e5, "c2": 1.7e4}
    path = tmp_path / "my_car.yaml"
    path.write_text(yaml.safe_dump({"vehicle": {**car, "gravity": 9.81}}))
    with pytest.raises(ValueError, match="differs from the wrapped env's vehicle"):
        ReferenceShadow(_make(), reference_backend="linear", vehicle=str(path))


def test_ride_comfort_rate_must_be_the_control_rate() -> None:
    with pytest.raises(ValueError, match=r"^fs \(50 Hz\) is not the env's control rate"):
        RideComfort(_make(), fs=50.0)
    assert RideComfort(_make(), fs=100).fs == 100.0  # the same rate, an int for a float


def test_algo_of_the_file_and_the_flag_must_agree(tmp_path: Path) -> None:
    path = tmp_path / "cfg.yaml"
    path.write_text(yaml.safe_dump({ENV_ID: TINY}))
    with pytest.raises(ValueError, match="is 'ppo' in the file but --algo is 'sac'"):
        load_config(path, "sac")
    assert load_config(path, "ppo").algo == "ppo"


def test_benchmark_first_seed_defaults_to_the_configs() -> None:
    """No default replaces the config's seed: ``--seed`` is ``None`` unless given."""
    assert benchmark_parser().parse_args(["ppo_vertical"]).seed is None
    assert benchmark_parser().parse_args(["ppo_vertical", "--seed", "4"]).seed == 4


def test_train_flags_replace_the_config_with_a_note(
    tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    path = tmp_path / "cfg.yaml"
    path.write_text(yaml.safe_dump({ENV_ID: TINY}))
    train(path, tmp_path / "run", total_timesteps=32, progress=True, seed=5)
    err = capsys.readouterr().err
    assert "note: --timesteps 32 replaces the config's n_timesteps: 64" in err
    assert "note: --seed 5 replaces the config's seed: 3" in err
    train(path, tmp_path / "run2", total_timesteps=64, progress=True, seed=3)
    assert "note:" not in capsys.readouterr().err  # the same values: nothing replaced


def test_policy_settings_and_command_flags_must_agree() -> None:
    from agents.commands.flags import with_policy_kwargs

    trained = {"vehicle": "manchester", "backend": "surrogate"}
    with pytest.raises(ValueError, match=r"^policy p\.zip: trained with backend='surrogate'"):
        with_policy_kwargs(trained, {"backend": "reference"}, "p.zip")
    merged = with_policy_kwargs(trained, {"vehicle": "manchester", "speed": 30.0}, "p.zip")
    assert merged == {**trained, "speed": 30.0}
