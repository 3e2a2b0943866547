"""agents.training.train_rllib: RLlib PPO on the native vector env (needs the rllib extra; skipped
without it — the main CI environment has no Ray, .ci/rllib.sh runs these in its own)."""

import csv
import json

import numpy as np
import pytest

pytest.importorskip(
    "ray.rllib", reason="needs the rllib extra (own venv: .ci/rllib.sh, docs/scaling.md)"
)
import gymnasium as gym  # noqa: E402
import ray  # noqa: E402

from agents.policies.loading import load_policy  # noqa: E402
from agents.training.train_rllib import (
    RLlibPolicy,
    build_algo_config,
    load_rllib_config,
    load_rllib_policy,
    train_rllib,
    write_checkpoint_manifest,
)

ENV = "railgym/VerticalSuspension-v1"


def _config(**over):
    block = {
        "trainer": "rllib",
        "iterations": 1,
        "seed": 3,
        "num_env_runners": 0,
        "num_envs_per_env_runner": 4,
        "env_kwargs": {"backend": "surrogate", "duration": 2.0},
        "eval_env_kwargs": {"backend": "reference"},
        "n_eval_episodes": 2,
        "training": {"train_batch_size_per_learner": 256, "minibatch_size": 64, "num_epochs": 2},
        "model": {"fcnet_hiddens": [16, 16]},
    }
    return {ENV: {**block, **over}}


@pytest.fixture(scope="module")
def local_ray():
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield
    ray.shutdown()


@pytest.mark.parametrize(
    ("over", "match"),
    [
        ({"trainer": "sb3"}, "trainer must be 'rllib'"),
        ({"algo": "sac"}, "algo must be one of"),
        ({"num_env_runners": -1}, "num_env_runners must be at least 0"),
        ({"seed": 2**40}, "seed must be at most"),
        ({"env_kwargs": [1]}, "env_kwargs"),
        ({"iterations": 0}, "iterations"),
        ({"n_steps": 64}, "unknown keys \\['n_steps'\\]"),
        ({"training": {"learning_rate": 1e-3}}, "training has unknown keys \\['learning_rate'\\]"),
        ({"model": {"net_arch": [64]}}, "model has unknown keys"),
    ],
)
def test_bad_config_names_the_field(over, match):
    with pytest.raises(ValueError, match=match):
        load_rllib_config(_config(**over))


def test_shipped_config_loads():
    cfg = load_rllib_config("railgym/configs/agents/ppo_vertical_rllib.yaml")
    assert cfg.env_kwargs["backend"] == "surrogate"
    assert cfg.eval_env_kwargs["backend"] == "reference"
    build_algo_config(cfg).validate()


def test_checkpoint_round_trip_and_deterministic_action_is_the_mean(local_ray, tmp_path):
    cfg = load_rllib_config(_config())
    from ray.tune.registry import register_env

    from agents.training.train_rllib import RLLIB_ENV, native_vector_env

    register_env(RLLIB_ENV, native_vector_env)
    algo = build_algo_config(cfg).build_algo()
    algo.train()
    space = gym.make(ENV).action_space
    live = RLlibPolicy(algo.get_module(), space)
    checkpoint = tmp_path / "checkpoint"
    algo.save_to_path(str(checkpoint))
    algo.stop()
    write_checkpoint_manifest(checkpoint)
    loaded = load_rllib_policy(checkpoint, ENV)
    obs = np.random.default_rng(0).normal(size=(8, gym.make(ENV).observation_space.shape[0]))
    a_live, _ = live.predict(obs)
    np.testing.assert_array_equal(loaded.predict(obs)[0], a_live)
    factory, _, label = load_policy(str(checkpoint), ENV)  # what railgym evaluate loads
    np.testing.assert_array_equal(factory(None).predict(obs)[0], a_live)
    assert label == "rllib:checkpoint"
    assert a_live.shape == (8, 1) and np.all(np.abs(a_live) <= 1.0)
    # stochastic actions scatter around the deterministic one (the Gaussian mean) where it
    # is inside the bounds
    one = np.repeat(obs[:1], 4000, axis=0)
    samples, _ = loaded.predict(one, deterministic=False)
    if abs(a_live[0, 0]) < 0.5:
        assert abs(np.median(samples) - a_live[0, 0]) < 0.05
    # a changed or added checkpoint file is refused (RLlib checkpoints are pickles)
    (checkpoint / "extra.pkl").write_bytes(b"not from this run")
    with pytest.raises(ValueError, match="differ from those listed"):
        load_rllib_policy(checkpoint, ENV)
    with pytest.warns(UserWarning, match="because of trust"):
        trusted = load_rllib_policy(checkpoint, ENV, trust=True)
    np.testing.assert_array_equal(trusted.predict(obs)[0], a_live)


def test_train_rllib_writes_checkpoint_and_reference_evaluation(local_ray, tmp_path):
    out = train_rllib(_config(), tmp_path / "run")
    assert (out / "checkpoint").is_dir()
    listed = json.loads((out / "manifest.json").read_text())["sha256"]
    assert any(k.endswith("module_state.pt") or "rl_module" in k for k in listed)
    rows = list(csv.DictReader((out / "eval.csv").open()))
    assert len(rows) == 1
    assert float(rows[0]["mean_length"]) == 200.0  # 2 s at control_dt 0.01 s
    assert float(rows[0]["timesteps"]) >= 256
    again = load_rllib_config(out / "config.yaml")  # the resolved config loads again
    assert again.seed == 3 and again.training["minibatch_size"] == 64
    with pytest.raises(ValueError, match="overwrite"):
        train_rllib(_config(), out)
