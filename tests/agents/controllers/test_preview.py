"""LQ preview control (agents.controllers.preview): on an exact discrete linear model with a known
delay the closed loop is the textbook augmented one, without preview the controllers are lqr and
lqg action for action, with preview the rear floor point rides better, and the CLI runs it."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from scipy.linalg import expm, solve_discrete_are

from agents.commands.cli import main
from agents.controllers.classical import VehicleLQR
from agents.controllers.control_base import vehicle_lqr_gain, vehicle_lqr_weights
from agents.controllers.lqg import VehicleLQG
from agents.controllers.preview import LQGPreview, LQRPreview
from agents.controllers.registry import VEHICLE_CONTROLLERS, VEHICLE_ID, build_controller
from agents.policies.residual_export import linear_base
from railgym.envs.vehicle.env import VerticalVehicleEnv, VerticalVehicleVectorEnv
from railgym.vehicles.vehicle.model import linear_state_space

SPAN = 2.0 * (9.5 + 1.28)  # front-to-rear wheelset distance of manchester_whole, m


def _plant(a, b, e, dt, nodes=16):
    """Exact sampling of ``ẋ = A·x + B·F + E·w`` over ``dt``, F held, w linear in time from
    w_0 to w_1, by Gauss–Legendre quadrature of the convolution integral:
    ``(Φ, Γ, E_0, E_1)`` with ``x⁺ = Φ·x + Γ·F + E_0·w_0 + E_1·w_1``."""
    s, wts = np.polynomial.legendre.leggauss(nodes)
    s, wts = 0.5 * dt * (s + 1.0), 0.5 * dt * wts
    kernels = [w * expm(a * (dt - t)) for t, w in zip(s, wts, strict=True)]
    gamma = sum(k @ b for k in kernels)
    e1 = sum(k @ e * (t / dt) for k, t in zip(kernels, s, strict=True))
    return expm(a * dt), gamma, sum(k @ e for k in kernels) - e1, e1


def test_closed_loop_on_an_exact_model_with_a_known_delay_is_the_augmented_one(tmp_path):
    """Wheelsets 2b = 2.5 m and 2a = 19 m apart at 50 m/s and a 10 ms step: every wheelset
    sits on a whole register sample (0.5 m), the rear bogie meets the front one's track 38
    steps later, the preview grid (20 m, 0.5 m) is the register. The plant is the linear
    model sampled exactly (force held, wheel inputs first-order held between the samples),
    all four wheelsets driven, the front one unknown to the controller. Independently of
    :mod:`agents.controllers.preview`: the register shift, the augmented DARE (scipy on the whole
    system) and the loop ``F = −K·x − K_ξ·ξ`` with the LQR's ``K``; the controller, fed the
    full observation and its preview channels, gives the same forces step for step."""
    path = tmp_path / "whole.yaml"
    with open(path, "w") as f:
        yaml.safe_dump(
            {
                "base": "manchester",
                "whole_vehicle": {
                    "carbody_mass": 32000.0,
                    "carbody_pitch_inertia": 1.97e6,
                    "carbody_length": 26.0,
                    "bending_frequency": 10.0,
                    "bending_damping": 0.02,
                    "bending_modal_mass": 21654.0,
                    "bogie_mass": 2615.0,
                    "bogie_pitch_inertia": 1476.0,
                    "bogie_semi_spacing": 9.5,
                    "semi_wheelbase": 1.25,
                },
            },
            f,
        )
    v, horizon, steps = 50.0, 20.0, 160
    env = VerticalVehicleEnv(
        backend="linear", observation="full", preview=horizon, speed=v, vehicle=str(path)
    )
    base = env.unwrapped
    ctrl = LQRPreview(env)
    dt, f_max, scale = base.cfg.control_dt, base.cfg.f_max, base.obs_scale
    step = v * dt
    wheels = base.vehicle.wheelset_positions
    offsets = np.rint((wheels - wheels[-1]) / step).astype(int)
    assert offsets.tolist() == [43, 38, 5, 0] and ctrl.design.known == (1, 2, 3)
    n_reg = int(round(horizon / step)) + 1  # 41 samples, 0..20 m
    a, b, e, _, _ = linear_state_space(base.vehicle)
    phi, gamma, e0, e1 = _plant(a, b, e, dt)
    k_lqr = vehicle_lqr_gain(base.vehicle, ctrl.params, base.cfg)[3]

    # the augmented model: x and the register [z_0, ż_0, …, z_40, ż_40]
    def sample(m):  # selects register entry m (z, ż); beyond the head: unknown, zero
        out = np.zeros((2, 2 * n_reg))
        if m < n_reg:
            out[:, 2 * m : 2 * m + 2] = np.eye(2)
        return out

    g = sum(
        e0[:, [j, 4 + j]] @ sample(offsets[j]) + e1[:, [j, 4 + j]] @ sample(offsets[j] + 1)
        for j in (1, 2, 3)
    )
    shift = np.zeros((2 * n_reg, 2 * n_reg))
    for m in range(n_reg - 1):
        shift[2 * m : 2 * m + 2] = sample(m + 1)
    big_a = np.block([[phi, g], [np.zeros((2 * n_reg, 14)), shift]])
    big_b = np.vstack([gamma, np.zeros((2 * n_reg, 2))])
    big_q = np.zeros((14 + 2 * n_reg,) * 2)
    _, _, q, n, r = vehicle_lqr_weights(base.vehicle, ctrl.params, base.cfg)
    big_q[:14, :14] = q * dt
    big_s = np.vstack([n * dt, np.zeros((2 * n_reg, 2))])
    p = solve_discrete_are(big_a, big_b, big_q, r * dt, s=big_s)
    k_big = np.linalg.solve(r * dt + big_b.T @ p @ big_b, big_b.T @ p @ big_a + big_s.T)
    k_xi = k_big[:, 14:]
    np.testing.assert_allclose(ctrl.k_preview, k_xi, rtol=1e-6, atol=1e-6 * np.abs(k_xi).max())

    # a smooth track of a few wavelengths, 1 mm, sampled every 0.5 m
    rng = np.random.default_rng(5)
    x = step * np.arange(steps + 50)
    lam, amp, ph = rng.uniform(3.0, 60.0, 8), rng.uniform(0.1e-3, 0.3e-3, 8), rng.uniform(0, 6, 8)
    z = (amp * np.sin(2 * np.pi * x[:, None] / lam + ph)).sum(1)
    zdot = v * (amp * 2 * np.pi / lam * np.cos(2 * np.pi * x[:, None] / lam + ph)).sum(1)
    track = np.stack([z, zdot], axis=1)  # (samples, 2)

    def advance(state, force, k):
        nxt = phi @ state + gamma @ force
        for j in range(4):
            cols = [j, 4 + j]
            nxt += e0[:, cols] @ track[k + offsets[j]] + e1[:, cols] @ track[k + offsets[j] + 1]
        return nxt

    n_p = base.preview_points.size
    assert n_p == n_reg
    state_c, state_i = np.zeros(14), np.zeros(14)
    forces_c, forces_i = [], []
    for k in range(steps):
        obs = np.zeros(len(base.obs_names))
        obs[:14] = state_c
        obs[27 : 27 + n_p], obs[27 + n_p :] = track[k : k + n_p, 0], track[k : k + n_p, 1]
        action, _ = ctrl.predict((obs / scale).astype(np.float32))
        forces_c.append(action * f_max)
        state_c = advance(state_c, forces_c[-1], k)
        register = track[k : k + n_reg].reshape(-1)
        forces_i.append(-(k_lqr @ state_i) - k_big[:, 14:] @ register)
        state_i = advance(state_i, forces_i[-1], k)
    forces_c, forces_i = np.array(forces_c), np.array(forces_i)
    assert 0.05 * f_max < np.abs(forces_i).max() < f_max  # the loop stays linear (no clip)
    np.testing.assert_allclose(forces_c, forces_i, rtol=0, atol=2e-5 * np.abs(forces_i).max())
    # the preview's part of the force is not small
    ff = np.array([k_big[:, 14:] @ track[k : k + n_reg].reshape(-1) for k in range(steps)])
    assert np.abs(ff).max() > 0.05 * np.abs(forces_i).max()  # 5000 × the tolerance


@pytest.mark.parametrize(
    "observation, plain, preview",
    [("sensors", VehicleLQG, LQGPreview), ("full", VehicleLQR, LQRPreview)],
)
def test_without_preview_the_actions_are_lqg_and_lqr_exactly(observation, plain, preview):
    venv = VerticalVehicleVectorEnv(
        num_envs=2, backend="linear", duration=1.0, observation=observation, preview=0.0
    )
    ref, ctrl = plain(venv), preview(venv)
    assert ctrl.design is None
    obs, _ = venv.reset(seed=11)
    for _ in range(100):
        want, _ = ref.predict(obs)
        got, _ = ctrl.predict(obs)
        np.testing.assert_array_equal(got, want)
        obs, *_ = venv.step(want)
    assert np.abs(want).max() > 0.01


def _a_w(ctrl_class, preview):
    venv = VerticalVehicleVectorEnv(num_envs=4, backend="linear", duration=10.0, preview=preview)
    ctrl = ctrl_class(venv)
    obs, _ = venv.reset(seed=1000)
    while True:
        action, _ = ctrl.predict(obs)
        obs, _, _, truncated, info = venv.step(action)
        if truncated.all():
            return info["comfort"]["a_w"].mean(0)


def test_preview_of_the_wheelbase_lowers_the_rear_ride_below_lqg():
    """Linear backend, class 5 at 144 km/h, four 10 s tracks: with the full horizon the rear
    floor point's a_w is at least 8 % below LQG's (measured 12 %), front and centre lower
    too; the actuators' limit (8 kN) bounds the gain."""
    lqg, lq_preview = _a_w(VehicleLQG, SPAN), _a_w(LQGPreview, SPAN)
    assert lq_preview[2] < 0.92 * lqg[2]
    assert np.all(lq_preview < lqg)


