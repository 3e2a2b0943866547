"""The declared env arguments (:mod:`railgym.envs.params`): one declaration gives the check,
the stored value, the limits, the constructor's keywords and the docs table."""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import math
from pathlib import Path
from typing import Any, NamedTuple

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import railgym  # noqa: F401  (registers the envs)
from railgym import _checks as val
from railgym.envs.params import (
    Params,
    Spec,
    arguments_table,
    consts,
    declared,
    default,
    keyword_signature,
    keyword_source,
    limits,
    param,
    specs,
    update_docs,
)
from railgym.envs.vehicle.env import LIMITS as VEHICLE_LIMITS
from railgym.envs.vehicle.env import VehicleParams, VerticalVehicleEnv, VerticalVehicleVectorEnv
from railgym.envs.vertical.env import (
    LIMITS,
    VerticalParams,
    VerticalSuspensionEnv,
    VerticalSuspensionVectorEnv,
)
from railgym.registration import ENVS as REGISTERED

DOCS = Path(__file__).resolve().parents[2] / "docs" / "envs"
CLASSES = [VerticalParams, VehicleParams]
ENVS = [
    (VerticalSuspensionEnv, VerticalSuspensionVectorEnv, VerticalParams),
    (VerticalVehicleEnv, VerticalVehicleVectorEnv, VehicleParams),
]


def _bounded(cls: type) -> list[tuple[type, str, Spec]]:
    return [
        (cls, name, s)
        for name, s in specs(cls).items()
        if s.kind in ("real", "int") and (s.lo is not None or s.hi is not None)
    ]


BOUNDED = [row for cls in CLASSES for row in _bounded(cls)]


def _inside(s: Spec, u: float) -> float:
    """A value of the declared range of ``s`` at fraction ``u`` ∈ [0, 1] (open ends avoided)."""
    lo = s.lo if s.lo is not None else -1e6
    hi = s.hi if s.hi is not None else lo + 1e6
    x = lo + u * (hi - lo)
    if s.lo_open and x <= lo:
        x = math.nextafter(lo, math.inf)
    if s.hi_open and x >= hi:
        x = math.nextafter(hi, -math.inf)
    return round(x) if s.kind == "int" else x


@pytest.mark.parametrize(("cls", "name", "spec"), BOUNDED, ids=lambda r: getattr(r, "__name__", r))
@given(u=st.floats(0.0, 1.0))
@settings(max_examples=25, deadline=None)
def test_any_value_inside_the_declared_range_is_accepted_and_stored(cls, name, spec, u):
    value = _inside(spec, u)
    assert cls.check(name, value) == value
    assert type(cls.check(name, np.float64(value) if spec.kind == "real" else value)) is type(value)


@pytest.mark.parametrize(("cls", "name", "spec"), BOUNDED, ids=lambda r: getattr(r, "__name__", r))
@given(excess=st.floats(1e-9, 1e12))
@settings(max_examples=25, deadline=None)
def test_any_value_outside_the_declared_range_is_refused_naming_the_field(cls, name, spec, excess):
    bad = []
    if spec.hi is not None:
        above = spec.hi + excess * (1 + abs(spec.hi)) if not spec.hi_open else spec.hi + excess
        bad.append(math.ceil(above) if spec.kind == "int" else above)
    if spec.lo is not None:
        below = spec.lo - excess * (1 + abs(spec.lo))
        bad.append(math.floor(below) if spec.kind == "int" else below)
    for value in bad:
        with pytest.raises(val.FieldError, match=rf"^{name} "):
            cls.check(name, value)


@pytest.mark.parametrize("cls", CLASSES, ids=lambda c: c.__name__)
@given(
    w=st.dictionaries(
        st.sampled_from(["acceleration", "deflection", "force"]), st.floats(0.0, 1e6), max_size=3
    )
)
@settings(max_examples=25, deadline=None)
def test_reward_weights_fill_in_the_declared_default_in_its_key_order(cls, w):
    got = cls.check("reward_weights", w)
    default = {"acceleration": 1.0, "deflection": 1.0, "force": 0.1}
    assert got == {**default, **w} and list(got) == list(default)


