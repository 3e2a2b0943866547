"""Crash baselines: passive, constant, speed-adaptive; rollout histories; constant search."""

from __future__ import annotations

import numpy as np
import pytest

from agents.controllers.crash_baselines import (
    BEST_CONSTANT_ACTION,
    ConstantAbsorber,
    CrashPassive,
    SpeedAdaptive,
    remaining_absorber_energy,
    rollout,
    search_constant,
)
from agents.evaluation.crash_report import (
    ERROR_ACTIONS,
    baseline_rows,
    baseline_table,
    error_table,
    surrogate_error_rows,
)
from railgym.envs.crash.env import TrainCrashEnv, TrainCrashVectorEnv
from railgym.vehicles.crash.outputs import result_criteria
from railgym.vehicles.crash.reference import simulate_reference
from railgym.vehicles.crash.scenario import load_scenario

KMH = 1 / 3.6


def _worst(env, controller):
    c = rollout(env, controller)[0].criteria()
    return c.peak_decel_g.max(), c


def test_speed_adaptive_beats_passive_at_25_kmh_on_the_reference_without_intrusion():
    env = TrainCrashVectorEnv(num_envs=1, backend="reference", speed=25 * KMH)
    passive, c_passive = _worst(env, CrashPassive(env))
    adaptive, c_adaptive = _worst(env, SpeedAdaptive(env))
    assert adaptive < 0.9 * passive
    assert np.all(c_adaptive.intrusion_m == 0.0) and np.all(c_passive.intrusion_m == 0.0)
    assert np.all(c_adaptive.pulse.mean_g < c_passive.pulse.mean_g)


def test_speed_adaptive_softens_slow_and_stiffens_fast_crashes():
    actions = []
    for kmh in (25, 50):
        env = TrainCrashEnv(backend="reference", speed=kmh * KMH)
        obs, _ = env.reset(seed=0)
        actions.append(SpeedAdaptive(env).predict(obs)[0])
    np.testing.assert_array_equal(actions[0], [-1.0, -1.0])  # 1.56 MJ: softest absorbers
    assert actions[1][0] == 1.0  # 6.25 MJ > the wall absorber's 3.5 MJ: stiffest


def test_remaining_absorber_energy_is_the_envelope_integral():
    zone = load_scenario("paper").wall
    got = remaining_absorber_energy(zone, np.array([0.0, zone.absorber_stroke, 3.0]))
    np.testing.assert_allclose(got, [zone.absorber_energy(), 0.0, 0.0], rtol=1e-6, atol=1e-6)
    # from 1.0 m on, the plateau 2 200 kN from 0.617 m to the stroke (ramp ends before 1.0 m)
    left = remaining_absorber_energy(zone, np.array([1.0]))[0]
    assert left == pytest.approx(2.2e6 * (zone.absorber_stroke - 1.0), rel=1e-6)


def test_rollout_histories_match_simulate_reference():
    env = TrainCrashVectorEnv(num_envs=2, backend="reference")
    runs = rollout(env, CrashPassive(env))
    ref = simulate_reference("paper")
    c_ref, c_env = result_criteria(ref), runs[0].criteria()
    np.testing.assert_allclose(c_env.peak_decel_g, c_ref.peak_decel_g, rtol=1e-9)
    np.testing.assert_allclose(c_env.pulse.mean_g, c_ref.pulse.mean_g, rtol=1e-9)
    np.testing.assert_array_equal(runs[0].v, runs[1].v)


def test_predict_shapes_and_errors():
    env = TrainCrashVectorEnv(num_envs=3, backend="reference")
    obs, _ = env.reset(seed=0)
    for ctl in (CrashPassive(env), ConstantAbsorber(env), SpeedAdaptive(env)):
        a, state = ctl.predict(obs)
        assert a.shape == (3, 2) and a.dtype == np.float32 and state is None
        assert ctl.predict(obs[0])[0].shape == (2,)
        with pytest.raises(ValueError, match="observation must have shape"):
            ctl.predict(obs[:, :3])
    np.testing.assert_array_equal(ConstantAbsorber(env).predict(obs)[0][0], BEST_CONSTANT_ACTION)
    with pytest.raises(ValueError, match="action must be in"):
        ConstantAbsorber(env, (2.0, 0.0))
    with pytest.raises(ValueError, match="margin"):
        SpeedAdaptive(env, margin=-1.0)
    with pytest.raises(ValueError, match="TrainCrash env"):
        CrashPassive(object())


def test_search_finds_the_shipped_best_constant():
    speeds = np.array([25, 30, 35, 40, 45, 50]) * KMH
    res = search_constant(speeds, levels=np.linspace(-1, 1, 9), backend="reference")
    np.testing.assert_array_equal(res.best, BEST_CONSTANT_ACTION)
    passive = int(np.flatnonzero(np.all(res.candidates == 0.0, axis=1))[0])
    assert res.score < res.peak[:, passive].mean()
    assert not res.admissible[passive]  # passive crushes structure at 45 km/h
    best = int(np.flatnonzero(np.all(res.candidates == res.best, axis=1))[0])
    assert np.all(res.intrusion[:5, best] == 0.0)


def test_report_tables_reproduce_the_issue_measurements():
    rows = surrogate_error_rows([40.0], fit="nominal")
    again = surrogate_error_rows([40.0], fit="per-speed")  # the same fit at the nominal speed
    for r, s in zip(rows, again, strict=True):
        np.testing.assert_array_equal(r["surrogate"].crush, s["surrogate"].crush)
    minus = rows[ERROR_ACTIONS.index(-1.0)]
    # issue 11: at −1 the surrogate reports 0.446 m of cab intrusion, the reference 0.200 m
    # (0.447 m since 0.5: k_u fitted per unloading line)
    assert minus["surrogate"].criteria().intrusion_m[0] == pytest.approx(0.446, abs=5e-3)
    assert minus["reference"].criteria().intrusion_m[0] == pytest.approx(0.200, abs=5e-3)
    table = error_table(rows)
    assert table.count("\n") == 2 + len(ERROR_ACTIONS) - 1
    assert "0.200 / 0.000 → 0.447 / 0.000" in table
    text = baseline_table(baseline_rows([25.0]))
    assert "| 25 | speed-adaptive |" in text and "| speed-adaptive |" in text
    with pytest.raises(ValueError, match="fit must be"):
        surrogate_error_rows([40.0], fit="other")
