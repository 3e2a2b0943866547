"""``VerticalSuspension-v1`` with ``actuator="semi-active"`` on the surrogate backend: the
damper's data-driven element (:mod:`railgym.vehicles.semi_active_element`) in the kernels."""

from __future__ import annotations

from importlib import resources

import gymnasium as gym
import numpy as np
import pytest

import railgym  # noqa: F401  (registers the environments)
from railgym._checks import FieldError
from railgym.vehicles.semi_active_element import load_damper_element
from railgym.vehicles.vertical.elements import DAMPER_LAWS

ENV_ID = "railgym/VerticalSuspension-v1"
SEMI = {"actuator": "semi-active"}


def _law(env: gym.Env) -> int:
    return env.unwrapped.sim.damper.law


def test_surrogate_backend_runs_the_element_and_the_others_the_exact_law():
    assert _law(gym.make(ENV_ID, **SEMI)) == DAMPER_LAWS["element"]
    for backend in ("reference", "linear"):
        assert _law(gym.make(ENV_ID, backend=backend, **SEMI)) == DAMPER_LAWS["exact"]
    env = gym.make(ENV_ID, **SEMI)
    assert env.unwrapped.sim.damper.element.length == load_damper_element().length


def test_element_only_dissipates_under_random_commands():
    """Every step's damper power ``F·v`` (``v = ẋ1 − ẋ2`` at the end of the step) is ≥ 0 over
    an episode of random commands on a class-6 track, and the damper does work."""
    env = gym.make(ENV_ID, backend="surrogate", track_class=6, duration=3.0, **SEMI)
    env.reset(seed=4)
    rng = np.random.default_rng(5)
    powers = []
    for _ in range(300):
        info = env.step(rng.uniform(0.0, 1.0, 1).astype(np.float32))[4]
        x = env.unwrapped.state
        powers.append(info["damper_force"] * (x[1] - x[3]))
    powers = np.array(powers)
    assert powers.min() >= 0.0
    assert np.count_nonzero(powers) > 150 and powers.sum() * 0.01 > 1.0  # J


def _carbody_acc(backend: str, seed: int, commands: np.ndarray) -> np.ndarray:
    env = gym.make(ENV_ID, backend=backend, track_class=5, duration=len(commands) * 0.01, **SEMI)
    env.reset(seed=seed)
    return np.array([env.step(np.array([c], np.float32))[4]["carbody_acc"] for c in commands])


@pytest.mark.parametrize("seed", [0, 1])
def test_surrogate_follows_the_reference_carbody_acceleration(seed):
    """The same random commands (held 0.1 s) on the same class-5 track for 5 s: relative RMS
    error of the surrogate's carbody acceleration against the reference's at most 5 % (the
    linear backend, the exact damper on a linear suspension, is off by more than 10 %)."""
    commands = np.repeat(np.random.default_rng(seed).uniform(0.0, 1.0, 50), 10)
    ref = _carbody_acc("reference", seed, commands)
    err = np.linalg.norm(_carbody_acc("surrogate", seed, commands) - ref) / np.linalg.norm(ref)
    lin = np.linalg.norm(_carbody_acc("linear", seed, commands) - ref) / np.linalg.norm(ref)
    assert err <= 0.05 and lin > 0.10


def test_damper_element_argument(tmp_path):
    """``damper_element=``: a packaged name or a ``.json`` path on the surrogate backend;
    refused with the force actuator, ignored with a warning by another backend, required for
    a damper without a packaged element; errors name the field."""
    path = load_damper_element().save(tmp_path / "element.json")
    by_path = gym.make(ENV_ID, damper_element=str(path), **SEMI)
    packaged = gym.make(ENV_ID, damper_element="mr_secondary", **SEMI)
    np.testing.assert_array_equal(
        by_path.unwrapped.sim.damper.element.coef, packaged.unwrapped.sim.damper.element.coef
    )
    with pytest.warns(UserWarning, match="damper_element is ignored"):
        gym.make(ENV_ID, backend="reference", damper_element="mr_secondary", **SEMI)
    with pytest.raises(FieldError, match="damper_element"):
        gym.make(ENV_ID, damper_element="mr_secondary")
    for bad in ("missing", str(tmp_path / "missing.json"), 3):
        with pytest.raises(FieldError, match="damper_element"):
            gym.make(ENV_ID, damper_element=bad, **SEMI)
    yaml_damper = tmp_path / "copy.yaml"
    yaml_damper.write_text(
        (resources.files("railgym") / "configs" / "dampers" / "mr_secondary.yaml").read_text()
    )
    with pytest.raises(FieldError, match="damper_element"):
        gym.make(ENV_ID, damper=str(yaml_damper), **SEMI)
    env = gym.make(ENV_ID, damper=str(yaml_damper), damper_element=str(path), **SEMI)
    assert _law(env) == DAMPER_LAWS["element"]
