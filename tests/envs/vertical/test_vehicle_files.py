"""A user's vehicle file through ``gym.make``: YAML 1.2 numbers (``2.4e6``), two envs of one
file are equal, and ``ReferenceShadow`` on the user's FMU accepts the env of that file."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import railgym  # noqa: F401  (registers the envs)
from railgym import _checks as val
from tests.fmu.user_fmu import USER_MAPPING_YAML

ID = "railgym/VerticalSuspension-v2"

#: the user's car as docs/fmi.md writes it: exponents without a sign (YAML 1.2 floats)
MY_CAR = """\
vehicle:
  name: my_car
  m1: 1800.0
  m2: 8000.0
  k1: 2.4e6
  c1: 3e4
  k2: 4.3E5
  c2: 1.7e+4
  gravity: 9.81
"""


@pytest.fixture
def my_car(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "my_car.yaml").write_text(MY_CAR)
    return tmp_path / "my_car.yaml"


def test_yaml_12_floats_are_numbers() -> None:
    data = val.load_yaml("a: 2.4e6\nb: 1e-3\nc: -2E+5\nd: .5\ne: +1.5e+3\nf: -.25e1\n", "x")
    assert data == {"a": 2.4e6, "b": 1e-3, "c": -2e5, "d": 0.5, "e": 1500.0, "f": -2.5}
    assert all(type(v) is float for v in data.values())


@pytest.mark.parametrize("text", ["e5", "1e", "1e5x", "1.2.3", "e-3", "1 e5", "--1e5"])
def test_words_like_numbers_stay_strings(text: str) -> None:
    assert val.load_yaml(f"a: {text}\n", "x") == {"a": text}


def test_integers_and_special_floats_unchanged() -> None:
    data = val.load_yaml("a: 12\nb: 0x1F\nc: .inf\nd: -.inf\ne: '2.4e6'\n", "x")
    assert data == {"a": 12, "b": 31, "c": np.inf, "d": -np.inf, "e": "2.4e6"}
    assert type(data["a"]) is int


@settings(max_examples=200, deadline=None)
@given(st.floats(allow_nan=False, allow_infinity=False, allow_subnormal=False))
def test_any_float_in_e_notation_reads_back_exactly(x: float) -> None:
    for text in (f"{x:e}", f"{x:E}", repr(x), f"{x:.17e}".replace("e+", "e")):
        assert val.load_yaml(f"v: {text}\n", "x")["v"] == float(text), text


def test_the_vehicle_file_of_the_docs_loads(my_car: Path) -> None:
    env = gym.make(ID, backend="linear", vehicle="my_car.yaml")
    car = env.unwrapped.cfg.model
    assert (car.k1, car.c1, car.k2, car.c2) == (2.4e6, 3e4, 4.3e5, 1.7e4)
    env.close()


def test_two_envs_of_one_file_are_equal(my_car: Path) -> None:
    a = gym.make(ID, backend="linear", vehicle="my_car.yaml").unwrapped
    b = gym.make(ID, backend="linear", vehicle=str(my_car)).unwrapped
    assert a.cfg.model == b.cfg.model
    assert a.vehicle_params == b.vehicle_params  # its nan fields (no damper, no air spring)
    assert np.isnan(a.vehicle_params.c_c) and np.isnan(a.vehicle_params.rho0)
    assert a.cfg.model.same_physics(b.cfg.model)
    other = my_car.with_name("other.yaml")
    other.write_text(MY_CAR.replace("k2: 4.3E5", "k2: 4.4e5"))
    c = gym.make(ID, backend="linear", vehicle="other.yaml").unwrapped
    assert not a.cfg.model.same_physics(c.cfg.model) and a.vehicle_params != c.vehicle_params


def _shadow_run(env: gym.Env, seed: int, actions: np.ndarray) -> dict:
    env.reset(seed=seed)
    for a in actions:
        *_, term, trunc, info = env.step(a)
        if term or trunc:
            break
    return info


def test_reference_shadow_on_the_users_fmu(my_car: Path, user_c_fmu: Path) -> None:
    """The wrapped env of ``vehicle="my_car.yaml"`` shadowed by the user's FMU: the shadow is
    that FMU (its carbody acceleration is the plain FMU env's), and the summary says so."""
    from railgym.wrappers import ReferenceShadow

    (my_car.parent / "map.yaml").write_text(USER_MAPPING_YAML)
    kw = {"duration": 1.0, "track_class": 4}
    actions = np.random.default_rng(3).uniform(-1, 1, (100, 1)).astype(np.float32)
    env = ReferenceShadow(
        gym.make(ID, backend="linear", vehicle="my_car.yaml", **kw),
        reference_backend="fmu",
        fmu=user_c_fmu,
        fmu_map="map.yaml",
    )
    summary = _shadow_run(env, 4, actions)["shadow"]
    shadow_acc = env.shadow.carbody_acceleration
    env.close()
    assert summary["steps"] == 100
    assert str(user_c_fmu) in summary["reference"] and "map.yaml" in summary["reference"]
    assert "'my_car'" in summary["reference"]
    plain = gym.make(
        ID, backend="fmu", fmu=user_c_fmu, fmu_map="map.yaml", vehicle="my_car.yaml", **kw
    )
    plain.reset(seed=4)  # the wrapped env's track (same seed), the same forces
    for a in actions:
        plain.step(a)
    # the linearised car is close to the FMU but not equal (a progressive spring, 2 slopes)
    assert 0.0 < summary["err_acc"] < 0.2 * summary["rms_acc_reference"]
    assert plain.unwrapped.carbody_acceleration == pytest.approx(shadow_acc, rel=1e-9)
    plain.close()


def test_reference_shadow_refuses_another_vehicle(my_car: Path, user_c_fmu: Path) -> None:
    from railgym.wrappers import ReferenceShadow

    (my_car.parent / "map.yaml").write_text(USER_MAPPING_YAML)
    (my_car.parent / "other.yaml").write_text(MY_CAR.replace("m1: 1800.0", "m1: 1900.0"))
    env = gym.make(ID, backend="linear", vehicle="my_car.yaml", duration=1.0)
    with pytest.raises(ValueError, match="differs from the wrapped env's vehicle 'my_car.yaml'"):
        ReferenceShadow(
            env, reference_backend="fmu", fmu=user_c_fmu, fmu_map="map.yaml", vehicle="other.yaml"
        )
