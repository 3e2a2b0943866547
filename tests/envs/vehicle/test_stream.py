"""VerticalVehicle-v3: the track streamed inside the compiled step, comfort figures online.

The rear wheelset's track is the streamed profile of railgym.track_stream at the env's grid;
the online comfort figures equal those of the per-step record (a_w, a_ZP95_Wb to rounding,
Wz, a filter against a Welch estimate, within 2 %); episodes up to 600 s take the same memory
as 20 s ones (≤ 64 kB per sub-env); a measured profile rides as on v2.
"""

from __future__ import annotations

from collections.abc import Callable

import gymnasium as gym
import numpy as np
import pytest
from scipy import signal

import railgym  # noqa: F401
import railgym._checks
from railgym.comfort import WeightingFilter
from railgym.envs.vehicle.batch import episode_comfort
from railgym.envs.vehicle.online_comfort import comfort_figures, comfort_step, new_comfort
from railgym.track_stream import stream_profile
from tests.envs.test_track_chunks import batch_bytes

ENV = "railgym/VerticalVehicle-v3"


def test_online_comfort_equals_the_record_figures() -> None:
    rng = np.random.default_rng(3)
    b, a = signal.butter(2, [0.5, 15.0], "bandpass", fs=100.0)
    for steps in (7, 300, 3217):  # below the minimum, one short window, several blocks
        acc = signal.lfilter(b, a, rng.standard_normal((steps, 3)), axis=0)
        c, cc = new_comfort(1, 0.01, 40.0)
        count = np.zeros(1, np.int64)
        for m in range(steps):
            count[0] = m + 1
            comfort_step(c, cc, acc[None, m], count, 0)
        online = comfort_figures(c, cc, 0, steps, 8)
        wk, wb = (WeightingFilter(100.0, k, lowpass=False) for k in ("Wk", "Wb"))
        record = episode_comfort(acc, 100.0, wk, wb)
        np.testing.assert_allclose(online["a_w"], record["a_w"], rtol=1e-10)
        np.testing.assert_allclose(online["a_ZP95_Wb"], record["a_ZP95_Wb"], rtol=1e-10)
        if steps > 3000:  # the record's Welch estimate of a 3 s record is one segment
            np.testing.assert_allclose(online["Wz"], record["Wz"], rtol=0.02)


def test_rear_wheelset_track_is_the_streamed_profile() -> None:
    env = gym.make(ENV, track_class=5, speed=40.0).unwrapped
    env.reset(seed=4)
    for _ in range(30):
        env.step(np.zeros(2, np.float32))
    sim = env.sim
    v = sim.arrays
    z, zd = v.z[0, : sim.end[0] - v.start[0]], v.zdot[0, : sim.end[0] - v.start[0]]
    ds = 40.0 * env.cfg.dt
    _, pz, slope = stream_profile(5, (sim.end[0] - 1) * ds, ds, 4)
    np.testing.assert_allclose(z, pz[v.start[0] : sim.end[0]], rtol=0, atol=1e-15)
    np.testing.assert_allclose(zd, 40.0 * slope[v.start[0] : sim.end[0]], rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("duration", [20.0, 600.0])
def test_memory_per_sub_env_does_not_grow_with_the_episode(duration: float) -> None:
    n = 16
    venv = gym.make_vec(ENV, num_envs=n, vectorization_mode="vector_entry_point", duration=duration)
    venv.reset(seed=0)
    assert batch_bytes(venv.unwrapped.sim) / n <= 64 * 1024


def test_episode_ends_with_comfort_figures() -> None:
    venv = gym.make_vec(ENV, num_envs=2, vectorization_mode="vector_entry_point", duration=6.0)
    venv.reset(seed=1)
    for _ in range(600):
        *_, infos = venv.step(np.zeros((2, 2), np.float32))
    assert infos["_comfort"].all()
    for key in ("a_w", "a_ZP95_Wb", "Wz"):
        assert np.all((infos["comfort"][key] > 0.0) & np.isfinite(infos["comfort"][key]))


def test_measured_profile_rides_as_on_v2(v3_rides_as_v2: Callable[..., None]) -> None:
    v3_rides_as_v2("VerticalVehicle", 400.0, 2, 150, duration=2.0)


def test_parallel_fill_gives_the_single_envs_numbers(
    last_sub_env_as_single: Callable[..., None],
) -> None:
    """From PARALLEL_MIN sub-envs the windows are filled on numba's threads: the last sub-env
    still steps as the single env of its seed."""
    last_sub_env_as_single(ENV, 260, 50, np.full(2, 0.1, np.float32), 40)


def test_too_wide_windows_are_refused_naming_num_envs() -> None:
    with pytest.raises(railgym._checks.FieldError, match="num_envs"):
        gym.make_vec(ENV, num_envs=4096, vectorization_mode="vector_entry_point", speed=1.0)
