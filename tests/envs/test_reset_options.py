"""Reset options are held for later episodes (docs/envs/*.md, *Reset options*): every reset
reports its case in ``info["case"]``, the first seeded reset without options that runs a held
case warns (once per env), ``options={"hold": False}`` returns to the constructor's case.

All three envs, single (``gym.make``) and vector (``gym.make_vec``, native and sync).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import railgym  # noqa: F401  (registers the environments)
from railgym.track import class_speed

VERTICAL, VEHICLE, CRASH = (
    "railgym/VerticalSuspension-v1",
    "railgym/VerticalVehicle-v1",
    "railgym/TrainCrash-v1",
)
#: short episodes (5 or 50 steps), so that a run crosses autoresets
KWARGS = {
    VERTICAL: {"backend": "linear", "duration": 0.05},
    VEHICLE: {"backend": "linear", "duration": 0.05},
    CRASH: {"backend": "reference", "scenario": "envelope", "max_duration": 0.05},
}
#: options that set a case other than the constructor's
OPTIONS = {
    VERTICAL: {"track_class": 4},
    VEHICLE: {"track_class": 4, "speed": (30.0, 35.0)},
    CRASH: {"speed_kmh": 30.0, "payload_t": 1.0},
}
HELD = "held from an earlier reset"


def _check_case(env_id: str, case: dict[str, Any], held: bool) -> None:
    """``case`` (a single env's ``info["case"]``) is the case of :data:`OPTIONS` (``held``)
    or the constructor's."""
    assert case["from_options"] is held
    if env_id == CRASH:
        assert case["speed_fixed"] is case["payload_fixed"] is held
        if held:
            assert case["speed"] == 30.0 / 3.6
            np.testing.assert_array_equal(case["payload_kg"], [1000.0, 1000.0])
        return
    assert case["track_class"] == (4 if held else 5) and case["profile"] is False
    if env_id == VERTICAL:
        assert case["speed"] == class_speed(4 if held else 5)
    else:
        want = [30.0, 35.0] if held else [class_speed(5)] * 2
        np.testing.assert_array_equal(case["speed_range"], want)
        assert want[0] <= case["speed"] <= want[1]


def _held_warnings(call: Callable[[], Any]) -> tuple[int, Any]:
    """How many held-case warnings ``call()`` gives, and what it returns."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = call()
    return sum(HELD in str(w.message) for w in caught), out


def _make(env_id: str, **kwargs: Any) -> gym.Env:
    return gym.make(env_id, **{**KWARGS[env_id], **kwargs})


def _make_vec(env_id: str, mode: str = "vector_entry_point", **kwargs: Any) -> gym.vector.VectorEnv:
    return gym.make_vec(env_id, num_envs=2, vectorization_mode=mode, **{**KWARGS[env_id], **kwargs})


def _run(env: gym.Env | gym.vector.VectorEnv, steps: int, seed: int = 0) -> list[Any]:
    """Observations, rewards and infos of ``steps`` seeded random steps (autoreset: vector)."""
    rng = np.random.default_rng(seed)
    vector = isinstance(env, gym.vector.VectorEnv)
    out = []
    for _ in range(steps):
        action = rng.uniform(-1.0, 1.0, env.action_space.shape).astype(np.float32)
        obs, reward, term, trunc, info = env.step(action)
        out.append((obs, reward, info))
        if not vector and (term or trunc):
            break
    return out


@pytest.mark.parametrize("env_id", [VERTICAL, VEHICLE, CRASH])
def test_a_seeded_reset_without_options_warns_once_that_it_runs_the_held_case(env_id):
    env = _make(env_id)
    count, (_, info) = _held_warnings(lambda: env.reset(seed=0, options=OPTIONS[env_id]))
    assert count == 0
    _check_case(env_id, info["case"], held=True)
    with pytest.warns(UserWarning, match=HELD + r".*options=\{'hold': False\}") as record:
        _, info = env.reset(seed=1)
    assert sum(HELD in str(w.message) for w in record) == 1
    _check_case(env_id, info["case"], held=True)  # still the held case, and it says so
    for call in (
        lambda: env.reset(seed=2),
        lambda: env.reset(seed=3, options=OPTIONS[env_id]),
        lambda: env.reset(seed=4),
    ):  # once per env
        count, (_, info) = _held_warnings(call)
        assert count == 0
        _check_case(env_id, info["case"], held=True)


@pytest.mark.parametrize("env_id", [VERTICAL, VEHICLE, CRASH])
def test_the_normal_resets_never_warn(env_id):
    def resets() -> list[dict]:
        cases = []
        own = _make(env_id)  # the constructor's case, reset after reset
        for seed in (0, 1, None):
            cases.append(own.reset(seed=seed)[1]["case"])
            _run(own, 3)
        cases.append(own.reset(seed=2, options={"hold": False})[1]["case"])  # nothing held
        every = _make(env_id)  # options on every reset
        for seed in (0, 1):
            every.reset(seed=seed, options=OPTIONS[env_id])
        every.reset()  # the next episode of the run: neither a seed nor options
        every.reset(options={})
        every.reset(seed=3, options={"hold": True})  # keeps the held case, knowingly
        return cases

    count, cases = _held_warnings(resets)
    assert count == 0
    for case in cases:
        _check_case(env_id, case, held=False)


@pytest.mark.parametrize("env_id", [VERTICAL, VEHICLE, CRASH])
def test_hold_false_returns_to_the_constructors_case(env_id):
    env, fresh = _make(env_id), _make(env_id)
    env.reset(seed=0, options=OPTIONS[env_id])
    _run(env, 3)
    count, (obs, info) = _held_warnings(lambda: env.reset(seed=7, options={"hold": False}))
    fresh_obs, fresh_info = fresh.reset(seed=7)
    assert count == 0
    _check_case(env_id, info["case"], held=False)
    assert info["case"].keys() == fresh_info["case"].keys()
    for key, value in fresh_info["case"].items():
        np.testing.assert_array_equal(info["case"][key], value, err_msg=key)
    np.testing.assert_array_equal(obs, fresh_obs)
    for (o, r, _), (fo, fr, _) in zip(_run(env, 60), _run(fresh, 60), strict=True):
        np.testing.assert_array_equal(o, fo)
        assert r == fr
    count, (_, info) = _held_warnings(lambda: env.reset(seed=8))  # nothing held: no warning
    assert count == 0 and info["case"]["from_options"] is False


def test_hold_false_with_other_options_applies_them_to_the_constructors_case():
    env = _make(VERTICAL, track_class=3)
    env.reset(seed=0, options={"track_class": 6, "speed": 20.0})
    _, info = env.reset(seed=0, options={"hold": False, "speed": 30.0})
    assert info["case"] == {"track_class": 3, "speed": 30.0, "profile": False, "from_options": True}


def test_options_equal_to_the_constructors_case_hold_nothing():
    env = _make(VERTICAL, track_class=4)
    _, info = env.reset(seed=0, options={"track_class": 4})
    assert info["case"]["from_options"] is False
    count, _ = _held_warnings(lambda: env.reset(seed=1))
    assert count == 0


@pytest.mark.parametrize("env_id", [VERTICAL, CRASH])
def test_bad_options_leave_the_held_case_unchanged(env_id, assert_names_the_field):
    env = _make(env_id)
    env.reset(seed=0, options=OPTIONS[env_id])
    assert_names_the_field(
        lambda _: env.reset(seed=0, options={"hold": "no"}), TypeError, r"options\['hold'\]"
    )
    bad = {"track_class": 9} if env_id == VERTICAL else {"speed_kmh": 1e9}
    with pytest.raises(ValueError, match="track_class|speed_kmh"):
        env.reset(seed=0, options={"hold": False, **bad})  # the drop is undone too
    _, info = env.reset(seed=0, options={"hold": True})
    _check_case(env_id, info["case"], held=True)


def test_a_track_class_option_resets_the_speed_for_later_options():
    """A new class without a speed runs at that class's speed, also after a later option
    that does not name the speed."""
    env = _make(VERTICAL)
    env.reset(seed=0, options={"speed": 30.0})
    env.reset(seed=0, options={"track_class": 4})
    x = np.linspace(0.0, 100.0, 1001)
    _, info = env.reset(seed=0, options={"profile": (x, np.zeros_like(x))})
    assert info["case"]["speed"] == class_speed(4) and info["case"]["profile"] is True
    _, info = env.reset(seed=0, options={"profile": None})
    assert info["case"]["profile"] is False and info["case"]["track_class"] == 4


@pytest.mark.parametrize("env_id", [VERTICAL, VEHICLE, CRASH])
def test_the_vector_env_reports_each_sub_envs_case_and_warns_once(env_id):
    venv = _make_vec(env_id)
    singles = [_make(env_id) for _ in range(2)]
    count, (_, info) = _held_warnings(lambda: venv.reset(seed=5, options=OPTIONS[env_id]))
    assert count == 0 and info["_case"].all()
    for i, env in enumerate(singles):
        case = env.reset(seed=5 + i, options=OPTIONS[env_id])[1]["case"]
        for key, value in case.items():
            np.testing.assert_array_equal(info["case"][key][i], value, err_msg=key)
            assert info["case"][f"_{key}"][i]
    # autoresets continue the held case without a warning; the step reports it, masked
    count, steps = _held_warnings(lambda: _run(venv, 60))
    assert count == 0
    reset_steps = [info for *_, info in steps if "case" in info]
    assert reset_steps and all(info["_case"].any() for info in reset_steps)
    for info in reset_steps:
        assert info["case"]["from_options"][info["_case"]].all()
    count, _ = _held_warnings(lambda: venv.reset(options={"reset_mask": np.array([True, False])}))
    assert count == 0  # a partial reset continues the run
    count, (_, info) = _held_warnings(lambda: venv.reset(seed=6))
    assert count == 1 and info["case"]["from_options"].all()
    count, (_, info) = _held_warnings(lambda: venv.reset(seed=7))
    assert count == 0  # once per vector env
    count, (_, info) = _held_warnings(lambda: venv.reset(seed=8, options={"hold": False}))
    assert count == 0 and not info["case"]["from_options"].any()


@pytest.mark.parametrize("env_id", [VERTICAL, CRASH])
def test_hold_false_on_the_vector_env_equals_a_fresh_vector_env(env_id):
    venv, fresh = _make_vec(env_id), _make_vec(env_id)
    venv.reset(seed=0, options=OPTIONS[env_id])
    _run(venv, 3)
    obs, info = venv.reset(seed=3, options={"hold": False})
    fresh_obs, fresh_info = fresh.reset(seed=3)
    np.testing.assert_array_equal(obs, fresh_obs)
    for key, value in fresh_info["case"].items():
        np.testing.assert_array_equal(info["case"][key], value, err_msg=key)
    for (o, r, _), (fo, fr, _) in zip(_run(venv, 60), _run(fresh, 60), strict=True):
        np.testing.assert_array_equal(o, fo)
        np.testing.assert_array_equal(r, fr)


def test_gymnasiums_sync_vector_env_autoresets_without_a_warning():
    """SyncVectorEnv resets a finished sub-env with ``reset()``: no seed, no options."""
    venv = _make_vec(VERTICAL, mode="sync")
    count, (_, info) = _held_warnings(lambda: venv.reset(seed=0, options=OPTIONS[VERTICAL]))
    assert count == 0 and (info["case"]["track_class"] == 4).all()
    count, steps = _held_warnings(lambda: _run(venv, 12))
    assert count == 0
    cases = [info["case"] for *_, info in steps if "case" in info]
    assert cases and all((c["track_class"] == 4).all() for c in cases)
    count, _ = _held_warnings(lambda: venv.reset(seed=1))
    assert count == 2  # each sub-env is an env of its own
