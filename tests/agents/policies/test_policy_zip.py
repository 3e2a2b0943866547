"""``railgym evaluate`` of any SB3 zip: agents.training.train checkpoints, rl-zoo3 runs, bare zips;
and agents.training.train reading rl-zoo3's hyperparameter format (issue 21 item 4)."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

import railgym  # noqa: F401  (registers the environments)
from agents.commands.cli import main
from agents.controllers.registry import ENV_ID
from agents.evaluation.runs import evaluate_vehicle
from agents.policies.loading import load_policy
from agents.policies.policy_zip import find_source, read_zoo_yaml, zip_network

pytest.importorskip("stable_baselines3")
import torch  # noqa: E402
from stable_baselines3 import PPO, SAC  # noqa: E402

from agents.training.train import train  # noqa: E402
from agents.training.train_config import load_config  # noqa: E402

RLZOO_FILE = Path(__file__).parents[3] / "railgym" / "configs" / "agents" / "rlzoo_vertical.yml"
#: rl-zoo3's layout of ``python -m rl_zoo3.train --algo ppo --env ENV -f LOG``
ZOO_DIR = ENV_ID.replace("/", "-")


def _observations(env_kwargs, n=40, seed=0):
    """Observations of a short seeded rollout (realistic inputs for the networks)."""
    env = gym.make(ENV_ID, **env_kwargs)
    obs, _ = env.reset(seed=seed)
    out = [obs]
    rng = np.random.default_rng(seed)
    for _ in range(n - 1):
        obs, *_ = env.step(rng.uniform(-1, 1, 1).astype(np.float32))
        out.append(obs)
    return np.array(out)


def _same_actions(factory, model, env_kwargs):
    """The rebuilt network acts as SB3's own model on the same observations."""
    obs = _observations(env_kwargs)
    venv = gym.make_vec(ENV_ID, 1, vectorization_mode="vector_entry_point", **env_kwargs)
    ours, _ = factory(venv).predict(obs, deterministic=True)
    theirs, _ = model.predict(obs, deterministic=True)
    np.testing.assert_allclose(ours, theirs, rtol=1e-6, atol=1e-7)


def _zoo_yaml(pairs: dict) -> str:
    """rl-zoo3's way of saving args.yml / config.yml: an OrderedDict with its Python tag."""
    import collections

    class Dumper(yaml.Dumper):
        pass

    return yaml.dump(collections.OrderedDict(sorted(pairs.items())), Dumper=Dumper)


def test_bare_zip_algorithm_and_network_from_its_data(tmp_path):
    """A zip with nothing beside it (no config, no manifest: --trust): PPO with a ReLU net
    and SAC, read from the zip's JSON data; the rebuilt nets act as SB3's."""
    env = gym.make(ENV_ID, duration=0.5)
    kw = {"net_arch": [16, 8], "activation_fn": torch.nn.ReLU, "log_std_init": -0.5}
    ppo = PPO("MlpPolicy", env, n_steps=16, batch_size=16, policy_kwargs=kw, seed=1)
    sac = SAC("MlpPolicy", env, policy_kwargs={"net_arch": [8]}, seed=2)
    for name, model, algo in (("ppo", ppo, "ppo"), ("sac", sac, "sac")):
        folder = tmp_path / name
        folder.mkdir()
        model.save(folder / "policy.zip")
        got_algo, policy, kwargs, shape = zip_network(folder / "policy.zip")
        assert (got_algo, policy, shape) == (algo, "MlpPolicy", env.observation_space.shape)
        if name == "ppo":
            assert kwargs == {"net_arch": [16, 8], "activation_fn": "relu", "log_std_init": -0.5}
        with pytest.raises(ValueError, match="no manifest.json beside it"):
            load_policy(str(folder / "policy.zip"))
        with pytest.warns(UserWarning, match="--trust"):
            factory, env_kwargs, label = load_policy(str(folder / "policy.zip"), trust=True)
        assert env_kwargs == {} and label == f"{name}/policy"
        _same_actions(factory, model, {})


def test_rlzoo_run_folder_gives_the_env_settings(tmp_path, capsys):
    """rl-zoo3's run folder: env id and env_kwargs from args.yml / config.yml (Python tags
    read as mappings), the network from the zip; evaluated by the command with --trust."""
    env_kwargs = {"observation": "full", "duration": 0.5}
    env = gym.make(ENV_ID, **env_kwargs)
    model = PPO("MlpPolicy", env, n_steps=16, batch_size=16, policy_kwargs={"net_arch": [8]})
    run = tmp_path / "ppo" / f"{ZOO_DIR}_1"
    (run / ZOO_DIR).mkdir(parents=True)
    model.save(run / f"{ZOO_DIR}.zip")
    model.save(run / "rl_model_64_steps.zip")
    (run / ZOO_DIR / "args.yml").write_text(
        _zoo_yaml({"algo": "ppo", "env": ENV_ID, "env_kwargs": None, "seed": 1})
    )
    config = {"env_kwargs": env_kwargs, "n_steps": 16, "policy": "MlpPolicy"}
    (run / ZOO_DIR / "config.yml").write_text(_zoo_yaml(config))
    assert (
        "!!python/object/apply:collections.OrderedDict" in (run / ZOO_DIR / "args.yml").read_text()
    )
    source = find_source(run / "rl_model_64_steps.zip")
    assert source.kind == "rl-zoo3" and source.env_id == ENV_ID
    assert source.env_kwargs == env_kwargs
    with pytest.warns(UserWarning, match="--trust"):
        factory, kwargs, label = load_policy(str(run / f"{ZOO_DIR}.zip"), trust=True)
    assert kwargs == {"observation": "full"} and label == f"{ZOO_DIR}_1"
    _same_actions(factory, model, env_kwargs)
    with pytest.warns(UserWarning, match="--trust"):
        code = main(
            ["evaluate", str(run / "rl_model_64_steps.zip"), "--trust"]
            + ["--backend", "linear", "--episodes", "1", "--track-class", "6"]
        )
    assert code == 0
    out = capsys.readouterr().out
    assert f"{ZOO_DIR}_1/rl_model_64_steps" in out
    # the same zip on the vehicle env: its args.yml says it is a VerticalSuspension policy
    with pytest.raises(ValueError, match=f"trained on {ENV_ID}"):
        load_policy(str(run / f"{ZOO_DIR}.zip"), "railgym/VerticalVehicle-v1", trust=True)
    # on another version of its env it is still the run's final model, named by its run
    with pytest.warns(UserWarning, match="runs on railgym/VerticalSuspension-v1"):
        _, _, label = load_policy(
            str(run / f"{ZOO_DIR}.zip"), "railgym/VerticalSuspension-v1", trust=True
        )
    assert label == f"{ZOO_DIR}_1"


