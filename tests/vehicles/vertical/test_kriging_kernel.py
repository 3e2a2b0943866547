"""The compiled Kriging predictor and a Kriging element inside the vertical kernels and envs."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import railgym  # noqa: F401  (registers the envs)
from railgym import _checks as val
from railgym.envs.vertical.env import VerticalSuspensionEnv
from railgym.track import track_time_input
from railgym.vehicles.vertical.elements import bump_stop_force
from railgym.vehicles.vertical.params import load_vehicle
from railgym.vehicles.vertical.simulate import simulate
from surrogates.models.kriging import Kriging, kriging_eval_into, kriging_scratch

VEH = load_vehicle("manchester")
ENV_ID = "railgym/VerticalSuspension-v1"
#: the element's training box: deflection (m), deflection rate (m/s)
HALF = np.array([0.02, 0.15])


def _law(U: np.ndarray) -> np.ndarray:
    """A smooth nonlinear suspension force (N) of deflection and rate."""
    p = VEH.kernel_params()
    return p.k2 * U[:, 0] * (1 + 300 * U[:, 0] ** 2) + 2e4 * np.tanh(U[:, 1] / 0.1)


def _fit(kernel: str = "gaussian", trend: str = "constant", **kw: object) -> Kriging:
    rng = np.random.default_rng(5)
    U = HALF * rng.uniform(-1.0, 1.0, (60, 2))
    return Kriging(kernel=kernel, trend=trend, **kw).fit(U, _law(U))


MODELS = {
    (kernel, trend, ex): _fit(kernel, trend, extrapolation=ex)
    for kernel in ("gaussian", "matern52")
    for trend in ("constant", "linear")
    for ex in ("linear", "clip")
}


def _mean_longdouble(model: Kriging, u: np.ndarray) -> tuple[float, np.ndarray, float]:
    """Independent extended-precision Kriging mean at ``u`` inside the box, its gradient
    (per input unit) and ``Σ|k_i w_i|``, the scale of the rounding of the correlation sum."""
    ld = np.longdouble
    lo, up = model.lower_.astype(ld), model.upper_.astype(ld)
    width = up - lo
    x = (u.astype(ld) - lo) / width
    X = (model.X_.astype(ld) - lo) / width
    ell = model.theta_.astype(ld) / width
    diff = x - X
    s = np.sum((diff / ell) ** 2, axis=1)
    if model.kernel == "gaussian":
        k = np.exp(-s / 2)
        g = k
    else:
        r = np.sqrt(ld(5) * s)
        k = (1 + r + r * r / 3) * np.exp(-r)
        g = ld(5) / 3 * (1 + r) * np.exp(-r)
    w = model.weights_.astype(ld)
    beta = model.beta_.astype(ld)
    trend = beta[0] + (x @ beta[1:] if model.trend == "linear" else 0)
    mean = model.y_mean_ + model.y_std_ * (trend + k @ w)
    dm = -((g * w) @ diff) / ell**2 + (beta[1:] if model.trend == "linear" else 0)
    return float(mean), (model.y_std_ * dm / width).astype(float), float(np.abs(k * w).sum())


def _points(seed: int, n: int, spread: float) -> np.ndarray:
    """``n`` points in the box scaled by ``spread`` (> 1: many outside), input units."""
    return spread * HALF * np.random.default_rng(seed).uniform(-1.0, 1.0, (n, 2))


@settings(max_examples=40, deadline=None)
@given(
    key=st.sampled_from(sorted(MODELS)),
    seed=st.integers(0, 2**32 - 1),
    spread=st.sampled_from([0.999, 1.5, 4.0, 1e3]),
)
def test_compiled_predictor_equals_predict_inside_and_outside_the_box(key, seed, spread):
    """kriging_eval_into = Kriging.predict to 1e-10 relative at random points, inside the box
    and outside it (linear extension from the boundary, or the clipped value)."""
    model = MODELS[key]
    arrays, work = model.kernel_arrays(), kriging_scratch(2)
    U = _points(seed, 25, spread)
    expected = model.predict(U)
    got = np.array([kriging_eval_into(u, arrays, work) for u in U])
    np.testing.assert_allclose(got, expected, rtol=1e-10, atol=1e-10 * model.y_std_)


@pytest.mark.parametrize("key", sorted(MODELS))
def test_compiled_predictor_equals_an_extended_precision_evaluation(key):
    """Against the Kriging formula evaluated independently in extended precision: inside,
    to the rounding of the correlation sum (scale Σ|k_i w_i|); outside, the value and tangent
    at the clipped point ("linear") or the clipped value ("clip")."""
    model = MODELS[key]
    arrays, work = model.kernel_arrays(), kriging_scratch(2)
    eps = np.finfo(float).eps
    for u in _points(1, 40, 3.0):
        uc = np.clip(u, model.lower_, model.upper_)
        mean, grad, scale = _mean_longdouble(model, uc)
        exact = mean + (grad @ (u - uc) if key[2] == "linear" else 0.0)
        tol = 1e-12 * abs(exact) + 200 * eps * model.y_std_ * (scale + 1)
        if key[2] == "linear":
            tol += 1e-9 * np.abs(grad * (u - uc)).sum()
        assert abs(kriging_eval_into(u, arrays, work) - exact) <= tol


def test_kernel_arrays_are_copies_and_refit_refreshes_the_prediction():
    model = _fit()
    arrays = model.kernel_arrays()
    arrays.weights[:] = 0.0
    u = np.array([[0.01, 0.05]])
    assert abs(model.predict(u)[0] - _law(u)[0]) < 0.01 * abs(_law(u)[0])
    rng = np.random.default_rng(9)
    U = HALF * rng.uniform(-1.0, 1.0, (40, 2))
    model.fit(U, 2 * _law(U))  # a refit must not reuse cached kernel arrays
    assert abs(model.predict(u)[0] - 2 * _law(u)[0]) < 0.02 * abs(_law(u)[0])


def _python_rk4(model: Kriging, z, zdot, fa, dt, n_sub):
    """Plain Python RK4 of the vertical model with ``F_s = model.predict([δ, δ̇])``; the
    track's stage midpoints by the cubic Hermite rule of the kernels. Returns the carbody
    acceleration at the end of each control step (m/s²) and the out-of-box evaluations."""
    p = VEH.kernel_params()

    def rhs(x, zc, zdc, f):
        u = np.array([[x[0] - x[2], x[1] - x[3]]])
        out = int(np.any(u < model.lower_) or np.any(u > model.upper_))
        fs = float(model.predict(u)[0])
        a1 = (p.k1 * (zc - x[0]) + p.c1 * (zdc - x[1]) - fs - f) / p.m1
        return np.array([x[1], a1, x[3], (fs + f) / p.m2]), out

    x = np.zeros(4)
    acc, ood = [], 0
    for m, f in enumerate(fa):
        for k in range(m * n_sub, (m + 1) * n_sub):
            za, zda, zb, zdb = z[k], zdot[k], z[k + 1], zdot[k + 1]
            zm = 0.5 * (za + zb) + dt / 8 * (zda - zdb)
            zdm = 1.5 / dt * (zb - za) - 0.25 * (zda + zdb)
            r1, o1 = rhs(x, za, zda, f)
            r2, o2 = rhs(x + 0.5 * dt * r1, zm, zdm, f)
            r3, o3 = rhs(x + 0.5 * dt * r2, zm, zdm, f)
            r4, o4 = rhs(x + dt * r3, zb, zdb, f)
            ood += o1 + o2 + o3 + o4
            x = x + dt / 6 * (r1 + 2 * r2 + 2 * r3 + r4)
        k = (m + 1) * n_sub
        acc.append(rhs(x, z[k], zdot[k], f)[0][3])
    return np.array(acc), ood


def test_kriging_env_episode_equals_a_python_integration_of_the_model():
    """gym.make with a Kriging element: 1 s of class 4 track with random actuator forces
    (the deflection leaves the training box) = a plain Python RK4 calling Kriging.predict."""
    model = MODELS["matern52", "constant", "linear"]
    env = gym.make(ENV_ID, backend="surrogate", surrogate=model, duration=1.0, track_class=4)
    env.reset(seed=3)
    base = env.unwrapped
    z, zdot = base.track()
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1.0, 1.0, (base.cfg.n_steps, 1)).astype(np.float32)
    acc = []
    for a in actions:
        _, _, term, _, info = env.step(a)
        assert not term
        acc.append(info["carbody_acc"])
    force = actions[:, 0].astype(float) * base.cfg.f_max
    ref, ood = _python_rk4(model, z, zdot, force, base.cfg.dt, 10)
    assert base.cfg.n_sub == 10
    assert info["out_of_domain"] == ood > 0
    np.testing.assert_allclose(acc, ref, rtol=0, atol=1e-9 * np.abs(ref).max())


def test_kriging_vector_env_equals_single_envs():
    model = MODELS["gaussian", "linear", "linear"]
    n = 3
    venv = gym.make_vec(
        ENV_ID, num_envs=n, vectorization_mode="vector_entry_point", surrogate=model, duration=0.5
    )
    singles = [VerticalSuspensionEnv(surrogate=model, duration=0.5) for _ in range(n)]
    obs_v, _ = venv.reset(seed=7)
    obs_s = np.stack([e.reset(seed=7 + i)[0] for i, e in enumerate(singles)])
    np.testing.assert_array_equal(obs_v, obs_s)
    rng = np.random.default_rng(1)
    for _ in range(40):
        act = rng.uniform(-1, 1, (n, 1)).astype(np.float32)
        obs_v, rew_v, _, _, info_v = venv.step(act)
        for i, e in enumerate(singles):
            o, r, _, _, info = e.step(act[i])
            np.testing.assert_allclose(obs_v[i], o, rtol=1e-12, atol=1e-12)
            assert info["carbody_acc"] == pytest.approx(info_v["carbody_acc"][i], rel=1e-12)


def test_kriging_raise_policy_and_the_whole_vehicle_refusal():
    """simulate honours extrapolation='raise'; VerticalVehicle-v1 refuses a Kriging by name."""
    model = _fit(extrapolation="raise")
    z = np.zeros(2001)
    with pytest.raises(ValueError, match="'raise'"):
        simulate("surrogate", VEH, z, z, 1e-3, force_a=3e4, surrogate=model, sample_every=10)
    with pytest.raises(val.FieldError, match="surrogate.*Kriging"):
        gym.make("railgym/VerticalVehicle-v1", surrogate=model)


def test_memory_form_kriging_force_is_its_prediction_plus_the_bump_stop_law():
    """A 3-input Kriging (δ, δ̇, ζ = δ − s) with the Maxwell state and the bump-stop law: the
    kernel's recorded F_s equals Kriging.predict at the recorded inputs plus F_bump(δ)."""
    rng = np.random.default_rng(2)
    U = np.array([0.05, 0.5, 4e-3]) * rng.uniform(-1.0, 1.0, (80, 3))
    V = _law(U[:, :2]) + 3e6 * U[:, 2]
    model = Kriging(kernel="matern52").fit(U, V)
    model.features_ = {"form": "maxwell", "tau": 8e-3, "known_physics": ["bump_stop"]}
    _, z, zdot = track_time_input(3, 30.0, 1.0, 1e-3, 4)
    amp = 1.5 * VEH.kernel_params().k2 * VEH.bump_stop.free_travel_compression
    fa = amp * np.sin(2 * np.pi * 1.5 * np.arange(100) * 0.01)
    rec = simulate("surrogate", VEH, z, zdot, 1e-3, force_a=fa, surrogate=model, sample_every=10)
    assert rec["states"].shape[1] == 5 and rec["contacts"] > 0 and not rec["diverged"]
    x = rec["states"]
    d = x[:, 0] - x[:, 2]
    u = np.column_stack([d, x[:, 1] - x[:, 3], d - x[:, 4]])
    p = VEH.kernel_params()
    expected = model.predict(u) + np.array([bump_stop_force(v, p) for v in d])
    np.testing.assert_allclose(rec["F_s"], expected, rtol=1e-12, atol=1e-9 * np.abs(V).max())
