"""Each registered env version keeps its results (Gymnasium bumps an env's version whenever
results change): a seeded episode of every registered railgym env, on every backend, under a
seeded action sequence, reproduces its stored return, observation sum and length.

A change of physics, elements or defaults that moves these figures needs a new version (with a
*Version history* entry in the env's docs), not new figures here. Relative tolerance 1e-6:
compiled code may round differently on another CPU.
"""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest

import railgym  # noqa: F401
from railgym.registration import ENVS

#: (env id, backend) -> (steps, return, sum of |observation|) of :func:`_episode`
FIGURES: dict[tuple[str, str], tuple[int, float, float]] = {
    ("railgym/VerticalSuspension-v0", "surrogate"): (2000, -2525.433052754019, 6518.928181111813),
    ("railgym/VerticalSuspension-v0", "reference"): (2000, -2563.622377679609, 6558.676906824112),
    ("railgym/VerticalSuspension-v1", "surrogate"): (2000, -2525.5788483050574, 6518.3905583024025),
    ("railgym/VerticalSuspension-v1", "reference"): (2000, -2563.622377679609, 6558.676906824112),
    ("railgym/VerticalSuspension-v2", "surrogate"): (2000, -2525.5788506032027, 6518.390561133623),
    ("railgym/VerticalSuspension-v2", "reference"): (2000, -2563.622377679609, 6558.676906824112),
    ("railgym/VerticalSuspension-v3", "surrogate"): (2000, -2492.658045217547, 6412.041153401136),
    ("railgym/VerticalSuspension-v3", "reference"): (2000, -2512.2437897890973, 6432.992582514882),
    ("railgym/VerticalVehicle-v0", "surrogate"): (2000, -3174.296289179717, 10816.840341687202),
    ("railgym/VerticalVehicle-v0", "reference"): (2000, -3316.370003421834, 10794.997714400291),
    ("railgym/VerticalVehicle-v1", "surrogate"): (2000, -3309.0886829455762, 10783.883130550385),
    ("railgym/VerticalVehicle-v1", "reference"): (2000, -3316.370003421834, 10794.997714400291),
    ("railgym/VerticalVehicle-v2", "surrogate"): (2000, -3309.088706069216, 10783.883181810379),
    ("railgym/VerticalVehicle-v2", "reference"): (2000, -3316.370003421834, 10794.997714400291),
    ("railgym/VerticalVehicle-v3", "surrogate"): (2000, -3491.6591782330624, 11001.653448581696),
    ("railgym/VerticalVehicle-v3", "reference"): (2000, -3500.165321847752, 11016.929182052612),
    ("railgym/TrainCrash-v0", "surrogate"): (458, -203.9223247835869, 3201.7601475715637),
    ("railgym/TrainCrash-v0", "reference"): (451, -198.0368619824061, 3158.0491943359375),
    ("railgym/TrainCrash-v1", "surrogate"): (452, -198.59731228180547, 3164.5626471042633),
    ("railgym/TrainCrash-v1", "reference"): (451, -198.0368619824061, 3158.0491943359375),
}


def _episode(env_id: str, backend: str) -> tuple[int, float, float]:
    with warnings.catch_warnings():  # gymnasium's "out of date" notice of the v0 versions
        warnings.simplefilter("ignore", DeprecationWarning)
        env = gym.make(env_id, backend=backend)
    rng = np.random.default_rng(7)
    obs, _ = env.reset(seed=3)
    steps, ret, l1 = 0, 0.0, float(np.abs(obs).sum())
    done = False
    while not done and steps < 3000:
        action = rng.uniform(-1.0, 1.0, env.action_space.shape).astype(np.float32)
        obs, reward, terminated, truncated, _ = env.step(action)
        steps, ret, l1 = steps + 1, ret + float(reward), l1 + float(np.abs(obs).sum())
        done = terminated or truncated
    env.close()
    return steps, ret, l1


def test_v0_versions_keep_the_figures_of_railgym_0_2():
    """v0 of each env reproduces the seeded episodes measured on railgym 0.2 (bfb1b67);
    v1 changes the surrogate backend only (the reference is the same model)."""
    for name in ("VerticalSuspension", "VerticalVehicle", "TrainCrash"):
        old, new = f"railgym/{name}-v0", f"railgym/{name}-v1"
        assert FIGURES[(old, "reference")] == FIGURES[(new, "reference")]
        assert FIGURES[(old, "surrogate")] != FIGURES[(new, "surrogate")]


def test_every_registered_version_has_figures():
    assert set(FIGURES) == {(i, b) for i in ENVS for b in ("surrogate", "reference")}


@pytest.mark.parametrize("case", sorted(FIGURES), ids=lambda c: f"{c[0]}-{c[1]}")
def test_seeded_episode_of_a_registered_version_is_unchanged(case):
    steps, ret, l1 = _episode(*case)
    want = FIGURES[case]
    assert steps == want[0]
    np.testing.assert_allclose([ret, l1], want[1:], rtol=1e-6)


def _carbody_acceleration(env_id: str, backend: str) -> np.ndarray:
    """Carbody acceleration (m/s²) of a passive 20 s class-5 episode (seed 2000)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        env = gym.make(env_id, backend=backend, track_class=5)
    env.reset(seed=2000)
    acc, done = [], False
    while not done:
        *_, terminated, truncated, _ = env.step(np.zeros(env.action_space.shape, np.float32))
        acc.append(env.unwrapped.carbody_acceleration)
        done = terminated or truncated
    env.close()
    return np.array(acc)


def test_v2_of_the_vertical_suspension_keeps_the_element_and_its_fidelity():
    """v2 evaluates v1's element by its Hermite tables: the carbody acceleration of a passive
    episode moves by far less than the fidelity target, and stays within the target (median
    relative RMS error ≤ 5 %, docs/envs/vertical.md) against the reference."""
    v1 = _carbody_acceleration("railgym/VerticalSuspension-v1", "surrogate")
    v2 = _carbody_acceleration("railgym/VerticalSuspension-v2", "surrogate")
    ref = _carbody_acceleration("railgym/VerticalSuspension-v2", "reference")
    assert 0.0 < np.linalg.norm(v2 - v1) / np.linalg.norm(v1) < 1e-5
    assert np.linalg.norm(v2 - ref) / np.linalg.norm(ref) < 0.05
