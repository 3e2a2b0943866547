"""Crash models and TrainCrash-v1 speed, with gymnasium's CartPole measured in the same run.

Targets (issue 4): surrogate ≥ 100 × faster than our reference for the default scenario (the
paper: LS-DYNA 51 548 s vs 8 s); one full crash episode on the surrogate env ≤ 5 ms; vector
env env-steps/s at 1024 sub-envs and the single-env step, both against CartPole. Every time is
the minimum over repeats (the machine is shared), after a warm-up call. Issue 13: the
compiled surrogate episode ≤ 0.08 ms; the vector env ≥ 50 % of CartPoleVectorEnv.

Our reference is a lumped-mass chain of 16 masses, not a finite-element model: it is only a few
times slower than the 2-mass surrogate, so the paper's ratio is out of reach by construction.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import gymnasium as gym
import numpy as np

import railgym  # noqa: F401  (registers the environments)
from benchmarks import row
from railgym.vehicles.crash import (
    build_crash_surrogate,
    load_scenario,
    simulate_reference,
    simulate_surrogate,
)

N_VEC = 1024


def _best(fn: Callable[[], object], repeats: int) -> float:
    """Minimum wall time of ``repeats`` calls of ``fn``, s (after one warm-up call)."""
    fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def _episode(env: gym.Env) -> int:
    """One passive (action 0) crash episode; returns its number of steps."""
    env.reset(seed=0)
    zero = np.zeros(env.action_space.shape, np.float32)
    n = 0
    while True:
        n += 1
        *_, term, trunc, _ = env.step(zero)
        if term or trunc:
            return n


def _step_us(env: gym.Env, action_fn: Callable[[int], object], n: int = 5000) -> float:
    """Mean step time over ``n`` steps (resetting when an episode ends), minimum of 3, µs."""

    def steps() -> None:
        env.reset(seed=0)
        for k in range(n):
            _, _, term, trunc, _ = env.step(action_fn(k))
            if term or trunc:
                env.reset()

    return _best(steps, repeats=3) / n * 1e6


def _vector_rate(venv: gym.vector.VectorEnv, action: np.ndarray, n: int) -> float:
    """Env-steps per second over ``n`` steps of all sub-envs, best of 3."""
    venv.reset(seed=0)
    t = _best(lambda: [venv.step(action) for _ in range(n)], repeats=3)
    return venv.num_envs * n / t


def run() -> list[dict]:
    """Rows of measurements (see ``benchmarks/__main__.py``)."""
    sc = load_scenario("paper")
    ref = simulate_reference(sc)
    t_ref = _best(lambda: simulate_reference(sc), repeats=30)
    masses = sc.lead.n_nodes + (sc.n_cars - 1) * sc.passenger.n_nodes
    rows = [
        row(
            f"crash reference run (paper, {sc.n_cars} cars, {sc.speed * 3.6:.0f} km/h)",
            t_ref * 1e3,
            "ms",
            context=f"{ref.t[-1]:.3f} s simulated, {masses} masses, dt {ref.dt:.1e} s",
        )
    ]
    for variant in ("hysteretic", "paper"):
        sur = build_crash_surrogate(ref, variant=variant, seed=0)
        res = simulate_surrogate(sc, sur)
        t_sur = _best(lambda s=sur: simulate_surrogate(sc, s), repeats=30)
        rows += [
            row(
                f"crash surrogate run ({variant})",
                t_sur * 1e3,
                "ms",
                "≤ 0.08" if variant == "hysteretic" else "",
                context=f"{res.t[-1]:.3f} s simulated, dt {res.dt:.1e} s",
            ),
            row(
                f"  reference / surrogate ({variant})",
                t_ref / t_sur,
                "×",
                "≥ 100",
                "paper: FE 51 548 s vs 8 s",
            ),
        ]
    env = gym.make("railgym/TrainCrash-v1")
    steps = _episode(env)
    t_ep = _best(lambda: _episode(env), repeats=20)
    rows.append(
        row(
            "TrainCrash-v1 passive episode (surrogate)",
            t_ep * 1e3,
            "ms",
            "≤ 5",
            f"{steps} steps of 1 ms, gym.make",
        )
    )
    cart = gym.make("CartPole-v1")
    t_cart = _step_us(cart, lambda k: k % 2)
    zero = np.zeros(env.action_space.shape, np.float32)
    t_crash = _step_us(env, lambda k: zero)
    rows += [
        row("CartPole-v1 step (anchor)", t_cart, "µs", context="gym.make, same run"),
        row("TrainCrash-v1 step (surrogate)", t_crash, "µs", context="2 substeps of 0.5 ms"),
        row("  ratio to CartPole", t_crash / t_cart, "×"),
    ]
    mode = "vector_entry_point"
    cart_vec = gym.make_vec("CartPole-v1", num_envs=N_VEC, vectorization_mode=mode)
    r_cart = _vector_rate(cart_vec, np.ones(N_VEC, np.int64), 300)
    venv = gym.make_vec("railgym/TrainCrash-v1", num_envs=N_VEC, vectorization_mode=mode)
    r_crash = _vector_rate(venv, np.zeros((N_VEC,) + zero.shape, np.float32), 100)
    rows += [
        row(f"CartPoleVectorEnv ({N_VEC}) (anchor)", r_cart / 1e6, "M steps/s", context="same run"),
        row(
            f"TrainCrash vector ({N_VEC}, surrogate)",
            r_crash / 1e6,
            "M steps/s",
            context="autoreset included",
        ),
        row("  share of CartPoleVectorEnv", 100 * r_crash / r_cart, "%", "≥ 50"),
    ]
    return rows


if __name__ == "__main__":
    for r in run():
        print(r)
