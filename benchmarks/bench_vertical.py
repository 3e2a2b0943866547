"""Vertical env speed against gymnasium's CartPole measured in the same run.

Targets (issue 13): single-env step ≤ 1.3 × CartPole-v1; vector env (1024) ≥ 25 % of
CartPoleVectorEnv's env-steps/s; a 20 s run on the surrogate ≥ 5 × faster than on the
reference (the paper's LPR co-simulation reached 51.03/49.64 ≈ 1.03 ×). Issue 10: the
packaged memory element's step within 10 % of the paper's static element.
"""

from __future__ import annotations

import time

import gymnasium as gym
import numpy as np

import railgym  # noqa: F401  (registers the environments)
from benchmarks import row
from railgym.track import track_time_input
from railgym.vehicles.collect import default_vertical_surrogate
from railgym.vehicles.vertical import load_vehicle, simulate


def _single_step_us(env: gym.Env, action_fn, n: int = 20000) -> float:
    env.reset(seed=0)
    for k in range(200):
        env.step(action_fn(k))
    env.reset(seed=0)
    t0 = time.perf_counter()
    for k in range(n):
        _, _, term, trunc, _ = env.step(action_fn(k))
        if term or trunc:
            env.reset()
    return (time.perf_counter() - t0) / n * 1e6


def _split_us(env: gym.Env, action: np.ndarray, n: int = 4000) -> tuple[float, float]:
    """``(compiled, shell)``: µs per single-env step in the batch's one compiled call (kernel and
    bookkeeping; its argument unboxing included) and in the rest (action check, ``info``,
    observation, wrappers), timed by wrapping ``advance`` (adds ~0.1 µs to the compiled part)."""
    sim = env.unwrapped.sim
    advance, spent = sim.advance, [0.0]

    def timed() -> None:
        t = time.perf_counter()
        advance()
        spent[0] += time.perf_counter() - t

    sim.advance = timed
    try:
        total = _single_step_us(env, lambda k: action, n)
    finally:
        del sim.advance
    compiled = spent[0] / (n + 200) * 1e6
    return compiled, total - compiled


def _vector_rate(venv, action, n: int) -> float:
    venv.reset(seed=0)
    for _ in range(5):
        venv.step(action)
    t0 = time.perf_counter()
    for _ in range(n):
        venv.step(action)
    return venv.num_envs * n / (time.perf_counter() - t0)


def run() -> list[dict]:
    """Rows of measurements (see ``benchmarks/__main__.py``)."""
    cart = gym.make("CartPole-v1")
    t_cart = _single_step_us(cart, lambda k: k % 2)
    rows = [row("CartPole-v1 step (anchor)", t_cart, "µs", context="gym.make, same run")]
    zero = np.zeros(1, np.float32)
    steps = {}
    for backend in ("surrogate", "reference", "linear"):
        env = gym.make("railgym/VerticalSuspension-v1", backend=backend)
        t = steps[backend] = _single_step_us(env, lambda k: zero)
        target = "≤ 1.3" if backend == "surrogate" else ""
        context = "10 RK4 substeps" + (", memory element" if backend == "surrogate" else "")
        rows += [
            row(f"VerticalSuspension step ({backend})", t, "µs", context=context),
            row(f"  ratio to CartPole ({backend})", t / t_cart, "×", target),
        ]
        if backend == "surrogate":
            compiled, shell = _split_us(env, zero)
            rows += [
                row("  of which the compiled call", compiled, "µs", context="kernel + bookkeeping"),
                row(
                    "  of which the Python shell", shell, "µs", context="check, info, obs, wrappers"
                ),
            ]
    static = default_vertical_surrogate("static")
    env = gym.make("railgym/VerticalSuspension-v1", surrogate=static)
    t = _single_step_us(env, lambda k: zero)
    rows += [
        row("VerticalSuspension step (static element)", t, "µs", context="paper's F(δ, δ̇)"),
        row("  memory / static element step", steps["surrogate"] / t, "×", "≤ 1.10"),
    ]
    n = 1024
    cart_vec = gym.make_vec("CartPole-v1", num_envs=n, vectorization_mode="vector_entry_point")
    r_cart = _vector_rate(cart_vec, np.ones(n, np.int64), 300)
    venv = gym.make_vec(
        "railgym/VerticalSuspension-v1", num_envs=n, vectorization_mode="vector_entry_point"
    )
    r = _vector_rate(venv, np.zeros((n, 1), np.float32), 30)
    rows += [
        row(f"CartPoleVectorEnv ({n}) (anchor)", r_cart / 1e6, "M steps/s", context="same run"),
        row(f"VerticalSuspension vector ({n}, surrogate)", r / 1e6, "M steps/s"),
        row("  share of CartPoleVectorEnv", 100 * r / r_cart, "%", "≥ 25"),
    ]
    veh = load_vehicle("manchester")
    _, z, zdot = track_time_input(5, 40.0, 20.0, 1e-3, seed=0)
    model = default_vertical_surrogate()
    times = {}
    for variant in ("surrogate", "dynamic"):
        simulate(variant, veh, z[:100], zdot[:100], 1e-3, surrogate=model)  # warm-up
        t0 = time.perf_counter()
        simulate(variant, veh, z, zdot, 1e-3, surrogate=model, sample_every=20)
        times[variant] = time.perf_counter() - t0
        paper = "paper T_s: LPR 48.31 s, Simpack 51.03 s"
        rows.append(row(f"20 s run, {variant}", times[variant] * 1e3, "ms", context=paper))
    ratio = times["dynamic"] / times["surrogate"]
    rows.append(row("  reference / surrogate time", ratio, "×", "≥ 5", "paper: 1.03 ×"))
    return rows


if __name__ == "__main__":
    for row in run():
        print(row)
