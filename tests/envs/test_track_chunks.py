"""Chunked track mode (issue 32, item 5): a vector env whose whole-episode tracks do not fit
holds a window of each track and draws the next window again from the episode's seed, bit for
bit the values of the whole arrays; memory per sub-env does not grow with the episode."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import railgym.envs.vertical.batch as vertical_batch
from railgym.envs.track_shell import TRACK_BYTES
from railgym.track import track_time_input, track_time_window


def _arrays(obj: Any, seen: set[int], depth: int = 0) -> Iterator[np.ndarray]:
    """The numpy arrays ``obj`` holds (attributes, tuples, lists, dicts), each owner once."""
    if isinstance(obj, np.ndarray):
        owner = obj
        while isinstance(owner.base, np.ndarray):
            owner = owner.base
        if id(owner) not in seen:
            seen.add(id(owner))
            yield owner
        return
    if depth > 4:
        return
    if isinstance(obj, dict):
        items = list(obj.values())
    elif isinstance(obj, tuple | list):
        items = list(obj)
    elif type(obj).__module__.startswith("railgym") and hasattr(obj, "__dict__"):
        items = list(vars(obj).values())
    else:
        return
    for item in items:
        yield from _arrays(item, seen, depth + 1)


def batch_bytes(sim: Any) -> int:
    """Bytes of all the numpy arrays a batch holds."""
    return sum(a.nbytes for a in _arrays(sim, set()))


def test_track_time_window_matches_whole_track() -> None:
    _, z, zdot = track_time_input(5, 70.0, 2.0, 1e-3, 3, wheelbase=2.5)
    for start, count in ((0, 10), (500, 1501), (1990, 11)):
        wz, wzd = track_time_window(5, 70.0, 2.0, 1e-3, 3, start, count, wheelbase=2.5)
        np.testing.assert_array_equal(wz, z[start : start + count])
        np.testing.assert_array_equal(wzd, zdot[start : start + count])
    with pytest.raises(ValueError, match="outside the samples"):
        track_time_window(5, 70.0, 2.0, 1e-3, 3, 1990, 12)


def _rollout(env_id: str, n: int, steps: int, kw: dict[str, Any]) -> tuple[list, Any]:
    venv = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", **kw)
    obs, _ = venv.reset(seed=11)
    out = [obs]
    rng = np.random.default_rng(2)
    low, high = venv.single_action_space.low, venv.single_action_space.high
    for _ in range(steps):
        act = rng.uniform(low, high, (n, low.size)).astype(np.float32)
        obs, rew, term, trunc, info = venv.step(act)
        out += [obs, rew, term, trunc, info["carbody_acc"], info["time"]]
    return out, venv.unwrapped.sim


VERTICAL_CASES = [
    ("railgym/VerticalSuspension-v2", {}),
    ("railgym/VerticalSuspension-v2", {"backend": "reference", "speed": 30.0}),
    ("railgym/VerticalSuspension-v1", {"backend": "linear", "observation": "full"}),
    ("railgym/VerticalSuspension-v2", {"actuator": "semi-active"}),
    (
        "railgym/VerticalSuspension-v2",
        {"profile": (np.linspace(0.0, 80.0, 801), 1e-3 * np.sin(np.linspace(0.0, 40.0, 801)))},
    ),
]


@pytest.mark.filterwarnings("ignore:VerticalSuspension. the surrogate element")
@pytest.mark.parametrize(("env_id", "kw"), VERTICAL_CASES)
def test_vertical_chunked_equals_whole(
    monkeypatch: pytest.MonkeyPatch, env_id: str, kw: dict[str, Any]
) -> None:
    """Windows of 37 samples (3 control steps of 10 substeps) reproduce the whole tracks bit
    for bit over 2.5 episodes of 1 s, autoreset included."""
    kw = {"duration": 1.0, **kw}
    whole, sim = _rollout(env_id, 3, 250, kw)
    assert sim.window is None
    monkeypatch.setattr(vertical_batch, "_FORCED_WINDOW", 37)
    chunked, sim_c = _rollout(env_id, 3, 250, kw)
    assert sim_c.window == 37 and sim_c.z.shape == (3, 37)
    assert len(whole) == len(chunked)
    for a, b in zip(whole, chunked, strict=True):
        np.testing.assert_array_equal(a, b)
    for i in range(3):
        z, zdot = sim.track_arrays(i)
        zc, zdotc = sim_c.track_arrays(i)
        np.testing.assert_array_equal(z, zc)
        np.testing.assert_array_equal(zdot, zdotc)
        at = int(sim_c.base[i])
        np.testing.assert_array_equal(sim_c.z[i], z[at : at + 37])
        assert int(sim_c.base[i] + sim_c.k[i]) == int(sim.k[i])


def test_vertical_chunked_runs_past_the_end_as_whole(monkeypatch: pytest.MonkeyPatch) -> None:
    """The last window ends at the episode's last sample: stepping the batch past the end
    raises as it does with whole tracks."""
    monkeypatch.setattr(vertical_batch, "_FORCED_WINDOW", 25)
    venv = gym.make_vec(
        "railgym/VerticalSuspension-v2",
        num_envs=2,
        vectorization_mode="vector_entry_point",
        duration=0.2,
    )
    venv.reset(seed=0)
    sim = venv.unwrapped.sim
    for _ in range(20):
        sim.advance()
    assert int(sim.base[0]) + sim.z.shape[1] == sim.n_samples
    with pytest.raises(ValueError, match="track index out of range"):
        sim.advance()


@pytest.mark.parametrize(
    "env_id", ["railgym/VerticalSuspension-v1", "railgym/VerticalSuspension-v2"]
)
def test_vertical_16384_envs_fit(env_id: str) -> None:
    """16384 sub-envs of 20-s episodes hold at most 1 GiB of arrays, the tracks in windows."""
    venv = gym.make_vec(env_id, num_envs=16384, vectorization_mode="vector_entry_point")
    sim = venv.unwrapped.sim
    assert sim.window is not None and sim.window < sim.n_samples
    assert batch_bytes(sim) <= TRACK_BYTES
