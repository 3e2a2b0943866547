"""Env steps as timed calls, shared by the env benchmarks (timed by :mod:`benchmarks._timing`).

A :class:`Steps` call runs a block of env steps and knows how many env-steps it ran, so a
rate is ``call.env_steps / seconds per call`` and a step time ``seconds per call /
call.env_steps`` whatever the block's size.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np

from benchmarks._timing import interleaved

#: single-env steps per timed call (resets included when an episode ends)
BLOCK = 100


class Steps:
    """``n`` steps of a single env (``action_fn(k)`` for step ``k``, reset where an episode
    ends) or of a vector env (the same ``action`` for all sub-envs, autoreset); the env is
    reset with seed 0 on construction. ``env_steps``: env-steps per call."""

    def __init__(self, env: Any, n: int, action_fn: Callable[[int], object]) -> None:
        self.env, self.n, self.action_fn = env, n, action_fn
        self.vector = isinstance(env, gym.vector.VectorEnv)
        self.env_steps = n * (env.num_envs if self.vector else 1)
        env.reset(seed=0)

    def __call__(self) -> None:
        env, action_fn = self.env, self.action_fn
        if self.vector:
            for k in range(self.n):
                env.step(action_fn(k))
            return
        for k in range(self.n):
            _, _, term, trunc, _ = env.step(action_fn(k))
            if term or trunc:
                env.reset()


def steps(env: gym.Env, action_fn: Callable[[int], object], n: int = BLOCK) -> Steps:
    """``n`` steps of the single env ``env`` per call."""
    return Steps(env, n, action_fn)


def vector_steps(venv: gym.vector.VectorEnv, action: np.ndarray, n: int) -> Steps:
    """``n`` steps of all sub-envs of ``venv`` per call, with ``action``."""
    return Steps(venv, n, lambda k: action)


def per_step_us(call: Steps, seconds: np.ndarray) -> np.ndarray:
    """µs per env-step of ``call`` from its seconds per call."""
    return seconds / call.env_steps * 1e6


def rate(call: Steps, seconds: np.ndarray) -> np.ndarray:
    """Env-steps per second of ``call`` from its seconds per call."""
    return call.env_steps / seconds


def split_us(env: gym.Env, action: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(compiled, shell)``: µs per single-env step, one sample per window, in the batch's
    one compiled call (kernel and bookkeeping; its argument unboxing included) and in the
    rest (action check, ``info``, observation, wrappers), timed by wrapping ``advance`` (adds
    ~0.1 µs to the compiled part)."""
    sim = env.unwrapped.sim
    spent: list[float] = []
    call = steps(env, lambda k: action)

    def timed() -> None:
        t = time.perf_counter()
        type(sim).advance(sim)
        spent.append(time.perf_counter() - t)

    sim.advance = timed
    try:
        w = interleaved({"env": call})["env"]
    finally:
        del sim.advance
    per_window = w.calls * call.env_steps
    compiled = np.array(spent[-len(w.seconds) * per_window :]).reshape(len(w.seconds), -1)
    compiled_us = compiled.mean(axis=1) * 1e6
    return compiled_us, per_step_us(call, w.seconds) - compiled_us
