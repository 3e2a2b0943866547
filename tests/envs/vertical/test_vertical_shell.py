"""The env shell of the vertical envs: copies, reward terms (also Wk-weighted), accessors, the
"raise" extrapolation policy, bounded outputs under extreme settings, "name or path" loading, the
single env's action check and ``info`` layout."""

from __future__ import annotations

import re

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import signal

from railgym.comfort import WeightingFilter
from railgym.envs.base import _check_small, check_actions
from railgym.envs.batch_base import noisy_obs
from railgym.envs.vertical.batch import REWARD_TERMS
from railgym.envs.vertical.env import (
    ACC_REF,
    INFO_KEYS,
    LIMITS,
    VerticalSuspensionEnv,
    VerticalSuspensionVectorEnv,
)
from railgym.vehicles.vertical.params import load_vehicle


@pytest.mark.parametrize("mid", [0, 37])
def test_single_env_copy_continues_bit_identically(
    continue_copies, mid, random_actions, assert_same_rollouts, step_rows
):
    run = step_rows("carbody_acc")
    env = VerticalSuspensionEnv(duration=0.6, sensor_noise=0.05)
    before = random_actions(mid, (1,), seed=1)
    acts = random_actions(23, (1,), seed=2)  # runs to the end of the 60-step episode (mid=37)
    a, b, twin = continue_copies(env, run, 4, before, acts)
    assert_same_rollouts(a, b)
    assert twin.sim.z is not env.sim.z and twin.sim.obs is twin.sim.res.obs


@pytest.mark.parametrize("mid", [0, 25])
def test_vector_env_copy_continues_bit_identically(
    continue_copies, mid, random_actions, assert_same_rollouts, step_rows
):
    run = step_rows("carbody_acc")
    venv = VerticalSuspensionVectorEnv(num_envs=3, duration=0.3, sensor_noise=0.05)
    before = random_actions(mid, (3, 1), seed=3)
    acts = random_actions(45, (3, 1), seed=4)  # crosses an autoreset
    a, b, _ = continue_copies(venv, run, 9, before, acts)
    assert_same_rollouts(a, b)


@pytest.mark.parametrize("noise", [0.0, 0.05])
def test_one_row_of_the_observations_is_that_row_of_all(noise):
    """The single env's path (``observe(rngs, i)``) gives bit for bit the row ``i`` of the
    vector env's path, the noise drawn from the same generator state."""
    obs = np.random.default_rng(0).normal(size=(3, 5))
    rngs = [np.random.default_rng(s) for s in (7, 8, 9)]
    every = noisy_obs(obs, noise, rngs)
    one = noisy_obs(obs, noise, [np.random.default_rng(8)], 1)
    assert one.dtype == every.dtype == np.float32 and one.shape == (5,)
    np.testing.assert_array_equal(one, every[1])
    assert (noise == 0.0) == bool(np.all(one == obs[1].astype(np.float32)))


def test_reward_terms_sum_to_the_reward_and_follow_the_definition(random_actions):
    w = {"acceleration": 1.5, "deflection": 0.5, "force": 0.2}
    env = VerticalSuspensionEnv(backend="reference", duration=0.5, reward_weights=w)
    env.reset(seed=0)
    for a in random_actions(50, (1,)):
        _, r, *_, info = env.step(a)
        t = info["reward_terms"]
        assert t["acceleration"] + t["deflection"] + t["force"] + t["divergence"] == r
        assert t["acceleration"] == pytest.approx(
            -w["acceleration"] * (info["carbody_acc"] / ACC_REF) ** 2, rel=1e-12
        )
        defl = (env.state[0] - env.state[2]) / env.cfg.free_travel
        assert t["deflection"] == pytest.approx(-w["deflection"] * defl**2, rel=1e-12)
        f = np.clip(a[0], -1, 1)
        assert t["force"] == pytest.approx(-w["force"] * f**2, rel=1e-6)
        assert info["actuator_force"] == env.actuator_force == pytest.approx(8000.0 * f)
        assert t["divergence"] == 0.0


