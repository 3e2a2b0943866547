"""Crash models and TrainCrash-v1 speed, with gymnasium's CartPole measured in the same run.

Targets (issue 4): surrogate ≥ 100 × faster than our reference for the default scenario (the
paper: LS-DYNA 51 548 s vs 8 s); one full crash episode on the surrogate env ≤ 5 ms; vector
env env-steps/s at 1024 sub-envs and the single-env step, both against CartPole. Every figure
is the median of repeated windows after a warm-up call, compared figures timed in interleaved
rounds (:mod:`benchmarks._timing`). Issue 13: the compiled surrogate episode ≤ 0.08 ms; the
vector env ≥ 50 % of CartPoleVectorEnv.

Our reference is a lumped-mass chain of 16 masses, not a finite-element model: it is only a few
times slower than the 2-mass surrogate, so the paper's ratio is out of reach by construction.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

import railgym  # noqa: F401  (registers the environments)
from benchmarks import measured
from benchmarks._stepping import per_step_us, rate, steps, vector_steps
from benchmarks._timing import interleaved, windows
from railgym.vehicles.crash.reference import simulate_reference
from railgym.vehicles.crash.scenario import load_scenario
from railgym.vehicles.crash.surrogate import build_crash_surrogate
from railgym.vehicles.crash.surrogate_model import simulate_surrogate

N_VEC = 1024


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


def run() -> list[dict]:
    """Rows of measurements (see ``benchmarks/__main__.py``)."""
    return _model_rows() + _env_rows()


def _model_rows() -> list[dict]:
    """The reference and surrogate crash models on the paper's scenario."""
    sc = load_scenario("paper")
    ref = simulate_reference(sc)
    masses = sc.lead.n_nodes + (sc.n_cars - 1) * sc.passenger.n_nodes
    surrogates = {v: build_crash_surrogate(ref, variant=v, seed=0) for v in ("hysteretic", "paper")}
    fns = {"reference": lambda: simulate_reference(sc)}
    fns |= {v: lambda s=sur: simulate_surrogate(sc, s) for v, sur in surrogates.items()}
    t = {name: w.seconds for name, w in interleaved(fns).items()}
    rows = [
        measured(
            f"crash reference run (paper, {sc.n_cars} cars, {sc.speed * 3.6:.0f} km/h)",
            t["reference"] * 1e3,
            "ms",
            context=f"{ref.t[-1]:.3f} s simulated, {masses} masses, dt {ref.dt:.1e} s",
        )
    ]
    for variant, sur in surrogates.items():
        res = simulate_surrogate(sc, sur)
        rows += [
            measured(
                f"crash surrogate run ({variant})",
                t[variant] * 1e3,
                "ms",
                "≤ 0.08" if variant == "hysteretic" else "",
                context=f"{res.t[-1]:.3f} s simulated, dt {res.dt:.1e} s",
            ),
            measured(
                f"  reference / surrogate ({variant})",
                t["reference"] / t[variant],
                "×",
                "≥ 100",
                "paper: FE 51 548 s vs 8 s",
            ),
        ]
    return rows


def _env_rows() -> list[dict]:
    """``TrainCrash-v1`` (episode, step, vector env) beside CartPole."""
    env = gym.make("railgym/TrainCrash-v1")
    n_steps = _episode(env)
    t_ep = windows(lambda: _episode(env)).seconds
    rows = [
        measured(
            "TrainCrash-v1 passive episode (surrogate)",
            t_ep * 1e3,
            "ms",
            "≤ 5",
            f"{n_steps} steps of 1 ms, gym.make",
        )
    ]
    zero = np.zeros(env.action_space.shape, np.float32)
    fns = {
        "cart": steps(gym.make("CartPole-v1"), lambda k: k % 2),
        "crash": steps(env, lambda k: zero),
    }
    w = interleaved(fns)
    t_cart, t_crash = (per_step_us(fns[k], w[k].seconds) for k in ("cart", "crash"))
    rows += [
        measured("CartPole-v1 step (anchor)", t_cart, "µs", context="gym.make, same run"),
        measured("TrainCrash-v1 step (surrogate)", t_crash, "µs", context="2 substeps of 0.5 ms"),
        measured("  ratio to CartPole", t_crash / t_cart, "×"),
    ]
    mode = "vector_entry_point"
    cart_vec = gym.make_vec("CartPole-v1", num_envs=N_VEC, vectorization_mode=mode)
    venv = gym.make_vec("railgym/TrainCrash-v1", num_envs=N_VEC, vectorization_mode=mode)
    fns = {
        "cart": vector_steps(cart_vec, np.ones(N_VEC, np.int64), 100),
        "crash": vector_steps(venv, np.zeros((N_VEC,) + zero.shape, np.float32), 20),
    }
    w = interleaved(fns)
    r_cart, r_crash = (rate(fns[k], w[k].seconds) for k in ("cart", "crash"))
    rows += [
        measured(
            f"CartPoleVectorEnv ({N_VEC}) (anchor)", r_cart / 1e6, "M steps/s", context="same run"
        ),
        measured(
            f"TrainCrash vector ({N_VEC}, surrogate)",
            r_crash / 1e6,
            "M steps/s",
            context="autoreset included",
        ),
        measured("  share of CartPoleVectorEnv", 100 * r_crash / r_cart, "%", "≥ 50"),
    ]
    return rows


if __name__ == "__main__":
    for r in run():
        print(r)
