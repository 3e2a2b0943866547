"""The controllable MR damper (:mod:`railgym.vehicles.semi_active`): passivity, the hysteresis
loop against its closed form, the command filter's time constant, the ``|w| ≤ 1`` invariant,
the packaged damper against the numbers its YAML cites, and bad YAML files."""

from __future__ import annotations

import dataclasses
import math
from importlib import resources

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from railgym import _checks as val
from railgym.envs.params import TrackEnvParams
from railgym.vehicles.semi_active import DamperParams, load_damper, simulate_damper
from railgym.vehicles.vertical.elements import damper_force as passive_force
from railgym.vehicles.vertical.params import load_vehicle

DAMPER = load_damper()
DT = 1e-3
RAW = yaml.safe_load(
    resources.files("railgym").joinpath("configs", "dampers", "mr_secondary.yaml").read_text()
)


def _hysteretic_force(v: np.ndarray, states: np.ndarray, p: DamperParams) -> np.ndarray:
    """The law's force before the passivity cut, from the simulated states ``(u, w)``."""
    u, w = states[:, 0], states[:, 1]
    return (p.c_a + p.c_b * u) * v + (p.f_a + p.f_b * u) * w


def _random_history(seed: int, n: int, v_max: float) -> tuple[np.ndarray, np.ndarray]:
    """A velocity history (random walk, clipped to ±v_max) and commands held 10 steps."""
    rng = np.random.default_rng(seed)
    v = np.clip(np.cumsum(rng.normal(0.0, 0.2 * v_max, n)), -v_max, v_max)
    command = np.repeat(rng.uniform(0.0, 1.0, n // 10 + 1), 10)[:n]
    return v, command


@given(seed=st.integers(0, 2**32 - 1), v_max=st.floats(0.01, 1.0))
@settings(max_examples=40)
def test_force_never_supplies_power_and_is_the_cut_law(seed, v_max):
    v, command = _random_history(seed, 600, v_max)
    force, states = simulate_damper(v, command, DT, DAMPER)
    assert np.all(force * v >= 0.0)
    f_h = _hysteretic_force(v, states, DAMPER)
    np.testing.assert_array_equal(force, np.where(f_h * v > 0.0, f_h, 0.0))


@given(seed=st.integers(0, 2**32 - 1), fraction=st.floats(0.05, 0.9))
@settings(max_examples=40)
def test_hysteresis_variable_stays_in_the_unit_interval(seed, fraction):
    # the docstring's bound: RK4 keeps |w| <= 1 while |v| dt <= x_y
    v, command = _random_history(seed, 600, fraction * DAMPER.x_y / DT)
    _, states = simulate_damper(v, command, DT, DAMPER)
    assert np.all(np.abs(states[:, 1]) <= 1.0)
    assert np.all((states[:, 0] >= 0.0) & (states[:, 0] <= 1.0))


def test_command_filter_reaches_one_minus_one_over_e_at_its_time_constant():
    n = 201
    force, states = simulate_damper(np.zeros(n), np.ones(n), DT, DAMPER)
    t = np.arange(n) * DT
    k = round(1.0 / (DAMPER.eta * DT))  # t = 1/eta
    # RK4 truncation: (η dt)⁵/120 per step, k steps to t = 1/η
    tol = k * (DAMPER.eta * DT) ** 5 / 120.0
    np.testing.assert_allclose(states[:, 0], 1.0 - np.exp(-DAMPER.eta * t), rtol=0.0, atol=tol)
    assert states[k, 0] == pytest.approx(1.0 - math.exp(-1.0), abs=tol)
    assert np.all(force == 0.0)  # at rest the device applies no force


def _loop(u: float, stroke: float, freq: float, cycles: int = 3):
    """Harmonic stroke ``x = X sin(ωt)`` at constant filtered command ``u``: the last cycle's
    displacement, velocity, simulated force and the closed-form force of the steady loop."""
    p = DAMPER
    per_cycle = round(1.0 / (freq * DT))
    t = np.arange(cycles * per_cycle + 1) * DT
    omega = 2.0 * math.pi * freq
    x, v = stroke * np.sin(omega * t), stroke * omega * np.cos(omega * t)
    force, _ = simulate_damper(v, np.full(t.size, u), DT, p, u0=u)
    last = slice((cycles - 1) * per_cycle, cycles * per_cycle)
    # steady branch after a reversal at x = ∓X with w = ±w_r (σ = 1/2, n = 2): w falls
    # linearly over the travel w_r·x_y, then follows tanh; w_r = tanh(2X/x_y − w_r)
    w_r = 1.0
    for _ in range(50):
        w_r = math.tanh(2.0 * stroke / p.x_y - w_r)
    s = np.sign(v[last])
    travel = s * x[last] + stroke  # since the last reversal
    lag = p.x_y * w_r
    w = s * np.where(travel < lag, travel / p.x_y - w_r, np.tanh((travel - lag) / p.x_y))
    f_h = (p.c_a + p.c_b * u) * v[last] + (p.f_a + p.f_b * u) * w
    return x[last], v[last], force[last], np.where(f_h * v[last] > 0.0, f_h, 0.0)


@pytest.mark.parametrize("u", [0.0, 0.5, 1.0])
def test_hysteresis_loop_matches_its_closed_form(u):
    p = DAMPER
    stroke, freq = 0.02, 1.0  # 20 mm at 1 Hz: peak velocity 0.126 m/s
    x, v, force, exact = _loop(u, stroke, freq)
    scale = (p.c_a + p.c_b * u) * v.max() + p.f_a + p.f_b * u
    np.testing.assert_allclose(force, exact, rtol=0.0, atol=1e-5 * scale)  # RK4 at dt = 1 ms
    # the force at two velocities of the rising stroke: the peak (x = 0) and half the peak
    # just after the reversal (x = −X√3/2, travel 2.7 mm = 1.34 x_y past the reversal)
    c, f = p.c_a + p.c_b * u, p.f_a + p.f_b * u
    i_peak = int(np.argmax(v))
    assert force[i_peak] == pytest.approx(c * v[i_peak] + f * math.tanh(stroke / p.x_y - 1.0))
    i_half = int(np.argmin(np.abs(x + stroke * math.sqrt(3.0) / 2.0) + 10.0 * (v < 0)))
    travel = stroke + x[i_half]
    w_half = math.tanh((travel - p.x_y) / p.x_y)
    assert force[i_half] == pytest.approx(c * v[i_half] + f * w_half, rel=1e-5, abs=1e-5 * f)


@pytest.mark.parametrize("u", [0.2, 1.0])
def test_loop_is_open_and_point_symmetric(u):
    p = DAMPER
    x, v, force, _ = _loop(u, 0.02, 1.0)
    f = p.f_a + p.f_b * u
    # width: at the same velocity 0.5·v_max, the force after the reversal (x < 0 on the
    # rising stroke, w still small) is below the force before the next one (x > 0, w ≈ 1)
    rising = v > 0.0
    near = np.abs(v - 0.5 * v.max()) < 0.02 * v.max()
    early = force[rising & near & (x < 0.0)]
    late = force[rising & near & (x > 0.0)]
    assert early.size and late.size
    assert late.min() - early.max() > 0.5 * f
    # a symmetric input gives the loop F(t + T/2) = −F(t)
    half = force.size // 2
    np.testing.assert_allclose(force[half:], -force[:half], rtol=0.0, atol=1e-6 * f)


def _sliding_force(p: DamperParams, v: float, u: float) -> float:
    """Force after a long stroke at constant velocity ``v`` and command ``u`` (w → 1)."""
    n = round(20.0 * p.x_y / (v * DT)) + 1  # 20 pre-yield travels
    force, _ = simulate_damper(np.full(n, v), np.full(n, u), DT, p, u0=u)
    return float(force[-1])


def test_packaged_damper_has_the_forces_its_yaml_cites():
    p = DAMPER
    susp = load_vehicle("manchester").kernel_params()
    f_max = next(f.default for f in dataclasses.fields(TrackEnvParams) if f.name == "f_max")
    for v, cited in ((0.1, 4200.0), (0.3, 6200.0)):
        on = _sliding_force(p, v, 1.0)
        assert on == pytest.approx((p.c_a + p.c_b) * v + p.f_a + p.f_b, rel=1e-9)
        assert on == pytest.approx(cited, rel=1e-3)
        # inside the band of the passive damper it replaces: compression ≤ F ≤ rebound
        assert passive_force(v, susp) < on < -passive_force(-v, susp)
        assert on < f_max
    off = _sliding_force(p, 0.1, 0.0)
    assert off == pytest.approx(400.0, rel=1e-3)
    assert off <= _sliding_force(p, 0.1, 1.0) / 10.0  # dynamic range ≥ 10 (Gavin et al.)


def _write(tmp_path, raw):
    path = tmp_path / "damper.yaml"
    path.write_text(yaml.safe_dump(raw))
    return path


@pytest.mark.parametrize(
    ("edit", "field", "words"),
    [
        (lambda d: d.pop("c_b"), "damper.c_b", "missing"),
        (lambda d: d.update(x_y=-0.001), "damper.x_y", "(0, 1]"),
        (lambda d: d.update(f_b=-5.0), "damper.f_b", "non-negative"),
        (lambda d: d.update(eta=0.0), "damper.eta", "(0,"),
        (lambda d: d.update(sigma=0.2), "damper.sigma", "[0.5"),
        (lambda d: d.update(c_x=1.0), "damper.c_x", "unknown field"),
        (lambda d: d.update(c_a="soft"), "damper.c_a", "number"),
    ],
)
def test_bad_yaml_names_file_and_field(tmp_path, edit, field, words):
    raw = yaml.safe_load(yaml.safe_dump(RAW))
    edit(raw["damper"])
    path = _write(tmp_path, raw)
    with pytest.raises(val.FieldError) as info:
        load_damper(path)
    text = str(info.value)
    assert str(path) in text and field in text and words in text


def test_unknown_top_level_key_and_forceless_damper_name_the_file(tmp_path):
    raw = yaml.safe_load(yaml.safe_dump(RAW))
    raw["dampers"] = {}
    path = _write(tmp_path, raw)
    with pytest.raises(val.FieldError, match="unknown field dampers") as info:
        load_damper(path)
    assert str(path) in str(info.value)
    raw = yaml.safe_load(yaml.safe_dump(RAW))
    raw["damper"].update(c_a=0.0, c_b=0.0, f_a=0.0, f_b=0.0)
    path = _write(tmp_path, raw)
    with pytest.raises(val.FieldError, match="produces no force") as info:
        load_damper(path)
    assert str(path) in str(info.value)