def test_wk_weighted_acceleration_term_is_the_offline_filtered_carbody_acc(random_actions):
    """``acc_weighting="Wk"``: each episode's acceleration terms are −(Wk(ẍ2)/ACC_REF)² of
    the filter run from rest over that episode's ``carbody_acc`` (its state is zeroed at the
    autoreset); everything else is the unweighted env's, bit for bit."""
    kw = {"num_envs": 2, "vectorization_mode": "vector_entry_point", "backend": "linear"}
    venv = gym.make_vec("railgym/VerticalSuspension-v1", duration=0.3, acc_weighting="Wk", **kw)
    raw = gym.make_vec("railgym/VerticalSuspension-v1", duration=0.3, **kw)
    sos = WeightingFilter(1.0 / venv.unwrapped.cfg.control_dt, "Wk", lowpass=False).sos
    venv.reset(seed=6)
    raw.reset(seed=6)
    episodes: list[list[tuple[np.ndarray, np.ndarray]]] = [[]]
    ended = np.zeros(2, bool)
    for a in random_actions(50, (2, 1), seed=8):  # 30 steps per episode: crosses an autoreset
        obs, _, term, trunc, info = venv.step(a)
        obs_raw, *_, info_raw = raw.step(a)
        np.testing.assert_array_equal(obs, obs_raw)
        for key in ("carbody_acc", "rms_carbody_acc", "actuator_force"):
            np.testing.assert_array_equal(info[key], info_raw[key])
        for key in ("deflection", "force"):
            np.testing.assert_array_equal(info["reward_terms"][key], info_raw["reward_terms"][key])
        if ended.any():  # the autoreset step: a new episode follows
            assert ended.all()
            episodes.append([])
        else:
            episodes[-1].append((info["carbody_acc"], info["reward_terms"]["acceleration"]))
        ended = term | trunc
    assert len(episodes) == 2 and len(episodes[1]) > 10
    for episode in episodes:
        acc, terms = (np.array(x) for x in zip(*episode, strict=True))
        want = -((signal.sosfilt(sos, acc, axis=0) / ACC_REF) ** 2)
        np.testing.assert_allclose(terms, want, rtol=1e-9, atol=1e-15)


def test_vector_reward_terms_are_arrays_that_sum_to_the_reward(random_actions):
    venv = VerticalSuspensionVectorEnv(num_envs=4, duration=0.2)
    venv.reset(seed=1)
    for a in random_actions(30, (4, 1)):
        _, r, *_, info = venv.step(a)
        t = info["reward_terms"]
        total = t["acceleration"] + t["deflection"] + t["force"] + t["divergence"]
        np.testing.assert_array_equal(total, r)
        assert info["_reward_terms"].all() and t["_force"].all()
        np.testing.assert_array_equal(venv.carbody_acceleration, info["carbody_acc"])
        # surrogate backend: [x1, v1, x2, v2, s] with the Maxwell state s of the element
        assert venv.state.shape == (4, 5) and venv.actuator_force.shape == (4,)


def test_divergence_term_and_accessors_are_copies():
    env = VerticalSuspensionEnv(backend="linear", duration=1.0)
    env.reset(seed=0)
    s = env.state
    s[0] = 1e6  # a copy: the env is not changed
    _, r, term, _, info = env.step(np.zeros(1, np.float32))
    assert not term
    env.sim.state[0, 0] = 1e6  # beyond the divergence guard
    _, r, term, _, info = env.step(np.zeros(1, np.float32))
    assert term and info["diverged"] and r == -100.0
    assert info["reward_terms"] == {
        "acceleration": 0.0,
        "deflection": 0.0,
        "force": 0.0,
        "divergence": -100.0,
    }


def test_raise_policy_terminates_with_a_flag_and_linear_does_not(box_lpr):
    runs = {}
    for policy in ("raise", "linear"):
        env = VerticalSuspensionEnv(surrogate=box_lpr(policy), track_class=4, duration=2.0)
        env.reset(seed=0)
        for k in range(200):  # noqa: B007 (k is read after the loop)
            _, r, term, trunc, info = env.step(np.ones(1, np.float32))
            if term or trunc:
                break
        runs[policy] = (k, term, info)
    k, term, info = runs["raise"]
    assert term and info["extrapolated"] and info["out_of_domain"] > 0 and k < 199
    k, term, info = runs["linear"]
    assert not term and "extrapolated" not in info and info["out_of_domain"] > 0


