"""Subprocess vector envs equal their in-process counterparts bit for bit (issue 9).

``gymnasium.vector.AsyncVectorEnv`` (workers started with ``spawn``: a fresh interpreter that
imports railgym, builds the env from a pickled factory and compiles or loads its kernels)
against ``SyncVectorEnv``, and stable-baselines3's ``SubprocVecEnv`` against ``DummyVecEnv``,
over a short seeded run with random actions that crosses episode ends (autoreset).
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
from gymnasium.vector import AsyncVectorEnv, SyncVectorEnv

from railgym.envs.crash.env import TrainCrashEnv, default_surrogate
from railgym.envs.vertical.env import VerticalSuspensionEnv
from railgym.vehicles.crash.scenario import load_scenario

N_ENVS, N_STEPS, SEED = 2, 9, 11
ENVS = ("crash", "vertical")
#: info entries compared besides observation, reward and the episode flags
INFO_KEYS = {"vertical": ("carbody_acc", "time"), "crash": ("decel_g", "crush_m")}


@functools.cache
def _factory(name: str) -> functools.partial:
    """Picklable env factory with 4-step episodes (the run crosses two autoresets); the crash
    surrogate is fitted once here and sent to the workers with the factory."""
    if name == "vertical":
        return functools.partial(VerticalSuspensionEnv, duration=0.04, sensor_noise=0.1)
    surrogate = default_surrogate(load_scenario("paper"))
    return functools.partial(
        TrainCrashEnv, max_duration=0.004, speed_jitter=0.1, surrogate=surrogate
    )


def _actions(space, n: int) -> list[np.ndarray]:
    rng = np.random.default_rng(SEED)
    return [rng.uniform(-1.5, 1.5, (n, *space.shape)).astype(np.float32) for _ in range(N_STEPS)]


def _gym_trace(venv, keys: tuple[str, ...]) -> list[tuple]:
    """Every array returned by a seeded run of a gymnasium vector env."""
    try:
        obs, _ = venv.reset(seed=SEED)
        trace: list[tuple] = [(obs,)]
        for action in _actions(venv.single_action_space, N_ENVS):
            obs, reward, term, trunc, info = venv.step(action)
            trace.append((obs, reward, term, trunc, *(info[k] for k in keys)))
        return trace
    finally:
        venv.close()


def _sb3_trace(venv) -> list[tuple]:
    """Observations, rewards, dones and terminal observations of a seeded SB3 run (rewards
    as float32: ``DummyVecEnv`` stores them so, ``SubprocVecEnv`` passes the env's float)."""
    try:
        venv.seed(SEED)
        trace: list[tuple] = [(venv.reset(),)]
        for action in _actions(venv.action_space, N_ENVS):
            obs, reward, done, infos = venv.step(action)
            final = [i.get("terminal_observation", np.zeros(0)) for i in infos]
            trace.append((obs, reward.astype(np.float32), done, *final))
        return trace
    finally:
        venv.close()


def _assert_identical(a: list[tuple], b: list[tuple]) -> None:
    assert len(a) == len(b)
    for step, (xs, ys) in enumerate(zip(a, b, strict=True)):
        for x, y in zip(xs, ys, strict=True):
            np.testing.assert_array_equal(x, y, err_msg=f"step {step}")
            assert np.asarray(x).dtype == np.asarray(y).dtype


@pytest.mark.parametrize("name", ENVS)
def test_async_vector_env_equals_sync_vector_env(name):
    factory, keys = _factory(name), INFO_KEYS[name]
    sync = _gym_trace(SyncVectorEnv([factory] * N_ENVS), keys)
    assert sum(t[2].sum() + t[3].sum() for t in sync[1:]) == 2 * N_ENVS  # two episode ends each
    assert np.all(np.isfinite(np.concatenate([np.ravel(x) for t in sync for x in t[:2]])))
    _assert_identical(_gym_trace(AsyncVectorEnv([factory] * N_ENVS, context="spawn"), keys), sync)


@pytest.mark.parametrize("name", ENVS)
def test_sb3_subproc_vec_env_equals_dummy_vec_env(name):
    vec_env = pytest.importorskip("stable_baselines3.common.vec_env")
    factory = _factory(name)
    dummy = _sb3_trace(vec_env.DummyVecEnv([factory] * N_ENVS))
    assert sum(t[2].sum() for t in dummy[1:]) == 2 * N_ENVS
    assert all(len(x) > 0 for t in dummy[1:] for x, d in zip(t[3:], t[2], strict=True) if d)
    subproc = vec_env.SubprocVecEnv([factory] * N_ENVS, start_method="spawn")
    _assert_identical(_sb3_trace(subproc), dummy)
