"""Residual policies (agents.controllers.residual): the summed action, the controller's state across
episode ends in training, the zip loaded as controller + network, and the config checks."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from agents.controllers.lqg import LQG, VehicleLQG
from agents.controllers.registry import ENV_ID, VEHICLE_ID
from agents.controllers.residual import ResidualPolicy, ResidualVectorEnv, residual_action
from agents.evaluation.runs import run_policy
from agents.training.envelope import EnvelopeVectorEnv, check_envelope
from agents.training.train_config import load_config
from railgym import _checks as val

#: 5 control steps per episode on the linear backend
SHORT = {"backend": "linear", "duration": 0.05, "observation": "sensors"}


def _native(env_id: str, n: int, **kwargs):
    return gym.make_vec(env_id, n, vectorization_mode="vector_entry_point", **kwargs)


finite = st.floats(-3.0, 3.0, allow_nan=False)


@given(base=finite, agent=finite, scale=st.floats(0.01, 2.0))
def test_summed_action_is_the_clipped_sum(base, agent, scale):
    out = float(residual_action(np.array([base]), np.array([agent]), scale)[0])
    expected = np.clip(base + scale * np.clip(agent, -1, 1), -1, 1)
    assert out == pytest.approx(expected, abs=1e-6)
    assert -1.0 <= out <= 1.0


class _Zero:
    """Policy whose action is 0 (the residual of the controller alone)."""

    def predict(self, obs, deterministic=True):
        return np.zeros((np.shape(obs)[0], 1), np.float32), None


def test_zero_residual_is_the_lqg_on_the_reference():
    """The evaluation side: a policy that outputs 0 added to the LQG reproduces the LQG's
    comfort indices exactly (same tracks, the LQG built per run as the baseline is)."""
    kwargs = {"backend": "reference", "track_class": 5, "duration": 4.0}
    lqg = run_policy(lambda env: LQG(env), kwargs, 3, 1000)
    res = run_policy(lambda env: ResidualPolicy(_Zero(), LQG(env), 0.5), kwargs, 3, 1000)
    assert res == lqg
    assert lqg["a_w"] > 0


def _lqg_by_hand(venv, steps: int, seed: int) -> list[np.ndarray]:
    """Observations of ``venv`` under a fresh LQG whose estimate is reset (``episode_start``)
    at the first observation of every episode, as in the env's NEXT_STEP autoreset."""
    ctrl = LQG(venv)
    obs, _ = venv.reset(seed=seed)
    start = np.ones(venv.num_envs, bool)
    ended = np.zeros(venv.num_envs, bool)
    seen = [obs]
    for _ in range(steps):
        action, _ = ctrl.predict(obs, episode_start=start)
        obs, _, term, trunc, _ = venv.step(action)
        start, ended = ended, term | trunc
        seen.append(obs)
    return seen


def test_training_wrapper_with_zero_actions_is_the_lqg_across_autoresets():
    """The training side: zero agent actions through ``ResidualVectorEnv`` give the same
    observations as the LQG stepped by hand over three episodes (NEXT_STEP autoreset, the
    estimate put back at rest at each new episode)."""
    expected = _lqg_by_hand(_native(ENV_ID, 2, **SHORT), 17, 4)
    env = _native(ENV_ID, 2, **SHORT)
    venv = ResidualVectorEnv(env, LQG(env), 1.0)
    obs, _ = venv.reset(seed=4)
    seen = [obs]
    for _ in range(17):
        obs, *_ = venv.step(np.zeros((2, 1), np.float32))
        seen.append(obs)
    for k, (a, b) in enumerate(zip(seen, expected, strict=True)):
        np.testing.assert_array_equal(a, b, err_msg=f"step {k}")


def test_estimate_restarts_with_each_envelope_episode():
    """SAME_STEP autoreset (the envelope): after an episode end the controller's estimate of
    that sub-env is at rest again before it sees the new episode's first observation."""
    env = _native(ENV_ID, 2, **SHORT)
    envelope = EnvelopeVectorEnv(env, check_envelope({"track_class": [4, 6]}), 0)
    ctrl = LQG(env)
    venv = ResidualVectorEnv(envelope, ctrl, 1.0)
    venv.reset(seed=1)
    starts = []
    original = ctrl.predict

    def spy(obs, episode_start=None, **kw):
        starts.append(np.array(episode_start))
        return original(obs, episode_start=episode_start, **kw)

    ctrl.predict = spy
    for _ in range(11):
        venv.step(np.zeros((2, 1), np.float32))
    # steps 0, 5, 10 see a first observation (5 steps per episode)
    assert [bool(s.all()) for s in starts] == [k % 5 == 0 for k in range(11)]


def test_agent_action_moves_the_force_by_scale():
    """A constant agent action ``a`` shifts the first applied force by ``scale·a·f_max``."""
    forces = []
    for a in (0.0, 0.4):
        env = _native(ENV_ID, 1, **SHORT)
        venv = ResidualVectorEnv(env, LQG(env), 0.5)
        venv.reset(seed=2)
        _, _, _, _, info = venv.step(np.full((1, 1), a, np.float32))
        forces.append(float(info["actuator_force"][0]))
    f_max = env.unwrapped.cfg.f_max
    assert forces[1] - forces[0] == pytest.approx(0.5 * 0.4 * f_max, rel=1e-5)


def test_vehicle_lqg_is_a_residual_base():
    env = _native(VEHICLE_ID, 2, backend="linear", duration=0.05)
    venv = ResidualVectorEnv(env, VehicleLQG(env), 0.5)
    venv.reset(seed=0)
    obs, reward, *_ = venv.step(np.zeros((2, 2), np.float32))
    assert obs.shape == (2, env.single_observation_space.shape[0])
    assert np.all(np.isfinite(reward))


