"""Whole-episode throughput of the envs, resets and window moves included.

The other env benchmarks time windows of steps and take their median, so the rare step that
resets every sub-env (a new track each: two inverse FFTs of the episode's grid) falls out of
the figure. Here one sample is one whole episode of every sub-env: the 2 000 steps of a 20 s
episode and the autoreset step that draws the next tracks, zero actions, default settings and
numba threads. At 16 384 sub-envs the tracks do not fit whole and are held in windows
(chunked mode, docs/envs/vertical.md), so the sample also holds the window moves. A crash
sample is ``max_duration``'s steps (and one), in which every train's passive crash ends
(``crash_over``, about 0.46 s) and is reset several times. Issue 32's
target: the throughput from 1 024 to 16 384 sub-envs does not fall (``16 384 / 1 024 ≥ 1``).
Issue 43's: the streamed versions (v3, no track arrays, no window moves) at 1 024 sub-envs at
least 1.4 × v2's, and at 16 384 and 65 536 at least 0.95 × their own at 1 024.
"""

from __future__ import annotations

import time

import gymnasium as gym
import numpy as np

import railgym  # noqa: F401  (registers the environments)
from benchmarks import measured, row
from railgym.progress import bar

ENV_IDS = (
    "railgym/VerticalSuspension-v2",
    "railgym/VerticalSuspension-v3",
    "railgym/VerticalVehicle-v2",
    "railgym/VerticalVehicle-v3",
    "railgym/TrainCrash-v1",
)
#: sub-env counts per env (the streamed v3 up to the vector envs' limit)
SIZES = {
    env_id: (1024, 16384, 65536) if env_id.endswith("-v3") else (1024, 16384) for env_id in ENV_IDS
}
#: whole episodes timed per size (each one sample)
EPISODES = {1024: 3, 16384: 1, 65536: 1}
#: the streamed versions and the version they are compared with at 1 024 sub-envs (issue 43)
STREAMED = {
    "railgym/VerticalSuspension-v3": "railgym/VerticalSuspension-v2",
    "railgym/VerticalVehicle-v3": "railgym/VerticalVehicle-v2",
}


def episode_rates(env_id: str, n: int, episodes: int) -> np.ndarray:
    """Env-steps/s of ``n`` sub-envs of ``env_id``, one sample per whole episode (its steps
    and the autoreset step after it; for the crash, ``max_duration``'s steps)."""
    venv = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point")
    try:
        venv.reset(seed=0)
        steps = venv.unwrapped.sim.cfg.n_steps + 1  # an episode and the step that resets it
        action = np.zeros(venv.action_space.shape, venv.action_space.dtype)
        venv.step(action)  # the first step after reset is part of no sample
        rates = []
        for _ in bar(range(episodes), desc=f"{env_id} × {n} episodes"):
            t0 = time.perf_counter()
            for _ in range(steps):
                venv.step(action)
            rates.append(n * steps / (time.perf_counter() - t0))
        return np.array(rates)
    finally:
        venv.close()


def run() -> list[dict]:
    """Rows of measurements (see ``benchmarks/__main__.py``): per env, the env-steps/s over
    whole episodes at each size and the ratio of the largest to the smallest."""
    rows = []
    at_1024: dict[str, float] = {}
    for env_id in ENV_IDS:
        sizes = SIZES[env_id]
        rates = {n: episode_rates(env_id, n, EPISODES[n]) for n in sizes}
        for n, r in rates.items():
            rows.append(measured(f"{env_id} × {n}, whole episodes", r / 1e6, "M steps/s"))
        at_1024[env_id] = float(np.median(rates[sizes[0]]))
        target = "≥ 0.95" if env_id in STREAMED else "≥ 1"
        for n in sizes[1:]:
            ratio = float(np.median(rates[n])) / at_1024[env_id]
            rows.append(row(f"  {n} / {sizes[0]} sub-envs", ratio, "×", target))
        if env_id in STREAMED:
            ratio = at_1024[env_id] / at_1024[STREAMED[env_id]]
            rows.append(row("  streamed / v2 at 1 024 sub-envs", ratio, "×", "≥ 1.4"))
    return rows
