"""railgym/TrainCrash-v1: checkers, seeding, vector env = singles, physics of the control."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import railgym  # noqa: F401  (registers the environments)
from railgym.envs.crash.env import TrainCrashEnv, TrainCrashVectorEnv, default_surrogate
from railgym.envs.crash.step import STATE_LIMIT
from railgym.vehicles.crash.outputs import PARALLEL_MIN
from railgym.vehicles.crash.reference import simulate_reference
from railgym.vehicles.crash.scenario import load_scenario
from railgym.vehicles.crash.surrogate_model import simulate_surrogate
from railgym.vehicles.crash.zone import absorber_zone_force, zone_force
from tests.envs.test_track_chunks import batch_bytes

ENV_ID = "railgym/TrainCrash-v1"


def _episode(env, action, seed=0):
    """Constant-action episode: (info history, rewards, last info, terminated, observations)."""
    obs, _ = env.reset(seed=seed)
    infos, rewards, observations = [], [], [obs]
    while True:
        obs, r, term, trunc, info = env.step(np.asarray(action, np.float32))
        infos.append(info)
        rewards.append(r)
        observations.append(obs)
        if term or trunc:
            return infos, np.array(rewards), info, term, np.array(observations)


@pytest.fixture(scope="module")
def passive():
    """Passive (action 0) episode of each backend on the paper scenario."""
    out = {}
    for backend in ("reference", "surrogate"):
        out[backend] = _episode(TrainCrashEnv(backend=backend), np.zeros(2))
    return out


@pytest.mark.parametrize("backend", ["surrogate", "reference"])
def test_checkers_pass(backend):
    check_env(gym.make(ENV_ID, backend=backend, render_mode="rgb_array").unwrapped)
    from stable_baselines3.common.env_checker import check_env as sb3_check

    sb3_check(TrainCrashEnv(backend=backend), warn=False)


@pytest.mark.parametrize("backend", ["reference", "surrogate"])
def test_recorder_equals_the_env(backend):
    """simulate_* record with the env's kernel: a passive episode gives the same numbers."""
    sc = load_scenario("paper")
    s = default_surrogate(sc) if backend == "surrogate" else None
    truth = simulate_reference(sc) if s is None else simulate_surrogate(sc, s)
    env = TrainCrashEnv(backend=backend, surrogate=s)
    _, info = env.reset(seed=0)
    np.testing.assert_array_equal(info["force_N"], truth.force[0])
    for k in range(1, truth.t.size):
        _, _, term, trunc, info = env.step(np.zeros(2, np.float32))
        np.testing.assert_array_equal(info["force_N"], truth.force[k])
        np.testing.assert_array_equal(info["crush_m"], truth.crush[k])
        np.testing.assert_array_equal(info["decel_g"], -truth.a[k, :2] / sc.gravity)
        assert info["time"] == pytest.approx(truth.t[k], abs=1e-12)
        if term or trunc:
            break
    assert k >= truth.t.size - 2  # the env's episode ends with the recorded run
    if backend == "reference":  # friction work of the env = the recorded friction energy
        assert info["friction_work_J"] == truth.energy["friction"][k]


def test_absorber_scale_multiplies_the_envelope_only_within_the_stroke():
    z = load_scenario("paper").wall
    args = (
        np.array(z.stroke),
        np.array(z.force),
        len(z.stroke),
        z.fold_amplitude,
        z.fold_wavelength,
        z.unloading_stiffness,
    )
    for d in (0.3, 1.0, 2.0, 2.5):
        f1, dp1 = zone_force(d, 0.0, *args)  # virgin loading: on the envelope
        assert absorber_zone_force(d, 0.0, *args, z.absorber_stroke, 1.0) == (f1, dp1)
        f, dp = absorber_zone_force(d, 0.0, *args, z.absorber_stroke, 1.3)
        expected = 1.3 * f1 if d <= z.absorber_stroke else f1  # the structure is not scaled
        assert f == pytest.approx(expected, rel=1e-12)
        assert dp == pytest.approx(d - f / z.unloading_stiffness, rel=1e-12)


def test_reset_is_deterministic_and_speed_jitter_is_seeded():
    env = TrainCrashEnv(backend="reference", max_duration=0.05)
    a = _episode(env, np.full(2, 0.4), seed=1)[1]
    b = _episode(env, np.full(2, 0.4), seed=2)[1]
    np.testing.assert_array_equal(a, b)  # no randomness without speed_jitter
    env = TrainCrashEnv(backend="reference", max_duration=0.05, speed_jitter=0.1)
    runs = {s: _episode(env, np.full(2, 0.4), seed=s) for s in (1, 1, 2)}
    again = _episode(env, np.full(2, 0.4), seed=1)
    np.testing.assert_array_equal(runs[1][1], again[1])
    assert not np.allclose(runs[1][1], runs[2][1])
    v0 = load_scenario("paper").speed
    for s in (1, 2):
        speed = runs[s][0][0]["initial_speed"]
        assert speed != v0 and abs(speed / v0 - 1) <= 0.1


