"""The user's quarter-car FMUs (:mod:`tests.fmu.user_fmu`): valid FMI 2.0, the physics they
declare, and the C and pythonfmu implementations giving the same trajectories."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml  # type: ignore[import-untyped, unused-ignore]
from scipy.optimize import brentq

from tests.fmu.user_fmu import (
    OUTPUTS,
    USER_CAR,
    USER_MAPPING_YAML,
    USER_VEHICLE_YAML,
    run_user_fmu,
    simulate_user_car,
    user_secondary_force,
)

fmpy = pytest.importorskip("fmpy", reason="the 'fmi' extra (fmpy) is not installed")

DT = 1e-3  # s, communication step


def _random_input(n: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A rough track (random-walk rate, mm amplitudes) and a random actuator force (kN)."""
    rng = np.random.default_rng(seed)
    zr_dot = np.cumsum(rng.normal(0.0, 2e-3, n))  # m/s
    zr_dot -= np.linspace(0.0, 1.0, n) * zr_dot[-1]  # no drift over the run
    zr = np.concatenate([[0.0], np.cumsum(zr_dot[:-1]) * DT])
    fact = rng.uniform(-3e3, 3e3, n)
    return zr, zr_dot, fact


def test_user_c_fmu_is_valid_with_units(user_c_fmu: Path) -> None:
    from fmpy.validation import validate_fmu  # type: ignore[import-untyped, unused-ignore]

    assert validate_fmu(str(user_c_fmu)) == []
    md = fmpy.read_model_description(str(user_c_fmu))
    assert md.coSimulation is not None and md.modelExchange is None
    units = {v.name: (v.causality, v.unit) for v in md.modelVariables}
    assert units == {
        "zr": ("input", "m"),
        "zr_dot": ("input", "m/s"),
        "Fact": ("input", "N"),
        "x1": ("output", "m"),
        "v1": ("output", "m/s"),
        "x2": ("output", "m"),
        "v2": ("output", "m/s"),
        "a2": ("output", "m/s2"),
    }
    base = {u.name: u.baseUnit for u in md.unitDefinitions}
    assert (base["N"].kg, base["N"].m, base["N"].s) == (1, 1, -2)
    assert (base["m/s2"].m, base["m/s2"].s) == (1, -2)


def test_user_py_fmu_has_the_same_variables(user_c_fmu: Path, user_py_fmu: Path) -> None:
    c = fmpy.read_model_description(str(user_c_fmu)).modelVariables
    py = fmpy.read_model_description(str(user_py_fmu)).modelVariables
    assert [(v.name, v.valueReference, v.causality) for v in py] == [
        (v.name, v.valueReference, v.causality) for v in c
    ]


def test_c_and_pythonfmu_fmus_give_the_same_trajectories(
    user_c_fmu: Path, user_py_fmu: Path
) -> None:
    """2 s of a random track and actuator force, a plain FMPy master: the two FMUs and the
    car in plain Python agree to rounding (same RK4, same held inputs)."""
    zr, zr_dot, fact = _random_input(2000, seed=7)
    c = run_user_fmu(user_c_fmu, zr, zr_dot, fact, DT)
    py = run_user_fmu(user_py_fmu, zr, zr_dot, fact, DT)
    ref = simulate_user_car(zr, zr_dot, fact, DT)
    scale = np.abs(c).max(axis=0)
    assert np.all(scale > [1e-3, 1e-2, 1e-3, 1e-2, 0.1])  # a real ride, every channel
    # measured: 0 (the same IEEE operations in C with -ffp-contract=off and in Python)
    assert np.all(np.abs(py - c) <= 1e-12 * scale), dict(
        zip(OUTPUTS, np.abs(py - c).max(0), strict=True)
    )
    # numpy's tanh against libm's: a few ulp
    assert np.all(np.abs(ref - c) <= 1e-12 * scale)