def test_lq_preview_is_a_residual_base_with_zero_residual_its_own_action():
    """``residual: lq-preview`` (ppo_vehicle_preview): a zero agent action applies exactly the
    LQ preview controller's forces, preview channels included."""
    from agents.controllers.registry import build_controller

    kwargs = {"backend": "linear", "duration": 0.05, "preview": 21.56}
    env = _native(VEHICLE_ID, 2, **kwargs)
    venv = ResidualVectorEnv(env, build_controller(VEHICLE_ID, "lq-preview", env), 0.5)
    ref = _native(VEHICLE_ID, 2, **kwargs)
    ctrl = build_controller(VEHICLE_ID, "lq-preview", ref)
    obs, _ = venv.reset(seed=3)
    ref_obs, _ = ref.reset(seed=3)
    start = np.ones(2, np.bool_)
    for _ in range(4):
        action, _ = ctrl.predict(ref_obs, episode_start=start)
        start[:] = False
        ref_obs, *_ = ref.step(np.clip(action, -1.0, 1.0).astype(np.float32))
        obs, *_ = venv.step(np.zeros((2, 2), np.float32))
        np.testing.assert_array_equal(obs, ref_obs)


def test_clipped_lqg_is_a_residual_base_clipped_to_the_command_range():
    """``residual: clipped-lqg`` (ppo_vertical_semiactive): the sum is clipped to the damper's
    command range [0, 1], whatever the agent's action."""
    from agents.controllers.registry import build_controller

    env = _native(ENV_ID, 2, **SHORT, actuator="semi-active")
    venv = ResidualVectorEnv(env, build_controller(ENV_ID, "clipped-lqg", env), 2.0)
    venv.reset(seed=0)
    for a in (1.0, -1.0):
        _, reward, *_ = venv.step(np.full((2, 1), a, np.float32))
        assert np.all(np.isfinite(reward))
    assert tuple(venv._bounds[0]) == (0.0,) and tuple(venv._bounds[1]) == (1.0,)
    for cfg in ("ppo_vehicle_preview", "ppo_vertical_semiactive"):
        assert load_config(cfg).residual in ("lq-preview", "clipped-lqg")


BLOCK = {"algo": "ppo", "n_timesteps": 64, "residual": "lqg"}


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"residual": "mpc"}, "residual"),
        ({"residual": 3}, "residual"),
        ({"residual_scale": 0.0}, "residual_scale"),
        ({"residual_scale": 2.5}, "residual_scale"),
        ({"residual_scale": "big"}, "residual_scale"),
        ({"action_hold": 2}, "residual"),
        ({"vectorization_mode": "sync"}, "residual"),
    ],
)
def test_config_rejects_a_bad_residual(change, match):
    with pytest.raises(val.FieldError, match=match):
        load_config({ENV_ID: {**BLOCK, **change}})


def test_crash_env_has_no_residual_controller():
    with pytest.raises(val.FieldError, match="residual"):
        load_config({"railgym/TrainCrash-v1": BLOCK})


def test_trained_residual_zip_loads_as_controller_plus_network(tmp_path, tiny_ppo_block):
    """A tiny residual run: training with ``observation: full`` and an ``lqg`` base is one
    error naming ``residual``; with sensors the saved zip loads (by path) as the LQG plus the
    network, and the FMU export holds that LQG (its training case's design)."""
    pytest.importorskip("stable_baselines3")
    from agents.policies.loading import load_policy
    from agents.policies.policy_fmu import export_policy
    from agents.training.train import train

    full = {"backend": "linear", "duration": 1.0, "observation": "full"}
    block = tiny_ppo_block(**BLOCK, n_steps=32, residual_scale=0.5, env_kwargs=full)
    with pytest.raises(val.FieldError, match="residual lqg: observation must be 'sensors'"):
        train({ENV_ID: block}, tmp_path / "full", progress=False)
    block["env_kwargs"] = {**block["env_kwargs"], "observation": "sensors"}
    out = train({ENV_ID: block}, tmp_path / "res", progress=False)
    factory, kwargs, _ = load_policy(str(out / "model.zip"), ENV_ID)
    env = _native(ENV_ID, 1, **kwargs, backend="linear", duration=1.0)
    ctrl = factory(env)
    assert isinstance(ctrl, ResidualPolicy) and isinstance(ctrl.controller, LQG)
    assert ctrl.scale == 0.5
    obs, _ = env.reset(seed=0)
    base = LQG(env).predict(obs)[0]
    net = ctrl.policy.predict(obs, deterministic=True)[0]
    np.testing.assert_allclose(ctrl.predict(obs)[0], np.clip(base + 0.5 * net, -1, 1), atol=1e-6)
    # on another case the controller keeps the training case's design (class 5 by default)
    class4 = _native(ENV_ID, 1, **kwargs, backend="linear", duration=1.0, track_class=4)
    kept = factory(class4).controller.kf.M
    np.testing.assert_array_equal(kept, ctrl.controller.kf.M)
    assert not np.allclose(kept, LQG(class4).kf.M)
    # the FMU holds the training case's design (closed loop: test_policy_fmu_residual.py)
    import json
    import shutil
    import zipfile

    if shutil.which("cc") or shutil.which("gcc"):
        fmu, _ = export_policy(out / "model.zip", tmp_path / "res.fmu")
        with zipfile.ZipFile(fmu) as zf:
            doc = json.loads(zf.read("resources/policy.json"))
        assert doc["residual"]["name"] == "lqg" and doc["residual"]["scale"] == 0.5
        np.testing.assert_array_equal(doc["residual"]["m"], kept)
