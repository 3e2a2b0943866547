"""Training over the operating envelope: per-episode track class and speed of every sub-env."""

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

from agents.training.envelope import Envelope, EnvelopeVectorEnv, check_envelope
from agents.training.train import GymVecToSB3, train
from agents.training.train_config import load_config
from railgym import _checks as val
from railgym.track import class_speed


def cases(env_id, envelope, seed, n=4, episodes=6, **kw):
    """(track class, speed m/s) of each sub-env for each episode, and the final observations."""
    venv = gym.make_vec(
        env_id, num_envs=n, vectorization_mode="vector_entry_point", duration=0.03, **kw
    )
    env = EnvelopeVectorEnv(venv, envelope)
    env.reset(seed=seed)
    base = venv.unwrapped
    seen = [list(zip(base.sim.track_class.tolist(), base.sim.speed.tolist(), strict=True))]
    finals = []
    for _ in range(episodes * 3):
        _, _, term, trunc, info = env.step(np.zeros((n, *venv.single_action_space.shape)))
        if np.any(term | trunc):
            assert np.all(info["_final_obs"] == (term | trunc))
            finals.append(info["final_obs"].copy())
            seen.append(
                list(zip(base.sim.track_class.tolist(), base.sim.speed.tolist(), strict=True))
            )
    return seen, finals


def test_every_sub_env_draws_its_class_and_speed_per_episode():
    env_id = "railgym/VerticalSuspension-v1"
    envelope = Envelope((4, 5, 6), (100.0, 180.0))
    seen, finals = cases(env_id, envelope, seed=3, backend="linear")
    flat = [c for episode in seen for c in episode]
    assert {tc for tc, _ in flat} == {4, 5, 6}
    speeds = np.array([v for _, v in flat]) * 3.6
    assert np.all((speeds >= 100.0) & (speeds <= 180.0)) and len(set(speeds)) == len(speeds)
    assert len(finals) == 6
    again, _ = cases(env_id, envelope, seed=3, backend="linear")
    other, _ = cases(env_id, envelope, seed=4, backend="linear")
    assert again == seen and other != seen
    # no speed range: each class's maximum passenger speed
    seen, _ = cases(env_id, Envelope((4, 6), None), seed=0, backend="linear")
    assert all(v == pytest.approx(class_speed(tc)) for ep in seen for tc, v in ep)


def test_vehicle_envelope_and_sb3_adapter():
    env_id = "railgym/VerticalVehicle-v1"
    envelope = Envelope((4, 5), (60.0, 200.0))
    seen, _ = cases(env_id, envelope, seed=1, backend="linear")
    flat = [c for episode in seen for c in episode]
    assert {tc for tc, _ in flat} == {4, 5}
    speeds = np.array([v for _, v in flat]) * 3.6
    assert np.all((speeds >= 60.0) & (speeds <= 200.0))
    venv = gym.make_vec(
        env_id, num_envs=2, vectorization_mode="vector_entry_point", backend="linear", duration=0.03
    )
    sb3 = GymVecToSB3(EnvelopeVectorEnv(venv, envelope, seed=0))
    sb3.reset()
    for _ in range(3):
        sb3.step_async(np.zeros((2, 2), np.float32))
        obs, _, dones, infos = sb3.step_wait()
    assert dones.all() and all("terminal_observation" in i for i in infos)
    assert not np.allclose(obs, infos[0]["terminal_observation"])


def test_config_envelope_is_checked_and_trains(tmp_path):
    path = Path(__file__).parents[3] / "railgym" / "configs" / "agents" / "ppo_vertical.yaml"
    cfg = yaml.safe_load(path.read_text())
    (env_id,) = cfg  # the packaged config's env: the newest version
    assert env_id == "railgym/VerticalSuspension-v3"
    block = cfg[env_id]
    assert check_envelope(block["envelope"]).track_class == (4, 5, 6)
    for bad, field in (
        ({"track_class": [7]}, "envelope.track_class"),
        ({"track_class": [5], "speed_kmh": [200, 100]}, "envelope.speed_kmh"),
        ({"track_class": [5], "speed": [1, 2]}, "envelope"),
    ):
        with pytest.raises(val.FieldError, match=field):
            load_config({env_id: {**block, "envelope": bad}})
    with pytest.raises(val.FieldError, match="envelope"):
        load_config(
            {
                "railgym/TrainCrash-v1": {
                    "algo": "ppo",
                    "n_timesteps": 1,
                    **{"envelope": {"track_class": [5]}},
                }
            }
        )
    tiny = {
        **block,
        "n_timesteps": 256,
        "n_envs": 4,
        "n_steps": 32,
        "batch_size": 64,
        "n_epochs": 1,
        "eval_freq": 10**6,
        "n_eval_episodes": 1,
        "env_kwargs": {**block["env_kwargs"], "backend": "linear", "duration": 0.2},
        "eval_env_kwargs": {"backend": "linear", "duration": 0.2},
    }
    out = train({"railgym/VerticalSuspension-v1": tiny}, tmp_path / "run", progress=False)
    saved = yaml.safe_load((out / "config.yaml").read_text())["railgym/VerticalSuspension-v1"]
    assert saved["envelope"] == block["envelope"]