def test_rlzoo_yaml_with_other_python_tags_is_refused_and_runs_nothing(tmp_path):
    sentinel = tmp_path / "pwned"
    bad = tmp_path / "args.yml"
    bad.write_text(f"!!python/object/apply:pathlib.Path.touch [{str(sentinel)!r}]\n")
    with pytest.raises(ValueError, match="not an rl-zoo3 settings file"):
        read_zoo_yaml(bad)
    assert not sentinel.exists()


def test_bare_zip_on_other_env_settings_is_a_clear_error(tmp_path):
    env = gym.make(ENV_ID, observation="full", duration=0.5)
    (tmp_path / "alone").mkdir()
    PPO("MlpPolicy", env, n_steps=16, batch_size=16).save(tmp_path / "alone" / "m.zip")
    with (
        pytest.warns(UserWarning, match="--trust"),
        pytest.raises(ValueError, match=r"observations of shape \(8,\), the env gives \(5,\)"),
    ):
        load_policy(str(tmp_path / "alone" / "m.zip"), trust=True)


def test_agents_train_checkpoint_is_evaluated(tmp_path, tiny_ppo_block):
    """runs/NAME/checkpoints/model_N_steps.zip: the run's config.yaml two folders up, and the
    checkpoints' own manifest written by agents.training.train."""
    block = tiny_ppo_block(checkpoint_freq=64, n_steps=32)
    out = train({"railgym/VerticalVehicle-v1": block}, tmp_path / "ppo_vehicle", progress=False)
    checkpoint = out / "checkpoints" / "model_64_steps.zip"
    assert (out / "checkpoints" / "manifest.json").is_file()
    assert find_source(checkpoint).config == out / "config.yaml"
    (row,) = evaluate_vehicle(
        [str(checkpoint)], backend="linear", track_classes=(6,), episodes=1, duration=2.0
    )
    assert row["policy"] == "ppo_vehicle/model_64_steps" and np.all(np.isfinite(row["a_w"]))


# ------------------------------------------------- one hyperparameter format: rl-zoo3's
def test_agents_train_reads_the_rlzoo_file_with_algo():
    zoo = load_config(RLZOO_FILE, algo="ppo")
    ours = load_config("ppo_vertical")
    assert zoo.algo == "ppo" and zoo.env_kwargs == ours.env_kwargs
    same = {k: v for k, v in ours.hyperparameters.items() if k != "policy_kwargs"}
    assert {k: zoo.hyperparameters[k] for k in same} == same
    with pytest.raises(ValueError, match="algo"):
        load_config(RLZOO_FILE)  # rl-zoo3's file names no algorithm
    with pytest.raises(ValueError, match="is 'ppo' in the file but --algo is 'sac'"):
        load_config("ppo_vertical", algo="sac")


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        ({"normalize": True}, "rl-zoo3's 'normalize' is not supported by agents.training.train"),
        ({"policy_kwargs": "dict(net_arch=[8])"}, "policy_kwargs is a Python expression"),
    ],
)
def test_rlzoo_keys_agents_train_cannot_honour_are_errors(extra, message):
    block = {"n_timesteps": 64, "policy": "MlpPolicy", **extra}
    with pytest.raises(ValueError, match=message):
        load_config({ENV_ID: block}, algo="ppo")


def test_agents_train_command_trains_an_rlzoo_file(tmp_path, capsys):
    config = tmp_path / "zoo.yml"
    block = {
        "n_timesteps": 64,
        "policy": "MlpPolicy",
        "n_envs": 1,
        "env_kwargs": {"backend": "linear", "duration": 0.5},
        "n_steps": 64,
        "batch_size": 64,
        "n_epochs": 1,
        "policy_kwargs": {"net_arch": [8]},
    }
    config.write_text(yaml.safe_dump({ENV_ID: block}))
    from agents.commands.train import main as train_main

    argv = [str(config), "--out", str(tmp_path / "run"), "--quiet", "--seed", "0"]
    assert train_main([*argv, "--algo", "ppo"]) == 0
    saved = yaml.safe_load((tmp_path / "run" / "config.yaml").read_text())[ENV_ID]
    assert saved["algo"] == "ppo"  # the resolved config names it: loadable on its own
    factory, _, label = load_policy(str(tmp_path / "run" / "model.zip"))
    assert label == "run"
    capsys.readouterr()
    assert train_main([*argv, "--overwrite"]) == 2
    assert "algo" in capsys.readouterr().err
    assert Path(tmp_path / "run" / "model.zip").is_file()
