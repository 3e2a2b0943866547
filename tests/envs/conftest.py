"""Fixtures shared by the env tests."""

from __future__ import annotations

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
