"""Observer-based LQR (LQG) baselines: separation principle, estimate convergence, by name."""

import numpy as np
import pytest
from scipy.linalg import expm

from agents.controllers.classical import LQR
from agents.controllers.lqg import LQG, VehicleLQG, fra_shaping
from agents.evaluation.runs import evaluate_vehicle
from agents.evaluation.sweeps import evaluate_sweep
from railgym.envs.vehicle.env import VerticalVehicleVectorEnv
from railgym.envs.vertical.env import VerticalSuspensionEnv, VerticalSuspensionVectorEnv
from railgym.track import fra_psd


def match(a, b):
    """Largest distance between two sets of complex numbers (greedy nearest match)."""
    b = list(b)
    worst = 0.0
    for z in sorted(a, key=abs):
        j = int(np.argmin([abs(z - w) for w in b]))
        worst = max(worst, abs(z - b.pop(j)))
    return worst


def test_shaping_filter_has_the_fra_spectrum():
    """|H(iω)|²·q/π equals the FRA PSD in time (per rad/s) well above the cut-off ω_r."""
    speed = 40.0
    a, q = fra_shaping(5, speed, longest=1e6)
    for omega_t in (2.0, 10.0, 60.0):  # rad/s
        h = np.linalg.solve(1j * omega_t * np.eye(2) - a, np.array([0.0, 1.0]))[0]
        psd_t = q * abs(h) ** 2 / np.pi
        assert psd_t == pytest.approx(fra_psd(omega_t / speed, 5) / speed, rel=1e-9)


def test_separation_principle_on_the_linear_backend():
    """The closed loop (plant, estimate, last force), identified from the env's own steps on a
    flat track, has the poles of Φ − Γ·K (the LQR's gain on the plant sampled with the force
    held) and of the filter's error Φ·(I − M·C), plus 0 for the stored force."""
    n = 24
    flat = (np.linspace(0.0, 2000.0, 2001), np.zeros(2001))
    venv = VerticalSuspensionVectorEnv(num_envs=n, backend="linear", profile=flat, duration=1.0)
    rng = np.random.default_rng(0)
    venv.reset(seed=0)
    for _ in range(6):  # random forces: the plant states span their 4 dimensions
        u0 = rng.uniform(-0.2, 0.2, (n, 1)).astype(np.float32)
        obs, *_ = venv.step(u0)
    ctrl = LQG(venv)
    f_max = ctrl.f_max
    ctrl._start(n)
    ctrl.x_pred = rng.normal(0.0, 1e-4, (n, 6)) * [1, 10, 1, 10, 1, 10]
    ctrl.u_prev = u0.astype(np.float64) * f_max
    xi1 = np.hstack([venv.state[:, :4], ctrl.x_pred, ctrl.u_prev / f_max])
    u1, _ = ctrl.predict(obs)
    assert np.all(np.abs(u1) < 1.0)  # no clipping: the loop is linear
    venv.step(u1)
    xi2 = np.hstack([venv.state[:, :4], ctrl.x_pred, ctrl.u_prev / f_max])
    j, *_ = np.linalg.lstsq(xi1, xi2, rcond=None)
    assert np.allclose(xi1 @ j, xi2, rtol=0, atol=1e-6 * np.abs(xi2).max())
    # expected: the plant sampled independently from LQR's continuous model
    lqr = LQR(VerticalSuspensionEnv(backend="linear", observation="full"))
    big = np.zeros((5, 5))
    big[:4, :4], big[:4, 4:] = lqr.A, lqr.B
    e = expm(big * venv.cfg.control_dt)
    plant = np.linalg.eigvals(e[:4, :4] - e[:4, 4:] @ lqr.K)
    expected = np.concatenate([plant, ctrl.kf.error_poles(), [0.0]])
    assert np.all(np.abs(expected) < 1.0)
    assert match(np.linalg.eigvals(j.T), expected) < 1e-4


