"""Whole-vehicle env speed against CartPole and VerticalSuspension-v0 in the same run.

Targets (issue 14): single-env step of ``VerticalVehicle-v0`` ≤ 2 × CartPole-v1's; vector
env (1024) env-steps/s ≥ 1/3 of ``VerticalSuspension-v0``'s vector env.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

import railgym  # noqa: F401  (registers the environments)
from benchmarks import row
from benchmarks.bench_vertical import _single_step_us, _vector_rate


def run() -> list[dict]:
    """Rows of measurements (see ``benchmarks/__main__.py``)."""
    cart = gym.make("CartPole-v1")
    t_cart = _single_step_us(cart, lambda k: k % 2)
    rows = [row("CartPole-v1 step (anchor)", t_cart, "µs", context="gym.make, same run")]
    zero = np.zeros(2, np.float32)
    for backend in ("surrogate", "reference", "linear"):
        env = gym.make("railgym/VerticalVehicle-v0", backend=backend)
        t = _single_step_us(env, lambda k: zero)
        rows += [
            row(f"VerticalVehicle step ({backend})", t, "µs", context="10 RK4 substeps"),
            row(f"  ratio to CartPole ({backend})", t / t_cart, "×", "≤ 2" if
                backend == "surrogate" else ""),
        ]  # fmt: skip
    n = 1024
    v0 = gym.make_vec("railgym/VerticalSuspension-v0", num_envs=n,
                      vectorization_mode="vector_entry_point")  # fmt: skip
    r_v0 = _vector_rate(v0, np.zeros((n, 1), np.float32), 30)
    del v0
    venv = gym.make_vec("railgym/VerticalVehicle-v0", num_envs=n,
                        vectorization_mode="vector_entry_point")  # fmt: skip
    r = _vector_rate(venv, np.zeros((n, 2), np.float32), 30)
    rows += [
        row(f"VerticalSuspension vector ({n}) (anchor)", r_v0 / 1e6, "M steps/s",
            context="surrogate, same run"),
        row(f"VerticalVehicle vector ({n}, surrogate)", r / 1e6, "M steps/s"),
        row("  share of VerticalSuspension's", r / r_v0, "×", "≥ 1/3"),
    ]  # fmt: skip
    return rows


if __name__ == "__main__":
    for r in run():
        print(r)
