"""VerticalSuspension-v3: the track streamed inside the compiled step.

Its input is the streamed profile of railgym.track_stream at the env's grid (sample for sample,
with the wheelbase the mean of two samples of it), sub-envs are the single env of the same seed,
episodes up to 600 s take the same memory as 20 s ones (≤ 64 kB per sub-env), a measured
profile rides as on v2 (bit for bit), and 65 536 sub-envs are accepted.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable

import gymnasium as gym
import numpy as np
import pytest

import railgym  # noqa: F401
import railgym._checks
from railgym.track_stream import stream_profile
from tests.envs.test_track_chunks import batch_bytes

ENV = "railgym/VerticalSuspension-v3"


def _make(**kw):
    return gym.make(ENV, **kw).unwrapped


def _inputs(env, steps: int) -> tuple[np.ndarray, np.ndarray]:
    """The track input ``(z, zdot)`` the kernel read at samples 0 .. steps·n_sub."""
    sim = env.sim
    n_sub = sim.cfg.n_sub
    z, zd = [sim.track_arrays(0)[0][:1]], [sim.track_arrays(0)[1][:1]]
    for _ in range(steps):
        env.step(np.zeros(1, np.float32))
        k = int(sim.k[0])
        z.append(sim.z[0, k - n_sub + 1 : k + 1].copy())
        zd.append(sim.zdot[0, k - n_sub + 1 : k + 1].copy())
    return np.concatenate(z), np.concatenate(zd)


def test_input_is_the_streamed_profile() -> None:
    env = _make(track_class=5, speed=40.0)
    env.reset(seed=11)
    z, zd = _inputs(env, 300)
    ds = 40.0 * env.cfg.dt
    _, pz, slope = stream_profile(5, (z.size - 1) * ds, ds, 11)
    np.testing.assert_allclose(z, pz[: z.size], rtol=0, atol=1e-15)
    np.testing.assert_allclose(zd, 40.0 * slope[: z.size], rtol=1e-12, atol=1e-15)


def test_wheelbase_input_is_the_mean_of_the_two_wheelsets() -> None:
    """wheelbase = 50 samples of 4 cm: the leading wheelset's height is a sample of the
    same profile 2 m ahead."""
    env = _make(track_class=5, speed=40.0, wheelbase=2.0)
    env.reset(seed=5)
    z, zd = _inputs(env, 200)
    ds = 40.0 * env.cfg.dt
    _, pz, slope = stream_profile(5, (z.size + 60) * ds, ds, 5)
    want = 0.5 * (pz[: z.size] + pz[50 : 50 + z.size])
    np.testing.assert_allclose(z, want, rtol=0, atol=1e-15)
    np.testing.assert_allclose(zd, 20.0 * (slope[: z.size] + slope[50 : 50 + z.size]), atol=1e-14)


def test_vector_sub_env_is_the_single_env_and_reset_repeats() -> None:
    venv = gym.make_vec(ENV, num_envs=3, vectorization_mode="vector_entry_point")
    venv.reset(seed=20)
    single = gym.make(ENV)
    single.reset(seed=22)
    for _ in range(150):
        o, r, *_ = venv.step(np.full((3, 1), 0.3, np.float32))
        so, sr, *_ = single.step(np.full(1, 0.3, np.float32))
    np.testing.assert_array_equal(o[2], so)
    assert r[2] == sr
    single.reset(seed=22)
    first = [single.step(np.zeros(1, np.float32))[0] for _ in range(20)]
    single.reset(seed=22)
    again = [single.step(np.zeros(1, np.float32))[0] for _ in range(20)]
    np.testing.assert_array_equal(first, again)


@pytest.mark.parametrize("duration", [20.0, 600.0])
def test_memory_per_sub_env_does_not_grow_with_the_episode(duration: float) -> None:
    n = 64
    venv = gym.make_vec(ENV, num_envs=n, vectorization_mode="vector_entry_point", duration=duration)
    venv.reset(seed=0)
    per_env = batch_bytes(venv.unwrapped.sim) / n
    assert per_env <= 64 * 1024, per_env
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        v2 = gym.make_vec(
            "railgym/VerticalSuspension-v2", num_envs=n, vectorization_mode="vector_entry_point"
        )
    assert per_env < batch_bytes(v2.unwrapped.sim) / n / 100


def test_600_s_episode_runs_to_its_end() -> None:
    env = gym.make(ENV, duration=600.0)
    env.reset(seed=1)
    steps, done, info = 0, False, {}
    while not done:
        _, _, terminated, truncated, info = env.step(np.zeros(1, np.float32))
        steps += 1
        done = terminated or truncated
    assert truncated and steps == 60_000
    assert info["time"] == pytest.approx(600.0)
    assert 0.2 < info["rms_carbody_acc"] < 3.0


def test_measured_profile_rides_as_on_v2(v3_rides_as_v2: Callable[..., None]) -> None:
    v3_rides_as_v2("VerticalSuspension", 900.0, 1, 400)


def test_65536_sub_envs_are_accepted() -> None:
    n = 65536
    venv = gym.make_vec(ENV, num_envs=n, vectorization_mode="vector_entry_point")
    obs, _ = venv.reset(seed=0)
    obs, reward, *_ = venv.step(np.zeros((n, 1), np.float32))
    assert obs.shape == (n, 5) and np.all(np.isfinite(reward))
    assert batch_bytes(venv.unwrapped.sim) / n <= 64 * 1024


def test_parallel_fill_gives_the_single_envs_numbers(
    last_sub_env_as_single: Callable[..., None],
) -> None:
    """From PARALLEL_MIN sub-envs the windows are filled on numba's threads: the last sub-env
    still steps as the single env of its seed."""
    last_sub_env_as_single(ENV, 300, 40, np.full(1, -0.2, np.float32), 60)


def test_too_wide_wheelbase_windows_are_refused_naming_speed() -> None:
    venv = gym.make_vec(
        ENV, num_envs=1024, vectorization_mode="vector_entry_point", speed=1.0, wheelbase=50.0
    )
    with pytest.raises(railgym._checks.FieldError, match="speed"):
        venv.reset(seed=0)
