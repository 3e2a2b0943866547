"""Whole-vehicle env speed against CartPole and VerticalSuspension-v1 in the same run.

Targets (issue 14): single-env step of ``VerticalVehicle-v1`` ≤ 2 × CartPole-v1's; vector
env (1024) env-steps/s ≥ 1/3 of ``VerticalSuspension-v1``'s vector env. Issue 22: the vector
env with the default memory element (the whole vehicle's, with its relaxation law) at least
0.85 × its rate with the paper's static element. Every figure is the median of repeated
windows, compared figures timed in interleaved rounds (:mod:`benchmarks._timing`).
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

import railgym  # noqa: F401  (registers the environments)
from benchmarks import _timing, measured
from benchmarks._stepping import per_step_us, rate, split_us, steps, vector_steps
from benchmarks._timing import interleaved
from railgym.vehicles.collect import default_vertical_surrogate
from railgym.vehicles.vehicle.collect import default_vehicle_surrogate


def run() -> list[dict]:
    """Rows of measurements (see ``benchmarks/__main__.py``): the single env, then the
    vector env."""
    return _single_rows() + _vector_rows()


def _single_rows() -> list[dict]:
    """Single-env step of each backend against CartPole, in interleaved rounds (episode ends
    and resets included)."""
    zero = np.zeros(2, np.float32)
    envs = {
        b: gym.make("railgym/VerticalVehicle-v1", backend=b)
        for b in ("surrogate", "reference", "linear")
    }
    fns = {"cart": steps(gym.make("CartPole-v1"), lambda k: k % 2)}
    fns |= {b: steps(env, lambda k: zero) for b, env in envs.items()}
    t = {name: per_step_us(fns[name], w.seconds) for name, w in interleaved(fns).items()}
    rounds = f"interleaved rounds, median of {_timing.REPEATS}"
    rows = [measured("CartPole-v1 step (anchor)", t["cart"], "µs", context="gym.make, same run")]
    for b in envs:
        rows += [
            measured(f"VerticalVehicle step ({b})", t[b], "µs", context="5 RK4 substeps of 2 ms"),
            measured(
                f"  ratio to CartPole ({b})",
                t[b] / t["cart"],
                "×",
                "≤ 2" if b == "surrogate" else "",
                rounds,
            ),
        ]
    compiled, shell = split_us(envs["surrogate"], zero)
    rows += [
        measured(
            "  of which the compiled call",
            compiled,
            "µs",
            context="surrogate, kernel + book, own windows",
        ),
        measured("  of which the Python shell", shell, "µs", context="check, info, obs, wrappers"),
    ]
    return rows


def _vector_rows() -> list[dict]:
    """Vector env (1024) env-steps/s against VerticalSuspension-v1's, and with the memory
    element against the static one (interleaved rounds)."""
    n = 1024
    mode = "vector_entry_point"
    v0 = gym.make_vec("railgym/VerticalSuspension-v1", num_envs=n, vectorization_mode=mode)
    zero2 = np.zeros((n, 2), np.float32)
    elements = {
        "maxwell": default_vehicle_surrogate(),
        "static": default_vertical_surrogate("static"),
    }
    fns = {"v0": vector_steps(v0, np.zeros((n, 1), np.float32), 10)}
    for form, element in elements.items():
        venv = gym.make_vec(
            "railgym/VerticalVehicle-v1", num_envs=n, vectorization_mode=mode, surrogate=element
        )
        fns[form] = vector_steps(venv, zero2, 10)
    r = {name: rate(fns[name], w.seconds) for name, w in interleaved(fns).items()}
    rounds = f"interleaved rounds, median of {_timing.REPEATS}"
    return [
        measured(
            f"VerticalSuspension vector ({n}) (anchor)",
            r["v0"] / 1e6,
            "M steps/s",
            context="surrogate, same run",
        ),
        measured(
            f"VerticalVehicle vector ({n}, surrogate)",
            r["maxwell"] / 1e6,
            "M steps/s",
            context="memory, default",
        ),
        measured("  share of VerticalSuspension's", r["maxwell"] / r["v0"], "×", "≥ 1/3", rounds),
        measured(f"VerticalVehicle vector ({n}, static element)", r["static"] / 1e6, "M steps/s"),
        measured(
            "  memory element / static element", r["maxwell"] / r["static"], "×", "≥ 0.85", rounds
        ),
    ]


if __name__ == "__main__":
    for r in run():
        print(r)
