"""The order of calls, enforced by the envs themselves (``gym.make`` adds no
``OrderEnforcing`` wrapper to railgym ids), and the one-read ``outcome(i)`` of the batch
contract equal to the reads it replaces.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import railgym  # noqa: F401  (registers the environments)
from railgym.envs.base import BatchEnv, ResetNeeded

#: short episodes (5 steps), so that a run ends
KWARGS = {
    "railgym/VerticalSuspension-v1": {"backend": "linear", "duration": 0.05},
    "railgym/VerticalSuspension-v2": {"duration": 0.05},
    "railgym/VerticalVehicle-v1": {"backend": "linear", "duration": 0.05},
    "railgym/TrainCrash-v1": {"backend": "reference", "scenario": "envelope", "max_duration": 0.05},
}


def _stack(env: gym.Env) -> list[str]:
    names = []
    while isinstance(env, gym.Wrapper):
        names.append(type(env).__name__)
        env = env.env
    return [*names, type(env).__name__]


@pytest.mark.parametrize("env_id", list(KWARGS))
def test_gym_make_refuses_steps_out_of_order_without_order_enforcing(env_id):
    env = gym.make(env_id, render_mode="rgb_array", **KWARGS[env_id])
    assert "OrderEnforcing" not in _stack(env)
    action = np.zeros(env.action_space.shape, env.action_space.dtype)
    with pytest.raises(gym.error.ResetNeeded, match="reset"):
        env.step(action)
    with pytest.raises(ResetNeeded, match="render"):
        env.render()
    env.reset(seed=1)
    ended = False
    for _ in range(1000):
        *_, terminated, truncated, _info = env.step(action)
        if terminated or truncated:
            ended = True
            break
    assert ended
    # the last frame of an ended episode can still be drawn; a further step cannot be taken
    assert env.render().ndim == 3
    with pytest.raises(RuntimeError, match="reset"):
        env.step(action)
    env.reset(seed=2)
    env.step(action)
    env.close()


@pytest.mark.parametrize("env_id", list(KWARGS))
def test_vector_step_before_reset_is_refused(env_id):
    envs = gym.make_vec(
        env_id, num_envs=2, vectorization_mode="vector_entry_point", **KWARGS[env_id]
    )
    with pytest.raises(gym.error.ResetNeeded, match="reset"):
        envs.step(np.zeros(envs.action_space.shape, envs.action_space.dtype))
    envs.close()


def _assembled(sim, i: int):
    """``(reward, terminated, truncated, info)`` of row ``i`` from the contract's five reads."""
    info = sim.info(i)
    info["reward_terms"] = sim.reward_terms(i)
    terminated = False
    for k, v in sim.flags().items():
        if v[i]:
            info[k] = terminated = True
    truncated = not terminated and bool(sim.truncated()[i])
    return float(sim.reward[i]), terminated, truncated, info


def _equal(a, b) -> bool:
    """Equal ``info`` values: arrays element by element, anything else by ``==``."""
    return bool(np.array_equal(a, b)) if isinstance(a, np.ndarray) else a == b


#: the batches with an ``outcome`` of their own (one row read directly), with and without a
#: damper
OUTCOME_CASES = [
    ("railgym/VerticalSuspension-v1", {}),
    ("railgym/VerticalSuspension-v2", {}),
    ("railgym/VerticalSuspension-v3", {"duration": 0.05, "actuator": "semi-active"}),
    ("railgym/VerticalVehicle-v3", {"duration": 0.05}),
    ("railgym/VerticalVehicle-v3", {"duration": 0.05, "actuator": "semi-active"}),
]


@pytest.mark.parametrize(("env_id", "extra"), OUTCOME_CASES)
def test_outcome_of_each_row_equals_the_reads_it_replaces(env_id, extra):
    """Every row of a vector batch over a whole episode (its truncation included), with large
    random actions; the single env's step returns the same; each row's ``info`` is that row of
    the vector env's arrays."""
    kwargs = {**KWARGS.get(env_id, {}), **extra}
    envs = gym.make_vec(env_id, num_envs=3, vectorization_mode="vector_entry_point", **kwargs)
    envs.reset(seed=3)
    sim = envs.unwrapped.sim
    assert hasattr(sim, "outcome")
    rng = np.random.default_rng(0)
    high = envs.single_action_space.high
    for _ in range(5):
        envs.step(rng.uniform(-high, high, envs.action_space.shape).astype(np.float32))
        for i in range(3):
            got, want = sim.outcome(i), _assembled(sim, i)
            assert got[:3] == want[:3]
            assert got[3].keys() == want[3].keys()
            for k, v in want[3].items():
                assert _equal(got[3][k], v), k
            assert all(type(got[3][k]) is type(v) for k, v in want[3].items())
            every = sim.info()
            assert list(every) == list(got[3])[: len(every)]
            for k, v in every.items():
                assert np.array_equal(v[i], got[3][k]), k
    assert sim.truncated().all()
    envs.close()

    env = gym.make(env_id, **kwargs)
    env.reset(seed=4)
    base = env.unwrapped
    assert isinstance(base, BatchEnv)
    _, reward, terminated, truncated, info = env.step(np.full(env.action_space.shape, 0.5))
    again = base.sim.outcome(0)
    assert (reward, terminated, truncated) == again[:3]
    assert info.keys() == again[3].keys()
    assert all(_equal(v, again[3][k]) for k, v in info.items())