@pytest.mark.parametrize("max_duration", [2.0, 0.1])  # autoreset after termination / truncation
def test_vector_env_equals_single_envs_with_autoreset(next_step_autoreset, max_duration):
    n, kw = 3, {"backend": "surrogate", "speed_jitter": 0.2, "max_duration": max_duration}
    venv = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point", **kw)
    singles = [TrainCrashEnv(**kw) for _ in range(n)]
    obs_v, info_v = venv.reset(seed=5)
    obs_s = [e.reset(seed=5 + i)[0] for i, e in enumerate(singles)]
    np.testing.assert_array_equal(obs_v, np.stack(obs_s))
    rng = np.random.default_rng(0)
    steps, ends = next_step_autoreset(singles), 0
    for _ in range(900 if max_duration > 1 else 250):
        act = rng.uniform(-1.2, 1.2, (n, 2)).astype(np.float32)
        obs_v, rew_v, term_v, trunc_v, info_v = venv.step(act)
        for i, (o, r, te, tr, info, _) in enumerate(steps.step(act)):
            np.testing.assert_array_equal(obs_v[i], o)
            assert rew_v[i] == r and term_v[i] == te and trunc_v[i] == tr
            np.testing.assert_array_equal(info_v["peak_decel_g"][i], info["peak_decel_g"])
            assert info_v["energy_error"][i] == info["energy_error"]
            ends += te if max_duration > 1 else tr
    assert ends >= n  # every sub-env ended (terminated / truncated) at least once


def test_large_vector_env_on_all_threads_equals_single_envs():
    """From ``PARALLEL_MIN`` sub-envs the vector env steps on all threads; its sub-envs still
    reproduce the single envs (autoreset after truncation included)."""
    n, kw = PARALLEL_MIN, {"backend": "surrogate", "speed_jitter": 0.2, "max_duration": 0.05}
    venv = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point", **kw)
    watched = (0, 77, n - 1)
    singles = {i: TrainCrashEnv(**kw) for i in watched}
    obs_v, _ = venv.reset(seed=5)
    for i, e in singles.items():
        np.testing.assert_array_equal(obs_v[i], e.reset(seed=5 + i)[0])
    rng = np.random.default_rng(0)
    done = dict.fromkeys(watched, False)
    for _ in range(120):
        act = rng.uniform(-1.2, 1.2, (n, 2)).astype(np.float32)
        obs_v, rew_v, term_v, trunc_v, _ = venv.step(act)
        for i, e in singles.items():
            if done[i]:
                o, r, te, tr = e.reset()[0], 0.0, False, False
            else:
                o, r, te, tr, _ = e.step(act[i])
            np.testing.assert_array_equal(obs_v[i], o)
            assert rew_v[i] == r and term_v[i] == te and trunc_v[i] == tr
            done[i] = te or tr


def test_16384_sub_envs_fit_in_1_gib_and_reset_all_at_once():
    """Issue 32's size: 16384 trains hold well under 1 GiB of arrays; a reset of all of them
    (one compiled call for their first-contact outputs) gives each the single env's start."""
    n = 16384
    venv = gym.make_vec(
        ENV_ID, num_envs=n, vectorization_mode="vector_entry_point", speed_jitter=0.2
    )
    obs, _ = venv.reset(seed=11)
    assert batch_bytes(venv.unwrapped.sim) <= 2**30
    for i in (0, 9000, n - 1):
        np.testing.assert_array_equal(obs[i], TrainCrashEnv(speed_jitter=0.2).reset(seed=11 + i)[0])
    assert len(np.unique(venv.unwrapped.sim.speed)) > n // 2  # each train its own speed
    venv.close()


def test_bad_actions_raise_and_large_actions_are_clipped():
    env = TrainCrashEnv(backend="reference", max_duration=0.02)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="finite"):
        env.step(np.array([0.0, np.nan], np.float32))
    with pytest.raises(ValueError, match="shape"):
        env.step(np.zeros(3, np.float32))
    a = _episode(env, [5.0, -7.0])
    b = _episode(env, [1.0, -1.0])
    np.testing.assert_array_equal(a[1], b[1])
    assert a[2]["absorber_scale"] == pytest.approx([1.3, 0.7])
    venv = gym.make_vec(ENV_ID, num_envs=2, vectorization_mode="vector_entry_point")
    venv.reset(seed=0)
    with pytest.raises(ValueError, match="finite"):
        venv.step(np.array([[0, 0], [np.inf, 0]], np.float32))