def test_controllers_refuse_the_other_observation():
    with pytest.raises(ValueError, match="full"):
        LQRPreview(VerticalVehicleEnv(backend="linear", duration=0.5, preview=3.0))
    with pytest.raises(ValueError, match="sensors"):
        LQGPreview(VerticalVehicleEnv(backend="linear", duration=0.5, observation="full"))
    assert VEHICLE_CONTROLLERS["lq-preview"][0] is LQGPreview
    assert VEHICLE_CONTROLLERS["lqr-preview"][0] is LQRPreview


def test_cli_evaluates_lq_preview_beside_lqg(capsys):
    argv = ["evaluate", "lq-preview", "lqg", "--env", "vehicle", "--backend", "linear"]
    short = ["--track-class", "5", "--episodes", "1", "--duration", "0.5"]
    assert main([*argv, *short, "--preview", "6"]) == 0
    out = capsys.readouterr().out
    assert "preview 6 m" in out
    rows = [line.split()[2] for line in out.splitlines()[2:]]
    assert rows == ["passive", "skyhook", "lq-preview", "lqg"]
    assert main([*argv, *short, "--preview", "-1"]) == 2
    assert "preview" in capsys.readouterr().err
    assert main(["evaluate", "skyhook", "--preview", "5", "--episodes", "1"]) == 2
    assert "--preview: only for --env vehicle" in capsys.readouterr().err