def test_vertical_estimate_converges_to_the_true_state():
    """Linear backend, FRA class 5, no sensor noise. Started, as the env, at rest, the estimate
    of [x1, v1, x2, v2] follows the true state to 1 % of each state's RMS; started wrong (2 cm
    deflection, 5 cm/s), the deflection and the velocities lock on within 2 s. (The absolute
    level of bogie, carbody and track together is barely observable from these sensors: an
    error there decays with the slowest filter pole.)"""
    venv = VerticalSuspensionVectorEnv(num_envs=2, backend="linear", duration=6.0)
    for wrong in (False, True):
        ctrl = LQG(venv)
        obs, _ = venv.reset(seed=3)
        ctrl._start(2)
        if wrong:
            ctrl.x_pred[:, :4] = [0.01, 0.05, -0.01, 0.05]
        err, states = [], []
        for _ in range(600):
            action, _ = ctrl.predict(obs)
            err.append(ctrl.x_est[:, :4] - venv.state[:, :4])
            states.append(venv.state[:, :4])
            obs, *_ = venv.step(action)
        err, states = np.array(err), np.array(states)
        rms = np.sqrt(np.mean(states**2, axis=(0, 1)))
        if not wrong:
            rel = np.sqrt(np.mean(err**2, axis=(0, 1))) / rms
            assert np.all(rel < 0.01), rel
            continue
        assert np.abs(err[0]).max() > 5e-3  # it did start wrong
        late = err[200:]
        defl = np.sqrt(np.mean((late[..., 0] - late[..., 2]) ** 2))
        rms_defl = np.sqrt(np.mean((states[..., 0] - states[..., 2]) ** 2))
        assert defl < 0.02 * rms_defl, (defl, rms_defl)
        rel_v = np.sqrt(np.mean(late[..., [1, 3]] ** 2, axis=(0, 1))) / rms[[1, 3]]
        assert np.all(rel_v < 0.02), rel_v


def test_vehicle_estimate_converges_and_lqg_beats_passive():
    """Whole vehicle, linear backend, class 5: the estimate of the carbody and bogie bounce
    states (those the gain weighs) follows the true ones to 5 % of their RMS; the bogie pitch
    is not observable from the sensors and gets (almost) no gain."""
    venv = VerticalVehicleVectorEnv(num_envs=2, backend="linear", duration=6.0)
    ctrl = VehicleLQG(venv)
    obs, _ = venv.reset(seed=3)
    err, states = [], []
    while True:
        action, _ = ctrl.predict(obs)
        err.append(ctrl.x_est[:, :14] - venv.state[:, :14])
        states.append(venv.state[:, :14])
        obs, _, term, trunc, _ = venv.step(action)
        assert not term.any()
        if trunc.all():
            break
    err, states = np.array(err[200:]), np.array(states[200:])
    rel = np.sqrt(np.mean(err**2, axis=(0, 1))) / np.sqrt(np.mean(states**2, axis=(0, 1)))
    seen = [0, 1, 2, 3, 5, 7, 8, 9, 10, 12]  # z_c, θ_c, q, z_b0, z_b1 and their rates
    assert np.all(rel[seen] < 0.05), rel
    pitch = [4, 6, 11, 13]
    k_rest = np.abs(ctrl.K[:, [j for j in range(14) if j not in pitch]]).max()
    assert np.abs(ctrl.K[:, pitch]).max() < 1e-6 * k_rest


def test_lqg_by_name_beats_passive_and_skyhook():
    rows = evaluate_sweep(["passive", "skyhook", "lqg"], "linear", [5], episodes=2)
    a_w = {r["policy"]: r["a_w"] for r in rows}
    assert a_w["lqg"] < 0.7 * a_w["passive"] and a_w["lqg"] < a_w["skyhook"], a_w
    rows = evaluate_vehicle(["passive", "lqg"], "linear", [5], episodes=1, duration=6.0)
    assert np.all(rows[1]["a_w_reduction_%"] > 10.0), rows[1]["a_w_reduction_%"]


def test_lqg_needs_the_sensor_observation():
    with pytest.raises(ValueError, match="observation must be 'sensors'"):
        LQG(VerticalSuspensionEnv(backend="linear", observation="full"))
    with pytest.raises(ValueError, match="observation must be 'sensors'"):
        VehicleLQG(VerticalVehicleVectorEnv(backend="linear", observation="full"))
