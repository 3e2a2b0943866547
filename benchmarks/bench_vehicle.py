"""Whole-vehicle env speed against CartPole and VerticalSuspension-v1 in the same run.

Targets (issue 14): single-env step of ``VerticalVehicle-v1`` ≤ 2 × CartPole-v1's; vector
env (1024) env-steps/s ≥ 1/3 of ``VerticalSuspension-v1``'s vector env. Issue 22: the vector
env with the default memory element (the whole vehicle's, with its relaxation law) at least
0.85 × its rate with the paper's static element.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

import railgym  # noqa: F401  (registers the environments)
from benchmarks import row
from benchmarks.bench_vertical import _single_step_us, _split_us, _vector_rate
from railgym.vehicles.collect import default_vertical_surrogate
from railgym.vehicles.collect_vehicle import default_vehicle_surrogate

#: interleaved rounds of the single-env timing (the machine's load changes between them)
ROUNDS = 7


def run() -> list[dict]:
    """Rows of measurements (see ``benchmarks/__main__.py``): the single env, then the
    vector env."""
    return _single_rows() + _vector_rows()


def _single_rows() -> list[dict]:
    """Single-env step of each backend against CartPole: the ratio is the median over
    ``ROUNDS`` rounds, each timing CartPole and then the vehicle env for 4000 steps (two
    episodes, ends and resets included)."""
    cart = gym.make("CartPole-v1")
    zero = np.zeros(2, np.float32)
    envs = {
        b: gym.make("railgym/VerticalVehicle-v1", backend=b)
        for b in ("surrogate", "reference", "linear")
    }
    t_cart, t_env = [], {b: [] for b in envs}
    for _ in range(ROUNDS):
        for b, env in envs.items():
            t_cart.append(_single_step_us(cart, lambda k: k % 2, 4000))
            t_env[b].append(_single_step_us(env, lambda k: zero, 4000) / t_cart[-1])
    rows = [
        row(
            "CartPole-v1 step (anchor)",
            float(np.median(t_cart)),
            "µs",
            context="gym.make, same run, median",
        )
    ]
    for b, ratios in t_env.items():
        t = float(np.median(ratios)) * float(np.median(t_cart))
        rows += [
            row(f"VerticalVehicle step ({b})", t, "µs", context="5 RK4 substeps of 2 ms"),
            row(
                f"  ratio to CartPole ({b})",
                float(np.median(ratios)),
                "×",
                "≤ 2" if b == "surrogate" else "",
                f"median of {ROUNDS} interleaved rounds",
            ),
        ]
    compiled, shell = _split_us(envs["surrogate"], zero)
    rows += [
        row("  of which the compiled call", compiled, "µs", context="surrogate, kernel + book"),
        row("  of which the Python shell", shell, "µs", context="check, info, obs, wrappers"),
    ]
    return rows


def _vector_rows() -> list[dict]:
    """Vector env (1024) env-steps/s against VerticalSuspension-v1's, and with the memory
    element against the static one (median of ``ROUNDS`` interleaved rounds)."""
    n = 1024
    v0 = gym.make_vec(
        "railgym/VerticalSuspension-v1", num_envs=n, vectorization_mode="vector_entry_point"
    )
    r_v0 = _vector_rate(v0, np.zeros((n, 1), np.float32), 30)
    del v0
    zero2 = np.zeros((n, 2), np.float32)
    elements = {
        "maxwell": default_vehicle_surrogate(),
        "static": default_vertical_surrogate("static"),
    }
    venvs = {
        form: gym.make_vec(
            "railgym/VerticalVehicle-v1",
            num_envs=n,
            vectorization_mode="vector_entry_point",
            surrogate=element,
        )
        for form, element in elements.items()
    }
    rates: dict[str, list[float]] = {form: [] for form in venvs}
    for _ in range(ROUNDS):  # interleaved: the machine's load changes between rounds
        for form, venv in venvs.items():
            rates[form].append(_vector_rate(venv, zero2, 10))
    r, r_static = (float(np.median(rates[f])) for f in ("maxwell", "static"))
    ratio = float(np.median(np.array(rates["maxwell"]) / np.array(rates["static"])))
    del venvs
    return [
        row(
            f"VerticalSuspension vector ({n}) (anchor)",
            r_v0 / 1e6,
            "M steps/s",
            context="surrogate, same run",
        ),
        row(
            f"VerticalVehicle vector ({n}, surrogate)",
            r / 1e6,
            "M steps/s",
            context="memory, default",
        ),
        row("  share of VerticalSuspension's", r / r_v0, "×", "≥ 1/3"),
        row(f"VerticalVehicle vector ({n}, static element)", r_static / 1e6, "M steps/s"),
        row(
            "  memory element / static element",
            ratio,
            "×",
            "≥ 0.85",
            f"median of {ROUNDS} interleaved rounds",
        ),
    ]


if __name__ == "__main__":
    for r in run():
        print(r)
