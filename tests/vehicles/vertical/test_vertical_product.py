"""The ``"maxwell_product"`` element (inputs δ, δ̇, ζ, δ·ζ) inside the one-bogie vertical
kernels: against an independent scipy integration of the quarter car with its analytic law,
through ``gym.make`` from its JSON file with the user's vehicle, and refused by the whole
vehicle's kernels."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicHermiteSpline

from railgym.track import track_time_input
from railgym.vehicles.vehicle.model import lpr_arrays
from railgym.vehicles.vertical.kernels import state_size, surrogate_arrays
from railgym.vehicles.vertical.params import load_vehicle
from railgym.vehicles.vertical.simulate import simulate
from surrogates import io
from surrogates.memory import memory_features
from surrogates.models.lpr import LegendreRegression

VEH = load_vehicle("manchester")
DT = 1e-3
TAU = 0.03  # s
#: F = K0·δ + C·δ̇ + K1·ζ + KAPPA·δ·ζ (N/m, N s/m, N/m, N/m²): a Maxwell branch whose
#: stiffness K1 + KAPPA·δ grows in compression
K0, C, K1, KAPPA = 3.0e5, 1.5e4, 4.0e5, 8.0e6


def _law_element() -> LegendreRegression:
    """The law as a 4-input LPR of degree 1 per input (exact, linear extrapolation exact)."""
    rng = np.random.default_rng(0)
    U3 = np.array([0.05, 0.5, 0.02]) * rng.uniform(-1.0, 1.0, (200, 3))
    U = np.column_stack([U3, U3[:, 0] * U3[:, 2]])
    V = K0 * U[:, 0] + C * U[:, 1] + K1 * U[:, 2] + KAPPA * U[:, 3]
    model = LegendreRegression(degree=(1, 1, 1, 1)).fit(U, V)
    model.features_ = {"form": "maxwell_product", "tau": TAU, "known_physics": []}
    return model


def _scipy_quarter_car(z, zdot, fa):
    """[x1, v1, x2, v2, s] with the analytic law by DOP853 on the cubic Hermite track (the
    kernels' track interpolation), the actuator force held over each step."""
    p = VEH.kernel_params()
    t = np.arange(z.size) * DT
    track = CubicHermiteSpline(t, z, zdot)
    rate = track.derivative()

    def rhs(s, x):
        k = min(int(s / DT), fa.size - 1)
        d, dd = x[0] - x[2], x[1] - x[3]
        zeta = d - x[4]
        fs = K0 * d + C * dd + K1 * zeta + KAPPA * d * zeta
        acc1 = (p.k1 * (track(s) - x[0]) + p.c1 * (rate(s) - x[1]) - fs - fa[k]) / p.m1
        return [x[1], acc1, x[3], (fs + fa[k]) / p.m2, zeta / TAU]

    states = [np.zeros(5)]
    for k in range(z.size - 1):  # one solve per step: the actuator force jumps there
        sol = solve_ivp(rhs, (t[k], t[k + 1]), states[-1], method="DOP853", rtol=1e-11, atol=1e-13)
        states.append(sol.y[:, -1])
    return np.array(states)


def test_the_kernel_equals_an_independent_scipy_integration():
    """RK4 of the kernel (1 ms) against DOP853 at 1e-11: equal to the RK4 truncation; the
    memory branch's coupling acts (the force differs from the same law without it)."""
    _, z, zdot = track_time_input(4, 30.0, 0.6, DT, 3)
    fa = 4e3 * np.sin(2 * np.pi * 1.2 * np.arange(z.size - 1) * DT)
    model = _law_element()
    rec = simulate("surrogate", VEH, z, zdot, DT, force_a=fa, surrogate=model)
    ref = _scipy_quarter_car(z, zdot, fa)
    assert rec["states"].shape[1] == 5 == state_size("surrogate", surrogate_arrays(model))
    scale = np.abs(ref).max(axis=0)
    np.testing.assert_allclose(rec["states"], ref, rtol=0, atol=1e-6 * scale.max())
    for j in range(5):
        assert np.abs(rec["states"][:, j] - ref[:, j]).max() < 1e-6 * scale[j]
    d = ref[:, 0] - ref[:, 2]
    coupling = KAPPA * d * (d - ref[:, 4])
    assert np.abs(coupling).max() > 0.01 * np.abs(K1 * (d - ref[:, 4])).max()


def test_the_product_input_is_the_fourth_and_only_the_new_form_sets_it():
    model = _law_element()
    lpr = surrogate_arrays(model)
    assert lpr.product and lpr.tau == TAU and lpr.lo.shape == (4,)
    model.features_ = {**model.features_, "form": "maxwell"}
    with pytest.raises(ValueError, match=r"'maxwell' must have 3 inputs"):
        surrogate_arrays(model)


AIR_CAR_YAML = """\
vehicle:
  name: user_quarter_car
  m1: 2100.0
  m2: 8150.0
  k1: 2.9e+6
  c1: 2.6e+4
  k2: 3.0e+5
  c2: 1.5e+4
  gravity: 9.81
"""


def test_gym_make_runs_the_element_file_with_the_users_vehicle(tmp_path):
    """The JSON file of the form, with units, drives VerticalSuspension-v3 on the user's
    vehicle: 5 states, the element's own law at every step (F_s from the states)."""
    model = _law_element()
    units = {"x1-x2": "m", "v1-v2": "m/s", "zeta": "m", "(x1-x2)*zeta": "m^2", "F_s": "N"}
    path = io.save(
        model,
        tmp_path / "el.json",
        inputs=list(units)[:4],
        output="F_s",
        units=units,
        form="maxwell_product",
        tau=TAU,
    )
    (tmp_path / "car.yaml").write_text(AIR_CAR_YAML)
    env = gym.make(
        "railgym/VerticalSuspension-v3",
        surrogate=str(path),
        vehicle=str(tmp_path / "car.yaml"),
        track_class=4,
        duration=1.0,
    )
    env.reset(seed=3)
    for _ in range(50):
        env.step(np.zeros(env.action_space.shape, np.float32))
    x = env.unwrapped.state
    assert x.shape == (5,) and np.all(np.isfinite(x)) and abs(x[4]) > 0
    env.close()


def test_the_whole_vehicle_refuses_the_form_naming_it():
    with pytest.raises(ValueError, match=r"'maxwell_product'.*one-bogie"):
        lpr_arrays(_law_element())


def test_the_features_of_the_form_drive_the_same_law_offline():
    """The training features of the form (memory_features, exact first-order hold) and the
    kernel's state agree: the element predicts the kernel's force along its own run."""
    _, z, zdot = track_time_input(4, 30.0, 0.3, DT, 5)
    model = _law_element()
    rec = simulate("surrogate", VEH, z, zdot, DT, surrogate=model)
    x = rec["states"]
    d, dd = x[:, 0] - x[:, 2], x[:, 1] - x[:, 3]
    t = np.arange(d.size) * DT
    U = memory_features(d, dd, t, TAU, "maxwell_product")
    zeta_kernel = d - x[:, 4]
    # the first-order hold of δ between the samples against RK4 of the kernel: close
    assert np.abs(U[:, 2] - zeta_kernel).max() < 2e-3 * np.abs(zeta_kernel).max()


def test_refinement_pairs_and_refit_keep_the_form():
    """``railgym refine`` on such an element: its pairs from a run are the form's four
    inputs (the product from the same Maxwell state) and the refit keeps the class, the
    free product slope and the form."""
    from railgym.vehicles.refinement import element_pairs, refit_worst
    from surrogates.passive import PassiveLegendreRegression

    t = np.arange(0.0, 2.0, 5e-3)
    d = 0.02 * np.sin(2 * np.pi * 1.3 * t) + 0.005 * np.sin(2 * np.pi * 7.0 * t)
    dd = np.gradient(d, t)
    zeta = memory_features(d, dd, t, TAU)[:, 2]
    run = {"t": t, "delta": d, "delta_dot": dd}
    run["force"] = K0 * d + C * dd + K1 * zeta + KAPPA * d * zeta
    model = PassiveLegendreRegression(degree=(1, 1, 1, 1), monotone=(True, True, True, False))
    U, V = element_pairs(_law_element(), run, 2, "manchester")
    assert U.shape[1] == 4 and U.shape[0] == V.size
    np.testing.assert_array_equal(U[:, 3], U[:, 0] * U[:, 2])
    model = model.fit(U, V)
    model.features_ = {"form": "maxwell_product", "tau": TAU, "known_physics": []}
    refit, U2, _ = refit_worst(model, (U, V), [element_pairs(model, run, 3, "manchester")], 10)
    assert refit.get_params()["monotone"] == (True, True, True, False)
    assert refit.features_["form"] == "maxwell_product" and U2.shape == (U.shape[0] + 10, 4)
    np.testing.assert_allclose(refit.predict(U), V, rtol=0, atol=1e-6 * np.abs(V).max())
