"""Track preview of VerticalVehicle-v1 (``preview=H``): the channels are the track ahead of
the rear wheelset at the documented points, the single and the native vector env observe the
same, ``preview=0`` is today's env, and a bad horizon is refused naming ``preview``."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from scipy.interpolate import CubicHermiteSpline

import railgym  # noqa: F401
from railgym.envs.vehicle.env import PREVIEW_SPACING, VerticalVehicleEnv, VerticalVehicleVectorEnv

SHORT = {"backend": "linear", "duration": 0.5}
SPAN = 2.0 * (9.5 + 1.28)  # front-to-rear wheelset distance of manchester_whole, m


def _rollout(env, steps, seed=4):
    """Observations of a seeded episode under a fixed action sequence (n_steps + 1, n_obs)."""
    rng = np.random.default_rng(0)
    obs, _ = env.reset(seed=seed)
    out = [obs]
    for _ in range(steps):
        obs, *_ = env.step(rng.uniform(-1.0, 1.0, env.action_space.shape).astype(np.float32))
        out.append(obs)
    return np.array(out)


@pytest.mark.parametrize("horizon", [0.3, 7.3, SPAN])
def test_preview_grid_is_the_documented_one(horizon):
    env = VerticalVehicleEnv(**SHORT, preview=horizon)
    points = env.unwrapped.preview_points
    n = math.ceil(horizon / PREVIEW_SPACING)
    assert points.size == n + 1 and points[0] == 0.0 and points[-1] == horizon
    np.testing.assert_allclose(np.diff(points), horizon / n, rtol=1e-12)
    assert np.diff(points).max() <= PREVIEW_SPACING
    names = env.unwrapped.obs_names
    assert names[11:] == tuple(f"preview_z_{i}" for i in range(n + 1)) + tuple(
        f"preview_zdot_{i}" for i in range(n + 1)
    )
    assert env.observation_space.shape == (11 + 2 * (n + 1),) == (len(names),)
    np.testing.assert_array_equal(env.unwrapped.obs_scale[11:], [0.01] * (n + 1) + [0.1] * (n + 1))


def test_preview_channels_are_the_track_ahead_of_the_rear_wheelset():
    """Independently of the kernel's interpolation: a C¹ cubic Hermite spline (scipy) of the
    episode's track, height over distance (x = k·v·dt) with slope ż/v, evaluated at the rear
    wheelset's distance travelled plus each preview point, gives every preview channel (to
    the float32 rounding of the observation)."""
    env = VerticalVehicleEnv(backend="linear", duration=1.0, preview=7.3, speed=35.0)
    base = env.unwrapped
    obs = _rollout(env, 40) * base.obs_scale
    cfg, arrays = base.cfg, base.sim.arrays
    v, dt = base.sim.speed[0], cfg.dt
    x = v * dt * np.arange(arrays.z.shape[1])
    track = CubicHermiteSpline(x, arrays.z[0], arrays.zdot[0] / v)
    points = base.preview_points
    n = points.size
    for m, row in enumerate(obs):
        at = m * cfg.n_sub * v * dt + points  # track distance of each preview point
        np.testing.assert_allclose(row[11 : 11 + n], track(at), rtol=3e-7, atol=1e-10)
        np.testing.assert_allclose(row[11 + n :], v * track(at, 1), rtol=3e-7, atol=1e-9)
    assert np.abs(obs[:, 11 : 11 + n]).max() > 1e-3  # a real FRA track, millimetres


def test_full_horizon_ends_at_the_front_wheelset():
    """The first preview point is the rear wheelset's input, the last (at the full horizon
    2(a + b)) the front one's: the wheelset inputs w_3 and w_0 of the full observation."""
    env = VerticalVehicleEnv(**SHORT, observation="full", preview=SPAN)
    names = env.unwrapped.obs_names
    obs = _rollout(env, 20) * env.unwrapped.obs_scale
    n = env.unwrapped.preview_points.size
    idx = {name: names.index(name) for name in ("w0", "w3", "w0_dot", "w3_dot")}
    z0, zl, d0, dl = (
        names.index(f"preview_{q}_{i}")
        for q, i in (("z", 0), ("z", n - 1), ("zdot", 0), ("zdot", n - 1))
    )
    np.testing.assert_array_equal(obs[:, z0], obs[:, idx["w3"]])
    np.testing.assert_array_equal(obs[:, zl], obs[:, idx["w0"]])
    np.testing.assert_array_equal(obs[:, d0], obs[:, idx["w3_dot"]])
    np.testing.assert_array_equal(obs[:, dl], obs[:, idx["w0_dot"]])


@pytest.mark.parametrize("observation", ["sensors", "full"])
def test_single_and_native_vector_env_observe_the_same(observation):
    kwargs = {**SHORT, "observation": observation, "preview": 12.0}
    single = gym.make("railgym/VerticalVehicle-v1", **kwargs)
    venv = gym.make_vec(
        "railgym/VerticalVehicle-v1", num_envs=2, vectorization_mode="vector_entry_point", **kwargs
    )
    assert venv.unwrapped.obs_names == single.unwrapped.obs_names
    np.testing.assert_array_equal(venv.unwrapped.preview_points, single.unwrapped.preview_points)
    for i in range(2):
        one = _rollout(single, 30, seed=7 + i)
        rng = np.random.default_rng(0)
        obs, _ = venv.reset(seed=7)
        many = [obs[i]]
        for _ in range(30):
            a = rng.uniform(-1.0, 1.0, single.action_space.shape).astype(np.float32)
            obs, *_ = venv.step(np.tile(a, (2, 1)))
            many.append(obs[i])
        np.testing.assert_array_equal(np.array(many), one)


@pytest.mark.parametrize("observation", ["sensors", "full"])
def test_zero_preview_is_todays_env(observation):
    plain = VerticalVehicleEnv(**SHORT, observation=observation)
    zero = VerticalVehicleEnv(**SHORT, observation=observation, preview=0.0)
    assert zero.unwrapped.obs_names == plain.unwrapped.obs_names
    assert len(zero.unwrapped.obs_names) == {"sensors": 11, "full": 27}[observation]
    assert zero.unwrapped.preview_points.size == 0
    np.testing.assert_array_equal(_rollout(zero, 25), _rollout(plain, 25))


@pytest.mark.parametrize(
    "value, error",
    [
        (-0.5, ValueError),
        (float("nan"), ValueError),
        (float("inf"), ValueError),
        (SPAN + 0.01, ValueError),
        (30.0, ValueError),
        ("5", TypeError),
        (True, TypeError),
    ],
)
def test_bad_preview_is_refused_naming_it(value, error):
    with pytest.raises(error, match="preview"):
        VerticalVehicleEnv(**SHORT, preview=value)
    with pytest.raises(error, match="preview"):
        VerticalVehicleVectorEnv(num_envs=2, **SHORT, preview=value)


def test_a_rounded_full_horizon_ends_at_the_front_wheelset():
    points = VerticalVehicleEnv(**SHORT, preview=SPAN * (1 + 1e-12)).unwrapped.preview_points
    assert points[-1] == SPAN


def test_beyond_the_front_wheelset_names_the_limit():
    with pytest.raises(ValueError, match=r"preview.*front wheelset.*21\.56"):
        VerticalVehicleEnv(**SHORT, preview=25.0)