def test_absorber_force_is_rate_limited():
    env = TrainCrashEnv(backend="surrogate", absorber_rate=20.0, max_duration=0.03)
    infos = _episode(env, [1.0, -1.0])[0]
    scale = np.array([i["absorber_scale"] for i in infos])
    k = np.arange(1, len(infos) + 1)
    np.testing.assert_allclose(scale[:, 0], np.minimum(1 + 0.02 * k, 1.3), rtol=1e-12)
    np.testing.assert_allclose(scale[:, 1], np.maximum(1 - 0.02 * k, 0.7), rtol=1e-12)


def test_bad_scenario_file_and_arguments_name_the_field(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text(
        "crash:\n  base: paper\n  name: bad\n  zones:\n    wall:\n"
        "      force_kN: [600, -5, 600, 2200, 2200, 3000, 3000]\n"
    )
    with pytest.raises(ValueError, match=r"crash\.zones\.wall\.force_kN\[1\]"):
        gym.make(ENV_ID, scenario=str(bad))
    for kwargs, field in [
        ({"backend": "fe"}, "backend"),
        ({"control_dt": -1.0}, "control_dt"),
        ({"absorber_range": 1.5}, "absorber_range"),
        ({"n_cars": 0}, "n_cars"),
        ({"reward_weights": {"comfort": 1}}, "reward_weights"),
        ({"speed": float("nan")}, "speed"),
        ({"surrogate": "x"}, "surrogate"),
        ({"scenario": "nowhere"}, "scenario"),
    ]:
        with pytest.raises(ValueError, match=field):
            TrainCrashEnv(**kwargs)


def test_passive_energy_accounting_on_the_reference(passive):
    _, _, info, term, obs = passive["reference"]
    e0 = load_scenario("paper").kinetic_energy
    absorbed = info["absorbed_energy_J"].sum()
    # what is left: the rebound's kinetic energy and carbody/coupler damping (< 1 % of E0)
    assert term and absorbed == pytest.approx(e0 - info["friction_work_J"], rel=0.01)
    assert abs(info["energy_error"]) < 1e-6
    # friction: f_c g times the sum over cars of mass × distance travelled (x: obs[0:2] m)
    sc = load_scenario("paper")
    distance = np.abs(np.diff(obs[:, :2], axis=0)).sum(axis=0)
    assert info["friction_work_J"] == pytest.approx(
        sc.friction * sc.gravity * (sc.car_masses * distance).sum(), rel=0.01
    )


def test_passive_episode_on_both_backends_agrees(passive):
    ref, sur = passive["reference"][2], passive["surrogate"][2]
    for key, rel in (("max_crush_m", 0.2), ("mean_decel_g", 0.1), ("peak_decel_g", 0.2)):
        np.testing.assert_allclose(sur[key], ref[key], rtol=rel)
    for info in (ref, sur):  # the paper design: absorbers nearly used up, no intrusion
        assert 0.85 < info["stroke_used"][0] < 1.0 and not info["stroke_exceeded"]
        np.testing.assert_allclose(info["stroke_used"], info["max_crush_m"] / [2.05, 1.73])


@pytest.mark.parametrize("backend", ["reference", "surrogate"])
def test_stiffer_absorbers_decelerate_harder_and_crush_less(backend):
    env = TrainCrashEnv(backend=backend)
    stiff = _episode(env, np.ones(2))[2]
    soft = _episode(env, -np.ones(2))[2]
    assert np.all(stiff["peak_decel_g"] > soft["peak_decel_g"])
    assert np.all(stiff["mean_decel_g"] > soft["mean_decel_g"])
    assert np.all(stiff["max_crush_m"] < soft["max_crush_m"])
    assert soft["stroke_exceeded"] and not stiff["stroke_exceeded"]


def test_info_decelerations_agree_with_the_recorded_accelerations():
    env = TrainCrashEnv(backend="reference")
    obs, _ = env.reset(seed=0)
    rng = np.random.default_rng(3)
    decel, a_obs, rewards = [], [], []
    while True:
        obs, r, term, trunc, info = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
        decel.append(info["decel_g"])
        a_obs.append(obs[4:6] * env.obs_scale[4:6])
        rewards.append(r)
        if term or trunc:
            break
    decel, a_obs = np.array(decel), np.array(a_obs)
    np.testing.assert_allclose(-a_obs / 9.81, decel, rtol=1e-6)  # float32 observation
    np.testing.assert_array_equal(info["peak_decel_g"], decel.max(axis=0))
    np.testing.assert_allclose(info["mean_decel_g"], decel.mean(axis=0), rtol=1e-12)
    # the mean deceleration is the velocity change over the crash (to the sampling error)
    dv = info["initial_speed"] - obs[2:4] * env.obs_scale[2:4]
    np.testing.assert_allclose(info["mean_decel_g"], dv / (9.81 * info["time"]), rtol=0.02)
    # reward: time-integrated deceleration cost plus intrusion cost (mm), weights 1
    intrusion = 1e3 * np.maximum(info["max_crush_m"] - [2.05, 1.73], 0).sum()
    expected = -((decel / 5.0) ** 2).mean(axis=1).sum() - intrusion
    assert np.sum(rewards) == pytest.approx(expected, rel=1e-9)


def test_divergence_freezes_and_terminates_without_nan():
    env = TrainCrashEnv(backend="reference")
    env.reset(seed=0)
    env.step(np.zeros(2, np.float32))
    env.unwrapped.sim.state[1][0] = 2 * STATE_LIMIT  # every node beyond the guard
    obs, r, term, trunc, info = env.step(np.zeros(2, np.float32))
    assert term and info["diverged"] and r == -100.0
    assert np.all(np.isfinite(obs)) and np.all(np.isfinite(info["force_N"]))


def test_surrogate_is_cached_or_given_and_render():
    sc = load_scenario("paper")
    assert default_surrogate(sc) is default_surrogate(load_scenario("paper"))
    given = default_surrogate(sc)
    env = TrainCrashEnv(surrogate=given, render_mode="rgb_array", max_duration=0.01)
    env.reset(seed=0)
    env.step(np.zeros(2, np.float32))
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.shape == (300, 800, 3)
    venv = gym.make_vec(
        ENV_ID,
        num_envs=2,
        vectorization_mode="vector_entry_point",
        render_mode="rgb_array",
        n_cars=3,
        backend="reference",
    )
    obs, _ = venv.reset(seed=0)
    assert obs.shape == (2, 18) and venv.action_space.shape == (2, 3)
    assert len(venv.render()) == 2


def test_vector_partial_reset_mask_keeps_the_other_crashes():
    venv = gym.make_vec(
        "railgym/TrainCrash-v1",
        num_envs=2,
        vectorization_mode="vector_entry_point",
        backend="reference",
    )
    venv.reset(seed=0)
    for _ in range(20):
        obs, *_ = venv.step(np.zeros((2, venv.unwrapped.sim.n_zones), np.float32))
    obs_reset, _ = venv.reset(options={"reset_mask": np.array([True, False])})
    np.testing.assert_array_equal(obs_reset[1], obs[1])  # sub-env 1 goes on untouched
    first, _ = TrainCrashEnv(backend="reference").reset(seed=0)
    np.testing.assert_array_equal(obs_reset[0], first)  # sub-env 0 starts its crash again


@pytest.mark.parametrize("backend", ["reference", "surrogate"])
@pytest.mark.parametrize("steps_before", [0, 40])  # copied at reset and mid-episode
def test_copies_continue_exactly_like_the_original(copy_env, backend, steps_before):
    env = TrainCrashEnv(backend=backend, speed_jitter=0.1)
    env.reset(seed=3)
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, (steps_before + 60, 2)).astype(np.float32)
    for a in actions[:steps_before]:
        env.step(a)
    twin = copy_env(env)
    for a in actions[steps_before:]:
        want, got = env.step(a), twin.step(a)
        np.testing.assert_array_equal(got[0], want[0])
        assert got[1:4] == want[1:4]
        np.testing.assert_array_equal(got[4]["force_N"], want[4]["force_N"])
    assert not want[2]  # still in the crash: the copies did not end early


def test_vector_env_copies_continue_exactly_like_the_original(copy_env):
    venv = TrainCrashVectorEnv(num_envs=3, backend="surrogate", speed_jitter=0.2, max_duration=0.1)
    venv.reset(seed=1)
    rng = np.random.default_rng(2)
    actions = rng.uniform(-1, 1, (150, 3, 2)).astype(np.float32)
    for a in actions[:30]:
        venv.step(a)
    twin = copy_env(venv)
    for a in actions[30:]:  # across the autoresets at truncation
        want, got = venv.step(a), twin.step(a)
        for g, w in zip(got[:4], want[:4], strict=True):
            np.testing.assert_array_equal(g, w)
        np.testing.assert_array_equal(got[4]["peak_decel_g"], want[4]["peak_decel_g"])
