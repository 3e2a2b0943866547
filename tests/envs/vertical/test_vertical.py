import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import railgym  # noqa: F401  (registers the environments)
from railgym.envs.vertical.env import VerticalSuspensionEnv, VerticalSuspensionVectorEnv

ENV_ID = "railgym/VerticalSuspension-v1"


def _rollout(env, seed, actions):
    obs, _ = env.reset(seed=seed)
    out = [obs]
    for a in actions:
        obs, r, term, trunc, info = env.step(a)
        out.append(np.concatenate([obs, [r, info["carbody_acc"]]]))
        if term or trunc:
            break
    return out


@pytest.mark.parametrize("backend", ["surrogate", "reference", "linear"])
def test_checkers_pass(backend):
    check_env(VerticalSuspensionEnv(backend=backend, duration=1.0), skip_render_check=True)
    from stable_baselines3.common.env_checker import check_env as sb3_check

    sb3_check(VerticalSuspensionEnv(backend=backend, duration=1.0), warn=False)


def test_same_seed_same_episode_other_seed_differs():
    env = gym.make(ENV_ID, duration=2.0)
    acts = [np.array([0.3 * np.sin(0.1 * k)], np.float32) for k in range(200)]
    a = _rollout(env, 7, acts)
    b = _rollout(env, 7, acts)
    c = _rollout(env, 8, acts)
    np.testing.assert_array_equal(np.array(a[1:]), np.array(b[1:]))
    assert not np.allclose(np.array(a[1:]), np.array(c[1:]))


def test_vector_env_equals_single_envs_with_autoreset(next_step_autoreset):
    n, duration = 3, 0.5  # 50 steps per episode: the run crosses one autoreset
    venv = gym.make_vec(
        ENV_ID,
        num_envs=n,
        vectorization_mode="vector_entry_point",
        duration=duration,
        sensor_noise=0.05,
    )
    singles = [VerticalSuspensionEnv(duration=duration, sensor_noise=0.05) for _ in range(n)]
    obs_v, _ = venv.reset(seed=11)
    obs_s = [e.reset(seed=11 + i)[0] for i, e in enumerate(singles)]
    np.testing.assert_array_equal(obs_v, np.stack(obs_s))
    rng = np.random.default_rng(0)
    steps = next_step_autoreset(singles)
    for _ in range(80):
        act = rng.uniform(-1, 1, (n, 1)).astype(np.float32)
        obs_v, rew_v, term_v, trunc_v, info_v = venv.step(act)
        for i, (o, r, te, tr, info, was_reset) in enumerate(steps.step(act)):
            if not was_reset:
                assert info["carbody_acc"] == info_v["carbody_acc"][i]
            np.testing.assert_array_equal(obs_v[i], o)
            assert rew_v[i] == pytest.approx(r, abs=0) and term_v[i] == te and trunc_v[i] == tr
    assert venv.unwrapped.sim.steps.max() < 50  # an autoreset happened


def test_bad_actions_raise_and_large_actions_are_clipped():
    env = VerticalSuspensionEnv(duration=1.0)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="finite"):
        env.step(np.array([np.nan], np.float32))
    with pytest.raises(ValueError, match="shape"):
        env.step(np.zeros(2, np.float32))
    a = _rollout(env, 3, [np.array([5.0])] * 20)
    b = _rollout(env, 3, [np.array([1.0])] * 20)
    np.testing.assert_array_equal(np.array(a[1:]), np.array(b[1:]))


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"backend": "simpack"}, "backend"),
        ({"control_dt": 0.0105}, "control_dt"),
        ({"track_class": 9}, "track_class"),
        ({"speed": -3.0}, "speed"),
        ({"observation": "pixels"}, "observation"),
        ({"reward_weights": {"comfort": 1.0}}, "reward_weights"),
        ({"f_max": float("nan")}, "f_max"),
        ({"acc_weighting": "Wx"}, "acc_weighting"),
    ],
)
def test_bad_arguments_name_the_field(kwargs, message):
    with pytest.raises(ValueError, match=message):
        VerticalSuspensionEnv(**kwargs)


def test_reset_options_change_track_class_and_roughness():
    env = VerticalSuspensionEnv(backend="linear", duration=5.0)
    rms = {}
    for tc in (3, 6):
        env.reset(seed=1, options={"track_class": tc, "speed": 30.0})
        assert env.track_class == tc
        for _ in range(500):
            *_, info = env.step(np.zeros(1, np.float32))
        rms[tc] = info["rms_carbody_acc"]
    assert rms[3] > 2 * rms[6]  # class 3 is far rougher than class 6 at the same speed


def test_passive_reward_is_of_order_one_and_info_keys():
    env = VerticalSuspensionEnv(backend="reference")
    env.reset(seed=0)
    total, n = 0.0, 0
    while True:
        _, r, term, trunc, info = env.step(np.zeros(1, np.float32))
        total, n = total + r, n + 1
        if term or trunc:
            break
    assert trunc and not term and n == 2000 and info["time"] == pytest.approx(20.0)
    assert -3.0 < total / n < -0.3
    assert {"carbody_acc", "out_of_domain", "bump_stop_contacts", "time"} <= set(info)


