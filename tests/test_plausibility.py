"""Physical plausibility where a unit or a regime is easy to get wrong: a crash that crushes a
car through, a profile in millimetres, an element fitted on another problem, a surrogate that
leaves the reference's envelope."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import railgym  # noqa: F401  (registers the envs)
from railgym.envs.crash_step import crush_limits
from railgym.vehicles.crash import load_scenario


def _run_crash(env) -> tuple[dict, float, int]:
    env.reset(seed=0)
    steps = 0
    while True:
        _, r, terminated, truncated, info = env.step(np.zeros(env.action_space.shape, np.float32))
        steps += 1
        if terminated or truncated:
            return info, float(r), steps


def test_crush_limits_are_the_car_lengths():
    np.testing.assert_allclose(crush_limits(np.array([27.6, 26.0, 26.0])), [27.6, 26.8, 26.0])


@pytest.mark.parametrize("backend", ["surrogate", "reference"])
@pytest.mark.parametrize("kmh", [400.0, 500.0])
def test_a_crash_that_crushes_the_lead_car_through_diverges(backend, kmh):
    env = gym.make("railgym/TrainCrash-v0", speed=kmh / 3.6, backend=backend)
    info, reward, steps = _run_crash(env)
    length = load_scenario("paper").lead.length
    assert info["diverged"] and reward == -100.0
    # it ends on the step that passes the car's length (one 1 ms step at <= 139 m/s: 0.14 m)
    assert length < info["max_crush_m"][0] < length + 0.14
    assert steps < 300  # long before max_duration (2000 steps)


@pytest.mark.parametrize("backend", ["surrogate", "reference"])
def test_a_fast_crash_the_model_holds_does_not_diverge(backend):
    info, _, _ = _run_crash(gym.make("railgym/TrainCrash-v0", speed=150 / 3.6, backend=backend))
    assert not info["diverged"] and info["max_crush_m"][0] < 27.6


@pytest.mark.parametrize(("kmh", "flagged"), [(40.0, False), (450.0, True)])
def test_the_vector_env_flags_a_train_crushed_through(kmh, flagged):
    venv = gym.make_vec(
        "railgym/TrainCrash-v0", num_envs=2, vectorization_mode="vector_entry_point"
    )
    venv.reset(seed=0, options={"speed_kmh": kmh})
    seen = np.zeros(2, bool)
    for _ in range(300):
        _, _, _, _, info = venv.step(np.zeros(venv.action_space.shape, np.float32))
        seen |= info["diverged"]
    assert seen.tolist() == [flagged, flagged]


def _element_file(tmp_path, **document):
    from surrogates import LegendreRegression, io

    u = np.random.default_rng(0).uniform(-1.0, 1.0, (200, 2))  # another problem: [-1, 1]²
    model = LegendreRegression(degree=3).fit(u, u.sum(axis=1))
    return str(io.save(model, tmp_path / "element.json", **document))


@pytest.mark.parametrize("env_id", ["railgym/VerticalSuspension-v0", "railgym/VerticalVehicle-v0"])
@pytest.mark.parametrize(
    ("document", "message"),
    [
        ({}, r"input 'u1' has no unit in features\.units"),
        (
            {"inputs": ["d", "v"], "output": "F", "units": {"d": "mm", "v": "m/s", "F": "N"}},
            r"input 'd' has unit 'mm'",
        ),
        (
            {"inputs": ["d", "v"], "output": "F", "units": {"d": "m", "v": "m/s", "F": "kN"}},
            r"output 'F' has unit 'kN'",
        ),
    ],
    ids=["no units", "mm", "kN"],
)
def test_an_element_in_other_units_is_refused(tmp_path, env_id, document, message):
    with pytest.raises(ValueError, match=rf"^surrogate .*{message}"):
        gym.make(env_id, surrogate=_element_file(tmp_path, **document))


def test_an_element_in_si_units_is_taken(tmp_path):
    units = {"d": "m", "v": "m/s", "F": "N"}
    path = _element_file(tmp_path, inputs=["d", "v"], output="F", units=units)
    env = gym.make("railgym/VerticalSuspension-v0", surrogate=path, duration=0.1)
    env.reset(seed=0)
