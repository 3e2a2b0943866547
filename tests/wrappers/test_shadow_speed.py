"""What ``ReferenceShadow``'s ``speedup`` compared, stated beside it in ``info["shadow"]``:
the backends, their batch calls and the steps timed."""

from types import SimpleNamespace

import gymnasium as gym
import numpy as np
import pytest

import railgym  # noqa: F401  (registers the environments)
import railgym.wrappers.reference_shadow as rs
from railgym.envs.vertical.batch import VerticalBatch
from railgym.wrappers import ReferenceShadow

ENV_ID = "railgym/VerticalSuspension-v1"


def test_speedup_states_what_it_compared(monkeypatch):
    """On a clock that moves 2 µs a step in the surrogate's batch call and 8 µs in the
    reference's, ``speedup`` is 4 and ``speedup_compared`` names both backends, their calls
    and the 20 steps of the episode."""
    clock = [0.0]
    monkeypatch.setattr(rs, "time", SimpleNamespace(perf_counter=lambda: clock[0]))
    advance, cost = VerticalBatch.advance, {"surrogate": 2e-6, "dynamic": 8e-6}

    def costly(sim):
        clock[0] += cost[sim.cfg.variant]
        advance(sim)

    monkeypatch.setattr(VerticalBatch, "advance", costly)
    env = ReferenceShadow(gym.make(ENV_ID, duration=0.2))
    env.reset(seed=0)
    zero = np.zeros(1, np.float32)
    while True:
        *_, term, trunc, info = env.step(zero)
        if term or trunc:
            break
    env.close()
    s = info["shadow"]
    assert s["steps"] == 20 and s["speedup"] == pytest.approx(4.0, rel=1e-9)
    assert s["speedup_compared"] == (
        "median time per control step in sim.advance, backend 'reference' (compiled per-env "
        "kernel) over backend 'surrogate' (compiled per-env kernel), over 20 steps of this "
        "episode, one vehicle per call, Python shell excluded; not the lane kernel of vector envs"
    )


def test_speedup_compared_names_the_fmu_and_unequal_step_counts():
    """A shadow that stopped early (its divergence) times fewer steps than the wrapped env;
    an FMU reference is timed in its FMU calls."""
    text = rs._compared("surrogate", "fmu", 30, 12)
    assert "backend 'fmu' (FMU calls through FMPy) over backend 'surrogate'" in text
    assert "over 30 and 12 steps of this episode" in text
