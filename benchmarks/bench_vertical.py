"""Vertical env speed against gymnasium's CartPole measured in the same run.

Targets (issue 13): single-env step ≤ 1.3 × CartPole-v1 (issue 32: also ``-v2``, the
successor with Hermite tables; issue 43: ``-v3`` on the surrogate and the reference backend);
vector env (1024) ≥ 25 % of CartPoleVectorEnv's env-steps/s; a 20 s run on the surrogate
≥ 5 × faster than on the reference (the paper's LPR co-simulation reached 51.03/49.64 ≈
1.03 ×). Issue 10: the packaged memory element's step within 10 % of the paper's static
element. Every figure is the median of repeated windows; compared figures are timed in
interleaved rounds (:mod:`benchmarks._timing`).
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

import railgym  # noqa: F401  (registers the environments)
from benchmarks import measured
from benchmarks._stepping import per_step_us, rate, split_us, steps, vector_steps
from benchmarks._timing import interleaved
from railgym.track import track_time_input
from railgym.vehicles.collect import default_vertical_surrogate
from railgym.vehicles.vertical.params import load_vehicle
from railgym.vehicles.vertical.simulate import simulate


def run() -> list[dict]:
    """Rows of measurements (see ``benchmarks/__main__.py``)."""
    return _single_rows() + _vector_rows() + _run_rows()


def _single_rows() -> list[dict]:
    """Single-env step times against CartPole-v1, measured interleaved."""
    zero = np.zeros(1, np.float32)
    cart = steps(gym.make("CartPole-v1"), lambda k: k % 2)
    fns = {"cart": cart}
    envs = {}
    for backend in ("surrogate", "reference", "linear"):
        envs[backend] = gym.make("railgym/VerticalSuspension-v1", backend=backend)
        fns[backend] = steps(envs[backend], lambda k: zero)
    for version in ("v2", "v3"):
        envs[version] = gym.make(f"railgym/VerticalSuspension-{version}")
        fns[version] = steps(envs[version], lambda k: zero)
    envs["v3 reference"] = gym.make("railgym/VerticalSuspension-v3", backend="reference")
    fns["v3 reference"] = steps(envs["v3 reference"], lambda k: zero)
    static = default_vertical_surrogate("static")
    fns["static"] = steps(
        gym.make("railgym/VerticalSuspension-v1", surrogate=static), lambda k: zero
    )
    t = {name: per_step_us(fns[name], w.seconds) for name, w in interleaved(fns).items()}
    rows = [measured("CartPole-v1 step (anchor)", t["cart"], "µs", context="gym.make, same run")]
    for backend in ("surrogate", "reference", "linear"):
        target = "≤ 1.3" if backend == "surrogate" else ""
        context = "10 RK4 substeps" + (", memory element" if backend == "surrogate" else "")
        rows += [
            measured(f"VerticalSuspension step ({backend})", t[backend], "µs", context=context),
            measured(f"  ratio to CartPole ({backend})", t[backend] / t["cart"], "×", target),
        ]
        if backend == "surrogate":
            compiled, shell = split_us(envs[backend], zero)
            rows += [
                measured(
                    "  of which the compiled call",
                    compiled,
                    "µs",
                    context="kernel + bookkeeping, own windows",
                ),
                measured(
                    "  of which the Python shell", shell, "µs", context="check, info, obs, wrappers"
                ),
            ]
    compiled, shell = split_us(envs["v2"], zero)
    rows += [
        measured("VerticalSuspension-v2 step", t["v2"], "µs", context="Hermite tables"),
        measured("  ratio to CartPole (v2)", t["v2"] / t["cart"], "×", "≤ 1.3"),
        measured("  of which the compiled call", compiled, "µs", context="own windows"),
        measured("  of which the Python shell", shell, "µs", context="own windows"),
        measured("VerticalSuspension-v3 step", t["v3"], "µs", context="streamed track"),
        measured("  ratio to CartPole (v3)", t["v3"] / t["cart"], "×", "≤ 1.3"),
        measured("  ratio to CartPole (v3 reference)", t["v3 reference"] / t["cart"], "×", "≤ 1.3"),
        measured("  v3 / v2 step", t["v3"] / t["v2"], "×", context="the track generated per step"),
        measured(
            "  v3 surrogate / reference step",
            t["v3"] / t["v3 reference"],
            "×",
            "≤ 1.0",
            context="single env",
        ),
        measured(
            "VerticalSuspension step (static element)", t["static"], "µs", context="paper's F(δ, δ̇)"
        ),
        measured("  memory / static element step", t["surrogate"] / t["static"], "×", "≤ 1.10"),
    ]
    return rows


def _vector_rows() -> list[dict]:
    """The vector env's env-steps/s against CartPoleVectorEnv's, measured interleaved."""
    n = 1024
    mode = "vector_entry_point"
    cart_vec = gym.make_vec("CartPole-v1", num_envs=n, vectorization_mode=mode)
    venv = gym.make_vec("railgym/VerticalSuspension-v1", num_envs=n, vectorization_mode=mode)
    vfns = {
        "cart": vector_steps(cart_vec, np.ones(n, np.int64), 100),
        "env": vector_steps(venv, np.zeros((n, 1), np.float32), 10),
    }
    w = interleaved(vfns)
    r_cart, r = (rate(vfns[k], w[k].seconds) for k in ("cart", "env"))
    return [
        measured(
            f"CartPoleVectorEnv ({n}) (anchor)", r_cart / 1e6, "M steps/s", context="same run"
        ),
        measured(f"VerticalSuspension vector ({n}, surrogate)", r / 1e6, "M steps/s"),
        measured("  share of CartPoleVectorEnv", 100 * r / r_cart, "%", "≥ 25"),
    ]


def _run_rows() -> list[dict]:
    """A 20 s run on the surrogate against the dynamic reference."""
    veh = load_vehicle("manchester")
    _, z, zdot = track_time_input(5, 40.0, 20.0, 1e-3, seed=0)
    model = default_vertical_surrogate()
    w = interleaved(
        {
            variant: lambda v=variant: simulate(
                v, veh, z, zdot, 1e-3, surrogate=model, sample_every=20
            )
            for variant in ("surrogate", "dynamic")
        }
    )
    paper = "paper T_s: LPR 48.31 s, Simpack 51.03 s"
    rows = []
    for variant in ("surrogate", "dynamic"):
        rows.append(measured(f"20 s run, {variant}", w[variant].seconds * 1e3, "ms", context=paper))
    ratio = w["dynamic"].seconds / w["surrogate"].seconds
    rows.append(measured("  reference / surrogate time", ratio, "×", "≥ 5", "paper: 1.03 ×"))
    return rows


if __name__ == "__main__":
    for r in run():
        print(r)