def test_constant_actuator_force_settles_at_the_static_deflection(user_c_fmu: Path) -> None:
    """Flat track, constant Fact: the bogie returns to 0 (the primary carries nothing more)
    and the secondary spring balances the force: k2·δ·(1 + 30δ²) = −Fact, x2 = −δ."""
    n, dt, force = 4000, 0.01, 8.0e3  # 40 s: the transient decays below 1e-12 m
    zero = np.zeros(n)
    out = run_user_fmu(user_c_fmu, zero, zero, np.full(n, force), dt)
    delta = brentq(lambda d: float(user_secondary_force(d, 0.0)) + force, -0.2, 0.0)
    linear = -force / USER_CAR.k2
    assert abs(delta - linear) > 0.005 * abs(linear)  # the progression matters at 19 mm
    x1, v1, x2, v2, a2 = out[-1]
    assert abs(x1) < 1e-9 and abs(v1) < 1e-8 and abs(v2) < 1e-8 and abs(a2) < 1e-7
    assert x2 == pytest.approx(-delta, rel=1e-9)


def test_secondary_law_and_its_linearisation_in_the_vehicle_yaml() -> None:
    car, f = USER_CAR, user_secondary_force
    h = 1e-7
    # tangents at rest are the linearised k2, c2 of the vehicle block
    vehicle = yaml.safe_load(USER_VEHICLE_YAML)["vehicle"]
    k2 = (f(h, 0.0) - f(-h, 0.0)) / (2 * h)
    c2 = (f(0.0, h) - f(0.0, -h)) / (2 * h)
    assert k2 == pytest.approx(vehicle["k2"], rel=1e-9)
    assert c2 == pytest.approx(vehicle["c2"], rel=1e-6)
    for key in ("m1", "m2", "k1", "c1", "gravity"):
        assert vehicle[key] == getattr(car, key)
    # two damper slopes away from δ̇ = 0, a stiffening spring, no bump stops
    assert f(0.0, 0.2) / 0.2 == pytest.approx(car.c_compression, rel=1e-12)
    assert f(0.0, -0.2) / -0.2 == pytest.approx(car.c_rebound, rel=1e-12)
    assert f(0.1, 0.0) == pytest.approx(car.k2 * 0.1 * 1.3)
    assert f(-0.1, 0.0) == -f(0.1, 0.0)
    # the mapping string names the FMUs' variables
    mapping = yaml.safe_load(USER_MAPPING_YAML)
    assert mapping["inputs"] == {
        "track": [{"displacement": "zr", "rate": "zr_dot"}],
        "actuator_force": ["Fact"],
    }
    assert mapping["outputs"]["deflection"] == "x1 - x2"
    assert mapping["outputs"]["bogie_acc"] == "der(v1)"


def test_an_element_collected_from_the_users_fmu_is_plausible(user_c_fmu: Path, tmp_path) -> None:
    """As tests/fmu/test_user_path.py builds it (the paper design on the FMU, the user's
    vehicle from the mapping): its linearisation is the car's k2, c2, so neither env warns
    that it does not look like the car's suspension."""
    import warnings

    import gymnasium as gym

    import railgym  # noqa: F401  (registers the envs)
    from railgym.fmu.collect import collect_fmu
    from railgym.vehicles.collect import build_vertical_surrogate
    from railgym.vehicles.element_plausibility import element_plausibility
    from railgym.vehicles.vertical.params import load_vehicle

    car = tmp_path / "my_car.yaml"
    car.write_text(USER_VEHICLE_YAML)
    mapping = {**yaml.safe_load(USER_MAPPING_YAML), "fmu": str(user_c_fmu), "vehicle": str(car)}
    (tmp_path / "map.yaml").write_text(yaml.safe_dump(mapping, sort_keys=False))
    data = collect_fmu(tmp_path / "map.yaml", "paper")
    model, _, _ = build_vertical_surrogate(data=data, vehicle=str(car))
    p = element_plausibility(model, load_vehicle(str(car)))
    assert p.plausible and p.findings == ()
    assert p.stiffness_ratio == pytest.approx(1.0, abs=0.02)
    assert p.damping_ratio == pytest.approx(1.0, abs=0.05)  # the tanh blend: mean of slopes
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        gym.make("railgym/VerticalSuspension-v1", surrogate=model, vehicle=str(car))
    assert not [w for w in record if "does not look like" in str(w.message)]
