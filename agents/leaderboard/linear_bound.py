"""Clairvoyant bound of an active force on the linear vertical model: the exact optimum.

With ``backend="linear"`` the vehicle is linear and time-invariant, and so is the ISO 2631-1
Wk filter (:class:`railgym.comfort.WeightingFilter`, ``sosfilt`` from rest): the weighted
carbody acceleration of a command sequence ``u`` (actions, force / ``f_max``, held over each
control step) on one track is ``y = y0 + H·u``, ``y0`` the passive response to the track and
``H`` the lower-triangular Toeplitz matrix of the weighted response ``h`` to one step of unit
action. Every controller, causal or not, produces one ``u`` in the box [−1, 1]^N, so

    min over u in [−1, 1]^N of  mean((y0 + H·u)[n0:]²)

(``n0``: the settling time left out of ``a_w``) is a convex box-constrained least-squares
problem whose global optimum bounds what any controller can reach on that track.
:func:`clairvoyant` solves it (L-BFGS-B) after checking the affine model against the env on a
random sequence, and returns the certified lower bound of :func:`certified_minimum` (below the
optimum by at most the solver's remaining gap).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from scipy import linalg, optimize

from railgym.comfort import WeightingFilter
from railgym.tasks import TASKS, case_kwargs

__all__ = ["MODEL_RTOL", "certified_minimum", "clairvoyant", "linear_bound", "weighted_response"]

#: largest relative error of the affine model against the env (a check, not a tolerance of
#: the bound)
MODEL_RTOL = 1e-6


def weighted_response(env: Any, seed: int, u: np.ndarray) -> np.ndarray:
    """The Wk-weighted carbody acceleration (m/s², every control step) of the single env
    ``env`` on the track of ``seed`` under the actions ``u`` (N,)."""
    env.reset(seed=seed)
    acc = []
    for a in u:
        _, _, term, trunc, info = env.step(np.array([a], np.float32))
        acc.append(float(info["carbody_acc"]))
        if term:
            raise RuntimeError("the linear model diverged")
    base = env.unwrapped
    return np.asarray(WeightingFilter(1.0 / base.cfg.control_dt, "Wk", False).filter(acc))


def clairvoyant(env: Any, seed: int, discard: float = 2.0) -> tuple[float, np.ndarray]:
    """A certified lower bound of the ``a_w`` (m/s², the first ``discard`` s left out) of any
    action sequence on the track of ``seed`` of the single linear env ``env``, and the best
    sequence found (N,)."""
    cfg = env.unwrapped.cfg
    if cfg.backend != "linear" or cfg.actuator != "force":
        raise ValueError("the exact bound needs backend 'linear' and actuator 'force'")
    n = int(cfg.n_steps)
    y0 = weighted_response(env, seed, np.zeros(n))
    step = np.zeros(n)
    step[0] = 1.0
    big_h = linalg.toeplitz(weighted_response(env, seed, step) - y0, np.zeros(n))
    check = np.random.default_rng(0).uniform(-1.0, 1.0, n)
    model, real = y0 + big_h @ check, weighted_response(env, seed, check)
    err = np.max(np.abs(model - real)) / np.max(np.abs(real))
    if not err < MODEL_RTOL:
        raise RuntimeError(f"the linear model is not affine in the actions (error {err:.2g})")
    n0 = int(round(discard / cfg.control_dt))
    return certified_minimum(big_h[n0:], y0[n0:])


def certified_minimum(a: np.ndarray, b: np.ndarray) -> tuple[float, np.ndarray]:
    """A lower bound of ``min sqrt(mean((a·u + b)²))`` over ``u`` in [−1, 1]^N and the best
    ``u`` found (L-BFGS-B). The bound is certified by convexity: for any ``u`` and gradient
    ``g`` of ``f = mean((a·u + b)²)``, ``f* ≥ f(u) − (gᵀu + Σ|g|)`` (the Frank–Wolfe gap),
    so it is below the true optimum whatever the solver's tolerance."""
    m = a.shape[0]

    def fun(u: np.ndarray) -> tuple[float, np.ndarray]:
        r = a @ u + b
        return float(r @ r / m), 2.0 * (a.T @ r) / m

    bounds = [(-1.0, 1.0)] * a.shape[1]
    res = optimize.minimize(
        fun,
        np.zeros(a.shape[1]),
        jac=True,
        method="L-BFGS-B",
        bounds=bounds,
        options={"maxiter": 20_000, "maxfun": 40_000, "ftol": 1e-15, "gtol": 1e-12},
    )
    f, g = fun(res.x)
    lower = f - float(g @ res.x + np.sum(np.abs(g)))
    return float(np.sqrt(max(lower, 0.0))), res.x


def linear_bound(task_name: str, label: str, episode: int, discard: float = 2.0) -> float:
    """The clairvoyant optimum of ``a_w`` (m/s²) on episode ``episode`` (track seed
    ``task.seed + episode``) of case ``label`` of a task on the linear backend
    (:func:`clairvoyant`)."""
    task = TASKS[task_name]
    env = gym.make(task.env_id, **case_kwargs(task_name, label))
    try:
        return clairvoyant(env, task.seed + episode, discard)[0]
    finally:
        env.close()
