"""Fixtures shared by the agents tests."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest


@pytest.fixture
def tiny_ppo_block() -> Callable[..., dict[str, Any]]:
    """``tiny_ppo_block(**overrides)``: the ``agents.training.train`` config block of a PPO run of
    seconds (128 steps on two envs of VerticalVehicle-v1's linear backend, 1 s episodes, no
    evaluation or checkpoint during the run, an 8-unit network), with ``overrides``."""

    def block(**overrides: Any) -> dict[str, Any]:
        return {
            "algo": "ppo",
            "n_timesteps": 128,
            "n_envs": 2,
            "seed": 0,
            "env_kwargs": {"backend": "linear", "duration": 1.0},
            "eval_freq": 10**6,
            "n_eval_episodes": 1,
            "checkpoint_freq": 10**6,
            "n_steps": 64,
            "batch_size": 64,
            "n_epochs": 1,
            "policy_kwargs": {"net_arch": [8]},
            **overrides,
        }

    return block


@pytest.fixture
def controlled_episode() -> Callable[[Any, Any, int], tuple[np.ndarray, dict[str, Any]]]:
    """``controlled_episode(env, controller, seed)``: one episode of ``controller`` from
    ``env.reset(seed=seed)``; the RMS over the steps of ``info["carbody_acc"]`` (per floor
    point) and the last step's info."""

    def run(env: Any, controller: Any, seed: int) -> tuple[np.ndarray, dict[str, Any]]:
        obs, _ = env.reset(seed=seed)
        acc = []
        while True:
            obs, _, term, trunc, info = env.step(controller.predict(obs)[0])
            acc.append(info["carbody_acc"])
            if term or trunc:
                return np.sqrt(np.mean(np.square(acc), axis=0)), info

    return run