@given(bad=st.floats(1e6, 1e300) | st.floats(-1e300, -1e-300))
@settings(max_examples=25, deadline=None)
def test_an_out_of_range_weight_is_refused_with_its_key(bad):
    with pytest.raises(val.FieldError, match=r"^reward_weights\['force'\] "):
        VerticalParams.check("reward_weights", {"force": bad * 1.0000001})


@given(lo=st.floats(0.1, 999.0), width=st.floats(1e-3, 1.0))
@settings(max_examples=25, deadline=None)
def test_a_band_within_the_limits_is_stored_as_a_float_pair(lo, width):
    hi = min(lo + width * (1000.0 - lo), 1000.0)
    if not lo < hi:
        return
    assert VerticalParams.check("band", [np.float32(lo).item(), hi]) == (
        np.float32(lo).item(),
        hi,
    )
    with pytest.raises(val.FieldError, match="^band "):
        VerticalParams.check("band", (hi, lo))


def test_the_constructor_stores_the_checked_arguments_and_derives_the_step_grid():
    p = VerticalParams(
        backend="linear", f_max=np.float32(4000.0), duration=np.int64(2), control_dt=0.02
    )
    assert p.f_max == 4000.0 and type(p.f_max) is float and p.duration == 2.0
    assert (p.dt, p.n_sub, p.n_steps, p.variant) == (1e-3, 20, 100, "linear")
    assert p.reward_weights == {"acceleration": 1.0, "deflection": 1.0, "force": 0.1}
    assert p.free_travel == p.model.bump_stop.free_travel_compression
    assert p.obs_scale[2] == p.free_travel  # the deflection channel's scale
    with pytest.raises(AttributeError):
        p.f_max = 1.0  # type: ignore[misc]
    q = VehicleParams(backend="reference", flexible=np.bool_(False), speed=(20, 30.0))
    assert q.flexible is False and q.speed == (20.0, 30.0) and q.dt == 2e-3


def test_unknown_argument_is_a_type_error_listing_the_arguments():
    with pytest.raises(TypeError, match=r"unknown argument\(s\) \['f_maxx'\].*'f_max'"):
        VerticalSuspensionEnv(f_maxx=1.0)
    with pytest.raises(TypeError, match="n_actuators"):
        VerticalSuspensionEnv(n_actuators=2)  # the whole vehicle's argument only


@pytest.mark.parametrize(("single", "vector", "cls"), ENVS, ids=lambda c: c.__name__)
def test_the_constructors_take_the_declared_fields_as_keywords(single, vector, cls):
    declared_ = {f.name: default(f) for f in dataclasses.fields(cls) if f.init}
    sig = inspect.signature(single).parameters
    assert list(sig) == ["render_mode", *declared_]
    assert {n: p.default for n, p in sig.items() if n != "render_mode"} == declared_
    assert list(inspect.signature(vector).parameters)[:2] == ["num_envs", "render_mode"]
    for name, s in specs(cls).items():
        assert s.desc, name  # every argument says what it is


def _registered_classes() -> list[type]:
    """Every class behind a registered id: the single and the vector entry points."""
    out = []
    for entries in REGISTERED.values():
        for entry in entries:
            module, name = entry.split(":")
            out.append(getattr(importlib.import_module(module), name))
    return out


@pytest.mark.parametrize("env_class", _registered_classes(), ids=lambda c: c.__name__)
def test_every_constructor_writes_out_the_declared_arguments(env_class):
    """The constructor's own keyword-only parameters are the declared fields of its params
    class, in order, with their declared types and defaults (``keyword_signature``): what
    ``inspect``, type checkers and IDEs read. A declaration added without its parameter fails
    here; paste ``keyword_source(params)`` into the constructor."""
    single = getattr(env_class, "single_class", env_class)
    params = single.params_class
    pos = inspect.Parameter.POSITIONAL_OR_KEYWORD
    first = [inspect.Parameter("render_mode", inspect.Parameter.KEYWORD_ONLY, default=None)]
    if single is not env_class:
        first.insert(0, inspect.Parameter("num_envs", pos, default=1))
    expected = keyword_signature(params, *first).parameters
    init = inspect.signature(env_class.__init__).parameters
    assert "self" in init and "kwargs" not in init
    got = inspect.signature(env_class).parameters
    hint = "the constructor's parameters after render_mode:\n" + keyword_source(params)
    assert list(got) == list(expected), hint
    for name, p in expected.items():
        q = got[name]
        assert q.kind == p.kind, name
        assert q.default == p.default and type(q.default) is type(p.default), name
        if name not in ("num_envs", "render_mode"):
            assert q.annotation == p.annotation, (name, q.annotation, hint)
    with pytest.raises(TypeError, match=r"unknown argument\(s\) \['nope'\]"):
        env_class(nope=1)


