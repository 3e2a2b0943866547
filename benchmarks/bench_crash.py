"""Crash models and TrainCrash-v0 speed, with anchors measured in the same run.

Targets (issue 4): surrogate ≥ 100 × faster than our reference for the default scenario (the
paper: LS-DYNA 51 548 s vs 8 s); one full crash episode on the surrogate env ≤ 5 ms; vector
env env-steps/s at 1024 sub-envs (reported against CartPoleVectorEnv).
"""

from __future__ import annotations

import time

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


def _best(fn, repeats: int = 5) -> float:
    """Minimum wall time of ``repeats`` calls, s (after one warm-up call)."""
    fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def _episode(env: gym.Env) -> int:
    env.reset(seed=0)
    zero = np.zeros(env.action_space.shape, np.float32)
    n = 0
    while True:
        n += 1
        *_, term, trunc, _ = env.step(zero)
        if term or trunc:
            return n


def run() -> list[dict]:
    """Rows of measurements (see ``benchmarks/__main__.py``)."""
    sc = load_scenario("paper")
    ref = simulate_reference(sc)
    t_ref = _best(lambda: simulate_reference(sc))
    rows = [row("crash reference run (paper scenario)", t_ref * 1e3, "ms",
                context=f"{ref.t[-1]:.2f} s simulated, dt {ref.dt:.1e} s")]  # fmt: skip
    for variant in ("hysteretic", "paper"):
        sur = build_crash_surrogate(ref, variant=variant)
        t_sur = _best(lambda s=sur: simulate_surrogate(sc, s))
        rows += [
            row(f"crash surrogate run ({variant})", t_sur * 1e3, "ms"),
            row(f"  reference / surrogate ({variant})", t_ref / t_sur, "×", "≥ 100",
                "paper: FE 51 548 s vs 8 s"),  # fmt: skip
        ]
    env = gym.make("railgym/TrainCrash-v0")
    steps = _episode(env)
    t_ep = _best(lambda: _episode(env))
    rows += [
        row("TrainCrash-v0 passive episode (surrogate)", t_ep * 1e3, "ms", "≤ 5",
            f"{steps} steps of 1 ms"),  # fmt: skip
        row("  per step", t_ep / steps * 1e6, "µs"),
    ]
    n = 1024
    mode = "vector_entry_point"
    cart = gym.make_vec("CartPole-v1", num_envs=n, vectorization_mode=mode)
    venv = gym.make_vec("railgym/TrainCrash-v0", num_envs=n, vectorization_mode=mode)
    rates = {}
    for name, vec, action in (("cart", cart, np.ones(n, np.int64)),
                              ("crash", venv, np.zeros((n, 2), np.float32))):  # fmt: skip
        vec.reset(seed=0)
        reps = 300 if name == "cart" else 50
        t = _best(lambda v=vec, a=action, r=reps: [v.step(a) for _ in range(r)], repeats=2)
        rates[name] = n * reps / t
    rows += [
        row(f"CartPoleVectorEnv ({n}) (anchor)", rates["cart"] / 1e6, "M steps/s"),
        row(f"TrainCrash vector ({n}, surrogate)", rates["crash"] / 1e6, "M steps/s"),
        row("  share of CartPoleVectorEnv", 100 * rates["crash"] / rates["cart"], "%"),
    ]
    return rows


if __name__ == "__main__":
    for r in run():
        print(r)
