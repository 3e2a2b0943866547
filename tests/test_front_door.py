"""Every env's bad-argument table run through the entry points a user calls, ``gym.make`` and
``gym.make_vec``: the error keeps its type and names the field.

gymnasium's ``make`` re-raises a ``TypeError`` from an env constructor as ``type(e)(text)``
with one argument, so the project's error classes must be constructible that way.
"""

from __future__ import annotations

import gymnasium as gym
import pytest

import railgym  # noqa: F401  (registers the envs)
from railgym._checks import FieldError, FieldTypeError
from tests.envs.crash import test_bad_inputs_crash as crash_table
from tests.envs.vehicle import test_bad_inputs_vehicle as vehicle_table
from tests.envs.vertical import test_bad_inputs_vertical as vertical_table

TABLES = {
    "railgym/VerticalSuspension-v1": vertical_table,
    "railgym/VerticalVehicle-v1": vehicle_table,
}


def _constructor_rows() -> list[tuple[str, str, object, type, str]]:
    """Rows of the vertical and vehicle tables that build an env (``_env``/``_venv``)."""
    rows = []
    for env_id, module in TABLES.items():
        for name, call, error, field in module.ROWS:
            names = call.__code__.co_names
            if "_env" in names or "_venv" in names:
                rows.append((env_id, name, call, error, field))
    return rows


ROWS = _constructor_rows()


def _make(env_id):
    def make(**kw):
        return gym.make(env_id, **kw)

    return make


def _make_vec(env_id, default_num_envs=1):
    def make_vec(**kw):
        num_envs = kw.pop("num_envs", default_num_envs)
        return gym.make_vec(
            env_id, num_envs=num_envs, vectorization_mode="vector_entry_point", **kw
        )

    return make_vec


@pytest.mark.parametrize(
    ("env_id", "call", "error", "field"),
    [r[0:1] + r[2:] for r in ROWS],
    ids=[f"{r[0].split('/')[1]}-{r[1]}" for r in ROWS],
)
@pytest.mark.parametrize("entry", ["make", "make_vec"])
def test_table_through_gym_make(
    monkeypatch, assert_names_the_field, env_id, call, error, field, entry
):
    if entry == "make" and field == "render_mode":
        pytest.skip("gym.make wraps an rgb_array env in HumanRendering for render_mode='human'")
    module = TABLES[env_id]
    vec = _make_vec(env_id)
    monkeypatch.setattr(module, "_env", _make(env_id) if entry == "make" else _make_vec(env_id, 2))
    monkeypatch.setattr(module, "_venv", vec)
    assert_names_the_field(call, error, field)


CRASH = crash_table.test_env_arguments_name_the_field.pytestmark[0].args[1]


@pytest.mark.parametrize(("kwargs", "message"), CRASH, ids=[str(r[0]) for r in CRASH])
@pytest.mark.parametrize("entry", ["make", "make_vec"])
def test_crash_table_through_gym_make(kwargs, message, entry):
    with pytest.raises(ValueError, match=message):
        if entry == "make":
            gym.make("railgym/TrainCrash-v1", **kwargs)
        else:
            _make_vec("railgym/TrainCrash-v1", 2)(**kwargs)


@pytest.mark.parametrize("env_id", [*TABLES, "railgym/TrainCrash-v1"])
@pytest.mark.parametrize(
    ("kwargs", "field"),
    [({"speed": "fast"}, "speed"), ({"speed": True}, "speed"), ({"speed": 3 + 0j}, "speed")],
)
def test_a_wrong_argument_type_reaches_the_user_named(env_id, kwargs, field):
    with pytest.raises(FieldTypeError, match=rf"^{field}.* must be a number") as info:
        gym.make(env_id, **kwargs)
    assert isinstance(info.value, TypeError) and isinstance(info.value, ValueError)
    assert info.value.field == field


@pytest.mark.parametrize("env_id", list(TABLES))
def test_a_list_duration_reaches_the_user_named(env_id):
    with pytest.raises(FieldTypeError, match=r"^duration must be a number, got \[1\]"):
        gym.make(env_id, duration=[1])


def test_field_error_with_one_argument_is_the_whole_message():
    e = FieldError("duration must be positive, got -1")
    assert str(e) == "duration must be positive, got -1" and e.field == "duration"
    assert str(FieldError("duration", "must be positive")) == "duration must be positive"
    assert str(FieldTypeError("x", "full text", full=True)) == "full text"