def test_limits_are_the_declared_bounds():
    for name, s in specs(VerticalParams).items():
        if s.kind in ("real", "weights") and s.hi is not None:
            assert LIMITS[name] == s.hi
    assert LIMITS["band"] == (0.1, 1000.0) and LIMITS["f_max"] == 1e6
    assert VEHICLE_LIMITS["f_max"] == 1e9 and VEHICLE_LIMITS["control_dt"] == 1.0 / 60.0
    assert limits(VehicleParams)["duration"] == LIMITS["duration"] == 600.0


@pytest.mark.parametrize("page", sorted(DOCS.glob("*.md")), ids=lambda p: p.name)
def test_the_docs_tables_of_arguments_are_the_declarations(page):
    """A marked table differs from its declaration: run ``railgym env-tables``."""
    assert update_docs(page) == []


def test_the_docs_of_both_track_envs_carry_a_generated_table():
    for page, cls in (("vertical.md", VerticalParams), ("vehicle_vertical.md", VehicleParams)):
        text = (DOCS / page).read_text(encoding="utf-8")
        assert arguments_table(cls) in text
        for name, s in specs(cls).items():  # name, default and unit in one row
            row = next(line for line in text.splitlines() if line.startswith(f"| `{name}` |"))
            assert f"| {s.unit or '–'} |" in row


class _Consts(NamedTuple):
    f_max: float
    scale: float


@declared
class _Toy(Params):
    f_max: float = param(1.0, "N", "force", lo=0.0, lo_open=True, hi=10.0)
    mode: str = param("a", "", "mode", kind="choice", values=("a", "b"))
    on: bool = param(True, "", "switch", kind="bool")


def test_kernel_constants_are_filled_by_field_name():
    toy = _Toy(f_max=2)
    assert consts(_Consts, toy, scale=0.5) == _Consts(f_max=2.0, scale=0.5)
    with pytest.raises(TypeError, match=r"_Consts\.scale"):
        consts(_Consts, toy)
    with pytest.raises(TypeError, match="no field"):
        consts(_Consts, toy, scale=1.0, other=2.0)
    with pytest.raises(val.FieldTypeError, match="^on "):
        _Toy(on=1)
    with pytest.raises(val.FieldError, match="^mode "):
        _Toy(mode="c")
    assert _Toy().arguments() == {"f_max": 1.0, "mode": "a", "on": True}


def _episode(env: Any, n: int = 60) -> list[tuple[np.ndarray, float]]:
    rng = np.random.default_rng(2)
    rows = [(env.reset(seed=5)[0], 0.0)]
    for _ in range(n):
        a = rng.uniform(-1.0, 1.0, env.action_space.shape).astype(np.float32)
        obs, r, *_ = env.step(a)
        rows.append((obs, r))
    return rows


@pytest.mark.parametrize(
    ("env_id", "kwargs"),
    [
        ("railgym/VerticalSuspension-v1", {"backend": "reference", "sensor_noise": 0.1}),
        ("railgym/VerticalSuspension-v1", {"backend": "linear", "acc_weighting": "Wk"}),
        ("railgym/VerticalVehicle-v1", {"backend": "linear", "acc_weighting": "Wk"}),
    ],
)
def test_an_env_made_again_from_its_checked_arguments_repeats_its_episode_bit_for_bit(
    env_id, kwargs, assert_same_rollouts
):
    env = gym.make(env_id, duration=1.0, **kwargs)
    again = type(env.unwrapped)(**env.unwrapped.cfg.arguments())
    assert_same_rollouts(_episode(env), _episode(again))
