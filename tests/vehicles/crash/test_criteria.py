"""Crash criteria: pulse mean deceleration, moving-average peak, intrusion, pass/fail."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from railgym.vehicles.crash.criteria import (
    CriteriaLimits,
    G,
    crash_criteria,
    crash_pulse,
    intrusion,
    moving_average_peak,
    peak_deceleration,
)
from railgym.vehicles.crash.outputs import result_criteria
from railgym.vehicles.crash.reference import simulate_reference
from railgym.vehicles.crash.scenario import CrushZone, load_scenario


def _constant_force_crash(mass: float, v0: float, force: float, dt: float, duration: float):
    """Analytic single mass braked by a constant force ``force`` (N) until it stops, then at
    rest: time (n,), velocity and acceleration (n, 1)."""
    t = np.arange(0.0, duration + dt / 2, dt)
    t_stop = mass * v0 / force
    v = np.where(t < t_stop, v0 - force / mass * t, 0.0)
    a = np.where(t < t_stop, -force / mass, 0.0)
    return t, v[:, None], a[:, None], t_stop


@settings(max_examples=40, deadline=None)
@given(
    mass=st.floats(1e4, 3e4),
    v0=st.floats(3.0, 20.0),
    force=st.floats(5e5, 3e6),
    dt=st.sampled_from([1e-4, 7e-4, 1e-3]),
)
def test_pulse_mean_deceleration_of_constant_force_crash_is_analytic(mass, v0, force, dt):
    t_stop = mass * v0 / force
    t, v, a, _ = _constant_force_crash(mass, v0, force, dt, t_stop * 1.5 + 0.01)
    pulse = crash_pulse(t, v, a)
    assert pulse.start[0] == 0.0
    assert pulse.end[0] == pytest.approx(t_stop, rel=1e-9)
    assert pulse.delta_v[0] == pytest.approx(v0, rel=1e-12)
    assert pulse.mean_g[0] == pytest.approx(force / (mass * G), rel=1e-9)
    # the whole-record average (the old info["mean_decel_g"]) is lower: it counts the rest
    assert np.mean(-a) / G < pulse.mean_g[0]


def test_pulse_of_reference_single_mass_into_plateau_absorber():
    force, v0, mass = 1.0e6, 10.0, 30.0e3
    sc = load_scenario("paper")
    plateau = {"stroke": (1e-3, 5.0), "force": (force, force), "absorber_stroke": 1.0}
    wall = CrushZone(
        "wall", **plateau, unloading_stiffness=1e9, fold_amplitude=0.0, fold_wavelength=0.15
    )
    lead = replace(sc.lead, mass=mass, n_nodes=2, axial_rigidity=1e12, damping_ratio=0.0)
    sc = replace(sc, n_cars=1, friction=0.0, speed=v0, lead=lead, wall=wall)
    r = simulate_reference(sc, duration=1.0, sample_dt=1e-4)
    c = result_criteria(r)
    g = r.scenario.gravity
    assert c.pulse.end[0] == pytest.approx(v0 * mass / force, rel=5e-3)
    assert c.pulse.mean_g[0] == pytest.approx(force / (mass * g), rel=5e-3)
    # stopping distance 1.5 m > absorber stroke 1.0 m: 0.5 m into the structure
    assert c.intrusion_m[0] == pytest.approx(v0**2 * mass / (2 * force) - 1.0, abs=5e-3)
    assert not c.passed["intrusion"][0] and c.passed["mean_decel"][0]
    assert not c.all_passed


def test_moving_average_peak_of_half_sine_pulse():
    amp, tau, window, v0 = 60.0, 0.1, 0.01, 15.0
    t = np.arange(0.0, 0.2 + 1e-9, 1e-4)
    inside = t <= tau
    a = np.where(inside, -amp * np.sin(np.pi * t / tau), 0.0)
    v = v0 - amp * tau / np.pi * np.where(inside, 1 - np.cos(np.pi * t / tau), 2.0)
    expected = amp * 2 * tau / (np.pi * window) * math.sin(np.pi * window / (2 * tau)) / G
    assert moving_average_peak(t, v, window)[0] == pytest.approx(expected, rel=1e-9)
    # less than the raw peak, more than the mean over the whole pulse
    assert 2 * amp / np.pi / G < expected < peak_deceleration(a)[0] == pytest.approx(amp / G)


def test_moving_average_of_a_constant_deceleration_is_that_deceleration():
    t, v, a, _ = _constant_force_crash(3e4, 10.0, 1e6, 1e-3, 0.5)
    assert moving_average_peak(t, v, 0.01)[0] == pytest.approx(1e6 / 3e4 / G, rel=1e-9)


def test_intrusion_of_constructed_history():
    t = np.linspace(0.0, 1.0, 101)
    wall = 2.2 * np.sin(np.pi * t)  # peaks at 2.2 m
    interface = np.minimum(t, 0.5)  # never beyond its 1.73 m stroke
    crush = np.column_stack([wall, interface])
    got = intrusion(crush, np.array([2.05, 1.73]))
    np.testing.assert_allclose(got, [0.15, 0.0], atol=1e-12)
    with pytest.raises(ValueError, match="absorber_stroke must have shape"):
        intrusion(crush, np.array([2.05]))


def test_criteria_pass_fail_with_limits_and_errors():
    t, v, a, _ = _constant_force_crash(3e4, 10.0, 1.8e6, 1e-3, 0.4)  # 6.1 g
    crush = np.column_stack([np.linspace(0, 1.0, t.size)])
    c = crash_criteria(t, v, a, crush, np.array([2.0]))
    assert c.pulse.mean_g[0] == pytest.approx(1.8e6 / 3e4 / G)
    assert not c.passed["mean_decel"][0] and c.passed["intrusion"][0]
    c = crash_criteria(t, v, a, crush, np.array([2.0]), CriteriaLimits(mean_decel_g=7.0))
    assert c.all_passed
    c = crash_criteria(t, v, a, crush, np.array([2.0]), CriteriaLimits(peak_decel_g=6.0))
    assert not c.passed["peak_decel"][0]
    with pytest.raises(ValueError, match="limits.mean_decel_g"):
        crash_criteria(t, v, a, crush, np.array([2.0]), CriteriaLimits(mean_decel_g=-1.0))
    with pytest.raises(ValueError, match="strictly increasing"):
        crash_pulse(t[::-1], v, a)
    with pytest.raises(ValueError, match="window"):
        moving_average_peak(t, v, 5.0)


def test_paper_crash_pulse_is_longer_than_the_old_episode_mean():
    r = simulate_reference("paper")
    c = result_criteria(r)
    # each car stops (Δv = the initial speed), the lead car first
    np.testing.assert_allclose(c.pulse.delta_v, r.v[0, :2] - 0.0, rtol=0.02)
    assert np.all(c.pulse.mean_g < c.moving_average_g)
    assert np.all(c.moving_average_g < c.peak_decel_g)
    assert np.all(c.pulse.mean_g > np.mean(-r.a[:, :2], axis=0) / r.scenario.gravity)