def test_extreme_documented_settings_keep_step_finite(random_actions):
    w = {k: LIMITS["reward_weights"] for k in ("acceleration", "deflection", "force")}
    env = VerticalSuspensionEnv(
        backend="linear",
        observation="full",
        duration=1.0,
        sensor_noise=LIMITS["sensor_noise"],
        reward_weights=w,
        f_max=LIMITS["f_max"],
        track_class=1,
        speed=2 * 4.47,
    )
    env.reset(seed=0)
    for a in random_actions(100, (1,), seed=5):
        obs, r, term, trunc, info = env.step(a * 100)
        assert np.all(np.isfinite(obs)) and np.isfinite(r)
        assert all(np.isfinite(v) for v in info["reward_terms"].values())
        if term or trunc:
            break


def test_packaged_name_wins_over_a_folder_or_file_of_that_name(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "manchester").mkdir()
    (tmp_path / "manchester.yml").mkdir()  # a folder with a YAML suffix: not a file
    ref = load_vehicle("manchester")
    assert load_vehicle("manchester") == ref and ref.m2 == 16000.0
    with pytest.raises(ValueError, match="vehicle 'manchester.yml' is a folder, expected a file"):
        load_vehicle("manchester.yml")
    from importlib import resources

    text = resources.files("railgym").joinpath("configs", "vehicles", "manchester.yaml")
    (tmp_path / "mine.yaml").write_text(text.read_text().replace("m2: 16000.0", "m2: 15000.0"))
    assert load_vehicle("mine.yaml").m2 == 15000.0
    with pytest.raises(ValueError, match="unknown vehicle 'mine'"):
        load_vehicle("mine")  # a bare name never reads the working directory


_VALUES = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True, width=64),
    st.sampled_from([-1.0, 1.0, -0.0, 2.0, -0.5, 1e-300]),
)


@settings(max_examples=300, deadline=None)
@given(
    values=st.lists(_VALUES, min_size=1, max_size=3),
    dtype=st.sampled_from([np.float16, np.float32, np.float64]),
    box=st.sampled_from([(-1.0, 1.0), (-0.5, 2.0)]),
)
def test_single_env_action_check_is_check_actions(values, dtype, box):
    """The element-wise check of the single env gives the bits and errors of check_actions."""
    m = len(values)
    with np.errstate(over="ignore"):
        action = np.array(values).astype(dtype)
    low, high = np.full(m, box[0]), np.full(m, box[1])
    out = np.full((1, m), 7.0)
    try:
        expected = check_actions(action, (m,), low, high)
    except ValueError as exc:
        with pytest.raises(ValueError, match=re.escape(str(exc))):
            _check_small(action, (m,), (low.tolist(), high.tolist()), out)
        return
    assert _check_small(action, (m,), (low.tolist(), high.tolist()), out)
    assert out.tobytes() == expected.reshape(1, m).tobytes()


def test_fast_action_check_leaves_other_inputs_to_check_actions():
    out = np.zeros((1, 2))
    bounds = ([-1.0, -1.0], [1.0, 1.0])
    for other in ([0.5, 0.5], np.zeros(2, np.int64), np.zeros(3), np.zeros(2)[None]):
        assert not _check_small(other, (2,), bounds, out)
    assert not out.any()


def test_single_env_info_follows_the_declared_layout_and_the_vector_env(random_actions):
    env = VerticalSuspensionEnv(backend="reference", duration=0.2)
    venv = VerticalSuspensionVectorEnv(num_envs=1, backend="reference", duration=0.2)
    env.reset(seed=3)
    venv.reset(seed=3)
    keys = [k for k, _ in INFO_KEYS]
    infos = []
    for n, a in enumerate(random_actions(20, (1,), seed=7), start=1):
        obs, r, term, trunc, info = env.step(a)
        vobs, vr, vterm, vtrunc, vinfo = venv.step(a[None])
        assert list(info) == [*keys, "reward_terms"]
        for key, kind in INFO_KEYS:
            assert type(info[key]) is kind
            assert info[key] == vinfo[key][0]
        assert tuple(info["reward_terms"]) == REWARD_TERMS
        assert info["reward_terms"] == {k: vinfo["reward_terms"][k][0] for k in REWARD_TERMS}
        assert type(r) is float and r == vr[0] and obs.tobytes() == vobs[0].tobytes()
        assert info["time"] == n * env.cfg.control_dt and trunc is bool(vtrunc[0]) is (n == 20)
        infos.append(info)
    infos[0]["time"] = -1.0  # each step's dict is its own
    assert infos[1]["time"] == 2 * env.cfg.control_dt