def test_divergence_terminates_without_nan():
    env = VerticalSuspensionEnv(backend="linear", duration=1.0)
    env.reset(seed=0)
    env.unwrapped.sim.state[0, 0] = 1e6  # beyond the divergence guard
    obs, r, term, trunc, info = env.step(np.zeros(1, np.float32))
    assert term and info["diverged"] and np.all(np.isfinite(obs)) and np.isfinite(r)


def test_rgb_array_render():
    env = VerticalSuspensionEnv(render_mode="rgb_array", duration=1.0)
    env.reset(seed=0)
    env.step(np.ones(1, np.float32))
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3


def test_vector_partial_reset_mask():
    venv = gym.make_vec(ENV_ID, num_envs=3, vectorization_mode="vector_entry_point", duration=1.0)
    venv.reset(seed=5)
    for _ in range(10):
        venv.step(np.full((3, 1), 0.5, np.float32))
    before = venv.unwrapped.sim.state.copy()
    mask = np.array([False, True, False])
    obs, _ = venv.reset(seed=[None, 42, None], options={"reset_mask": mask})
    sim = venv.unwrapped.sim
    np.testing.assert_array_equal(sim.state[~mask], before[~mask])
    assert np.all(sim.state[1] == 0.0) and sim.steps.tolist() == [10, 0, 10]
    single = VerticalSuspensionEnv(duration=1.0)
    np.testing.assert_array_equal(obs[1], single.reset(seed=42)[0])
    np.testing.assert_array_equal(sim.z[1], single.sim.z[0])  # the track of seed 42
    with pytest.raises(ValueError, match="reset_mask"):
        venv.reset(options={"reset_mask": np.zeros(3, bool)})


def _carbody_receptance(p, omega):
    """Analytic X2/Z of the linear 2-DOF model at ω (rad/s), complex."""
    k1, k2 = p.k1 + 1j * omega * p.c1, p.k2 + 1j * omega * p.c2
    a = np.array([[k1 + k2 - p.m1 * omega**2, -k2], [-k2, k2 - p.m2 * omega**2]])
    return np.linalg.solve(a, np.array([k1, 0.0]))[1]


@pytest.mark.parametrize("wavelength", [12.0, 40.0, 90.0])
def test_sine_profile_gives_analytic_steady_state_of_linear_backend(wavelength):
    amp, speed, duration = 2e-3, 30.0, 20.0
    x = np.arange(0.0, duration * speed + 5.0, 0.05)
    z = amp * np.sin(2 * np.pi * x / wavelength)
    env = VerticalSuspensionEnv(backend="linear", speed=speed, duration=duration, profile=(x, z))
    env.reset(seed=0)
    n = round(duration / 0.01)
    acc = np.array([env.step(np.zeros(1, np.float32))[4]["carbody_acc"] for _ in range(n)])
    t = 0.01 * np.arange(1, n + 1)
    omega = 2 * np.pi * speed / wavelength
    h = -(omega**2) * amp * _carbody_receptance(env.vehicle_params, omega)
    expected = np.imag(h * np.exp(1j * omega * t))  # steady response to amp·sin(ωt)
    # the start transient decays with the body mode (about e^(-0.9 t/s)): below 1e-5 of the
    # amplitude after 15 s; what remains is RK4 and spline error
    late = t > 15.0
    np.testing.assert_allclose(acc[late], expected[late], rtol=0, atol=1e-5 * abs(h))


def test_profile_argument_file_option_and_vector_env_agree(tmp_path):
    x = np.arange(0.0, 100.0, 0.25)
    z = 2e-3 * np.sin(2 * np.pi * x / 38.0) + 5e-4 * np.sin(2 * np.pi * x / 7.0)
    path = tmp_path / "track.csv"
    path.write_text(
        "x,z\n" + "".join(f"{a!r},{b!r}\n" for a, b in zip(x.tolist(), z.tolist(), strict=True))
    )
    kw = {"backend": "linear", "duration": 1.0, "speed": 40.0}
    acts = [np.array([0.2 * np.sin(0.3 * k)], np.float32) for k in range(100)]
    from_file = _rollout(VerticalSuspensionEnv(profile=str(path), **kw), 0, acts)
    env = VerticalSuspensionEnv(**kw)
    env.reset(seed=0, options={"profile": (x, z)})
    from_option = _rollout(env, 5, acts)  # the profile option is kept; the seed plays no part
    np.testing.assert_array_equal(np.array(from_file[1:]), np.array(from_option[1:]))
    track_z = env.track()[0]  # sampled every 40 m/s × 1 ms; the spline passes the knots
    np.testing.assert_allclose(track_z[::25], z[::4][: track_z[::25].size], rtol=0, atol=1e-15)
    other = VerticalSuspensionEnv(profile=(x, -z), **kw)
    other.reset(seed=0, options={"profile": (x, z)})  # the option overrides the argument
    np.testing.assert_array_equal(other.track()[0], env.track()[0])
    venv = VerticalSuspensionVectorEnv(num_envs=2, profile=str(path), **kw)
    venv.reset(seed=3)
    for i in range(2):
        np.testing.assert_array_equal(venv.sim.z[i], env.track()[0])
    other.reset(options={"profile": None})  # back to seeded FRA track
    assert not np.allclose(other.track()[0], env.track()[0])
