"""Fixtures shared by the env tests."""

from __future__ import annotations

import warnings
from collections.abc import Callable, Iterator, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
import pytest


def _vector_equals_singles(
    env_id: str, kw: dict[str, Any], n_act: int, keys: Sequence[str]
) -> list[dict[str, Any]]:
    """Three sub-envs of the native vector env against three ``gym.make`` envs seeded
    ``4 + i``, 30 steps of seeded random commands in [0, 1] (see the fixture)."""
    n = 3
    venv = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", **kw)
    singles = [gym.make(env_id, **kw) for _ in range(n)]
    assert venv.single_action_space == gym.spaces.Box(0.0, 1.0, (n_act,), np.float32)
    obs_v, _ = venv.reset(seed=4)
    np.testing.assert_array_equal(
        obs_v, np.stack([e.reset(seed=4 + i)[0] for i, e in enumerate(singles)])
    )
    rng = np.random.default_rng(1)
    infos = []
    for _ in range(30):
        act = rng.uniform(0.0, 1.0, (n, n_act)).astype(np.float32)
        obs_v, rew_v, _, _, info_v = venv.step(act)
        for i, env in enumerate(singles):
            obs, rew, _, _, info = env.step(act[i])
            np.testing.assert_array_equal(obs_v[i], obs)
            assert rew_v[i] == rew
            for key in keys:
                np.testing.assert_array_equal(info_v[key][i], info[key])
        infos.append(info_v)
    return infos


@pytest.fixture
def semi_active_vector_equals_singles() -> Callable[..., list[dict[str, Any]]]:
    """``check(env_id, kw, n_act, keys)``: the native vector env of ``gym.make_vec(env_id,
    **kw)`` (semi-active: a Box [0, 1]^n_act action) equals single envs sub-env by sub-env
    (seeded ``s + i``) under random commands: observations, rewards and the info ``keys``.
    Returns the vector env's info of each step."""
    return _vector_equals_singles


def _random_commands(env: Any, n_act: int) -> Iterator[tuple[np.ndarray, dict[str, Any]]]:
    """Steps of ``env`` under random commands (see the fixture)."""
    env.reset(seed=2)
    rng = np.random.default_rng(3)
    while True:
        obs, _, term, trunc, info = env.step(rng.uniform(0, 1, n_act).astype(np.float32))
        yield obs, info
        if term or trunc:
            return


@pytest.fixture
def random_commands() -> Callable[[Any, int], Iterator[tuple[np.ndarray, dict[str, Any]]]]:
    """``steps(env, n_act)``: one episode of ``env`` from ``reset(seed=2)`` under seeded random
    commands uniform in [0, 1]^n_act; yields each step's observation and info (the env
    stands at that step while the caller reads it)."""
    return _random_commands


def _v3_rides_as_v2(family: str, length: float, n_act: int, n: int, **kw: Any) -> None:
    """``railgym/FAMILY-v3`` (the streamed track) steps as ``-v2`` for ``n`` steps of a
    constant command 0.2 on the same measured profile (two sines, ``length`` m, 0.1 m
    apart): observations and rewards equal to the bit."""
    x = np.linspace(0.0, length, round(10 * length) + 1)
    z = 0.004 * np.sin(2 * np.pi * x / 23.0) + 0.002 * np.sin(2 * np.pi * x / 4.1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        envs = [gym.make(f"railgym/{family}-{v}", profile=(x, z), **kw) for v in ("v2", "v3")]
    out = []
    for env in envs:
        env.reset(seed=0)
        out.append([env.step(np.full(n_act, 0.2, np.float32))[:2] for _ in range(n)])
    for (o2, r2), (o3, r3) in zip(*out, strict=True):
        np.testing.assert_array_equal(o2, o3)
        assert r2 == r3


@pytest.fixture
def v3_rides_as_v2() -> Callable[..., None]:
    """``check(family, length, n_act, n, **kw)``: ``-v3`` steps as ``-v2`` on a measured
    profile (see :func:`_v3_rides_as_v2`)."""
    return _v3_rides_as_v2


def _last_sub_env_as_single(env_id: str, n: int, seed: int, action: np.ndarray, steps: int) -> None:
    """The last of ``n`` sub-envs of the native vector env of ``env_id`` (``reset(seed)``)
    steps as the single env seeded ``seed + n - 1``: the same ``action`` for ``steps`` steps,
    the last observations equal to the bit."""
    venv = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point")
    venv.reset(seed=seed)
    single = gym.make(env_id)
    single.reset(seed=seed + n - 1)
    for _ in range(steps):
        o, *_ = venv.step(np.tile(action, (n, 1)))
        so, *_ = single.step(action)
    np.testing.assert_array_equal(o[-1], so)


@pytest.fixture
def last_sub_env_as_single() -> Callable[..., None]:
    """``check(env_id, n, seed, action, steps)``: the last sub-env of ``n`` steps as the
    single env of its seed (see :func:`_last_sub_env_as_single`)."""
    return _last_sub_env_as_single