def test_lq_preview_exports_as_a_linear_base():
    """The residual export's state-space law (agents.policies.residual_export's docstring),
    evaluated here in numpy, reproduces the controller's actions over 60 random observations: the
    filter blind to the preview channels, the feed-forward as the observation gain G."""
    env = VerticalVehicleEnv(backend="linear", duration=1.0, preview=8.0)
    ctrl = build_controller(VEHICLE_ID, "lq-preview", env)
    base = linear_base(ctrl, "lq-preview", 0.5)
    n_obs = len(env.unwrapped.obs_names)
    assert base.c.shape == (n_obs, base.n_x) and np.abs(base.g[:, 11:]).max() > 0
    obs = np.random.default_rng(3).normal(0.0, 0.3, (60, n_obs)).astype(np.float32)
    want = np.array([ctrl.predict(o)[0] for o in obs])
    x, u, got = np.zeros(base.n_x), np.zeros(2), []
    for o in obs:
        y = o * base.obs_scale
        x_hat = x + base.m @ (y - base.c @ x - base.d @ u)
        force = np.clip(base.g @ y - base.k @ x_hat, -base.f_max, base.f_max)
        got.append(np.clip(force / base.f_max, -1.0, 1.0).astype(np.float32))
        x, u = base.phi @ x_hat + base.gamma @ force, force
    np.testing.assert_allclose(np.array(got), want, rtol=0, atol=1e-6)
    assert np.ptp(want) > 0.1
