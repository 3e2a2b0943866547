"""Tests of the Kriging surrogate model."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.optimize import approx_fprime

from surrogates import Kriging
from surrogates.models.kriging import JITTER, _cholesky, _neg_log_likelihood, _trend_matrix


def branin(U: np.ndarray) -> np.ndarray:
    x, y = U[:, 0], U[:, 1]
    b, c, t = 5.1 / (4 * np.pi**2), 5 / np.pi, 1 / (8 * np.pi)
    return (y - b * x**2 + c * x - 6) ** 2 + 10 * (1 - t) * np.cos(x) + 10


def suspension(U: np.ndarray) -> np.ndarray:
    """Progressive spring (u1 in m) + damper with a tanh blow-off knee (u2 in m/s), N."""
    u1, u2 = U[:, 0], U[:, 1]
    return 4e5 * u1 + 2.2e8 * u1**3 + 3e3 * np.tanh(u2 / 0.1) + 5e3 * u2


def lhs(n: int, lower: list[float], upper: list[float], seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    d = len(lower)
    unit = (np.argsort(rng.random((n, d)), axis=0) + rng.random((n, d))) / n
    return np.asarray(lower) + unit * (np.asarray(upper) - np.asarray(lower))


def rel_rms(pred: np.ndarray, true: np.ndarray) -> float:
    return float(np.sqrt(np.mean((pred - true) ** 2) / np.mean(true**2)))


def quadratic_fit_predict(U: np.ndarray, V: np.ndarray, W: np.ndarray) -> np.ndarray:
    def basis(X: np.ndarray) -> np.ndarray:
        x, y = X[:, 0], X[:, 1]
        return np.column_stack([np.ones_like(x), x, y, x * x, x * y, y * y])

    coef = np.linalg.lstsq(basis(U), V, rcond=None)[0]
    return basis(W) @ coef


BRANIN_BOX = ([-5.0, 0.0], [10.0, 15.0])
SUSP_BOX = ([-0.03, -0.3], [0.03, 0.3])


@pytest.fixture(scope="module")
def branin_data() -> tuple[np.ndarray, np.ndarray]:
    U = lhs(40, *BRANIN_BOX, seed=1)
    return U, branin(U)


@pytest.fixture(scope="module")
def branin_model(branin_data: tuple[np.ndarray, np.ndarray]) -> Kriging:
    return Kriging().fit(*branin_data)


@pytest.mark.parametrize("kernel", ["gaussian", "matern52"])
def test_interpolates_training_points_without_nugget(kernel):
    U = lhs(30, *SUSP_BOX, seed=12)
    V = suspension(U)
    model = Kriging(kernel=kernel, nugget=None).fit(U, V)
    assert JITTER <= model.nugget_ < 1e-6
    err = np.max(np.abs(model.predict(U) - V)) / np.max(np.abs(V))
    assert err < 1e-6
    var = model.predict_variance(U)
    assert np.all(var >= 0.0)
    assert np.max(var) < 1e-10 * model.sigma2_
    mid = 0.5 * (U[:-1] + U[1:])  # between training points, inside the box
    assert np.all(model.predict_variance(mid) > 100.0 * np.max(var))
    corners = np.array(np.meshgrid(*zip(model.lower_, model.upper_, strict=True))).reshape(2, -1).T
    assert np.all(model.predict_variance(corners) > 1e-6 * model.sigma2_)


def test_variance_far_away_is_process_plus_trend_variance(branin_data):
    """Ordinary Kriging far from the data: ``σ² (1 + 1/(1ᵀ R⁻¹ 1))``."""
    # fixed nugget: R well conditioned, so the independent solve below is exact to round-off
    # (the noise-free auto fit is nearly interpolating, cond(R) ~ 1e15)
    m = Kriging(nugget=1e-6).fit(*branin_data)
    diff = (m.X_[:, None, :] - m.X_[None, :, :]) / m.theta_
    R = np.exp(-0.5 * np.sum(diff**2, axis=2)) + m.nugget_ * np.eye(len(m.X_))
    ones = np.ones(len(m.X_))
    expected = m.sigma2_ * (1.0 + 1.0 / (ones @ np.linalg.solve(R, ones)))
    far = np.array([[1e4, 1e4], [-1e4, 3.0]])
    np.testing.assert_allclose(m.predict_variance(far), expected, rtol=1e-6)


def test_beats_quadratic_polynomial_out_of_bag():
    U = lhs(60, *SUSP_BOX, seed=2)
    W = lhs(400, *SUSP_BOX, seed=3)
    W = np.clip(W, U.min(axis=0), U.max(axis=0))
    V, true = suspension(U), suspension(W)
    err_krig = rel_rms(Kriging().fit(U, V).predict(W), true)
    err_poly = rel_rms(quadratic_fit_predict(U, V, W), true)
    assert err_krig < 0.2 * err_poly
    assert err_krig < 1e-2


def test_branin_accuracy(branin_model):
    W = lhs(500, *BRANIN_BOX, seed=4)
    W = np.clip(W, branin_model.lower_, branin_model.upper_)
    true = branin(W)
    err_krig = rel_rms(branin_model.predict(W), true)
    err_poly = rel_rms(quadratic_fit_predict(branin_model.X_, branin_model.y_, W), true)
    assert err_krig < 0.05 * err_poly
    assert err_krig < 1e-2


@pytest.mark.parametrize("kernel", ["gaussian", "matern52"])
@pytest.mark.parametrize("trend", ["constant", "linear"])
def test_kernels_and_trends(branin_data, kernel, trend):
    U, V = branin_data
    model = Kriging(trend=trend, kernel=kernel).fit(U, V)
    assert model.beta_.shape == ((3,) if trend == "linear" else (1,))
    assert model.theta_.shape == (2,) and np.all(model.theta_ > 0)
    W = np.clip(lhs(300, *BRANIN_BOX, seed=5), model.lower_, model.upper_)
    assert rel_rms(model.predict(W), branin(W)) < 3e-2


def test_linear_trend_reproduces_plane_and_extrapolates_it():
    U = lhs(25, [0.0, -1.0], [2.0, 1.0], seed=6)
    V = 3.0 + 2.0 * U[:, 0] - 5.0 * U[:, 1]
    model = Kriging(trend="linear").fit(U, V)
    W = np.array([[1.0, 0.0], [4.0, 3.0], [-10.0, -7.0]])
    expected = 3.0 + 2.0 * W[:, 0] - 5.0 * W[:, 1]
    np.testing.assert_allclose(model.predict(W), expected, rtol=1e-5, atol=1e-5)


def test_nugget_estimates_noise_variance():
    rng = np.random.default_rng(7)
    U = rng.uniform(0.0, 1.0, (150, 1))
    noise_sd = 0.1
    V = np.sin(6.0 * U[:, 0]) + noise_sd * rng.standard_normal(150)
    model = Kriging().fit(U, V)
    noise_var = model.nugget_ * model.sigma2_
    assert 0.5 * noise_sd**2 < noise_var < 2.0 * noise_sd**2
    W = np.linspace(0.05, 0.95, 50)[:, None]
    assert rel_rms(model.predict(W), np.sin(6.0 * W[:, 0])) < 0.1


def test_extrapolation_linear_is_finite_and_matches_boundary_tangent(branin_model):
    far = np.array([[1e6, -1e6], [-1e3, 50.0], [2.5, 1e5]])
    assert np.all(np.isfinite(branin_model.predict(far)))
    assert branin_model.n_out_of_domain_ >= 3
    ub = np.clip(far, branin_model.lower_, branin_model.upper_)
    grad = branin_model._gradient_inside(ub)
    expected = branin_model._predict_inside(ub) + np.sum(grad * (far - ub), axis=1)
    np.testing.assert_allclose(branin_model.predict(far), expected, rtol=1e-12)


@pytest.mark.parametrize("kernel", ["gaussian", "matern52"])
@pytest.mark.parametrize("trend", ["constant", "linear"])
def test_analytic_gradient_matches_finite_differences(branin_data, kernel, trend):
    # a fixed nugget keeps the predictor well conditioned: the finite differences then see
    # the formula, not the round-off of a (nearly) interpolating fit
    model = Kriging(trend=trend, kernel=kernel, nugget=1e-6).fit(*branin_data)
    pts = lhs(10, [-4.0, 1.0], [9.0, 14.0], seed=8)
    G = model._gradient_inside(pts)
    h = 1e-5
    for j in range(2):
        step = np.zeros(2)
        step[j] = h
        fd = (model._predict_inside(pts + step) - model._predict_inside(pts - step)) / (2 * h)
        np.testing.assert_allclose(G[:, j], fd, rtol=1e-5, atol=1e-5 * np.abs(fd).max())


@pytest.mark.parametrize("kernel", ["gaussian", "matern52"])
@pytest.mark.parametrize("auto", [True, False])
def test_likelihood_gradient_matches_finite_differences(kernel, auto):
    rng = np.random.default_rng(9)
    X = rng.random((40, 2))
    y = np.sin(3.0 * X[:, 0]) + X[:, 1] ** 2 + 0.05 * rng.standard_normal(40)
    y = (y - y.mean()) / y.std()
    D2 = np.moveaxis((X[:, None, :] - X[None, :, :]) ** 2, 2, 0).reshape(2, -1)
    F = _trend_matrix(X, "linear")
    q = np.log([0.3, 0.7, 1e-2]) if auto else np.log([0.3, 0.7])

    def f(q: np.ndarray) -> float:
        return _neg_log_likelihood(q, D2, y, F, kernel, auto, 1e-3)[0]

    grad = _neg_log_likelihood(q, D2, y, F, kernel, auto, 1e-3)[1]
    np.testing.assert_allclose(grad, approx_fprime(q, f, 1e-7), rtol=1e-4, atol=1e-4)


def test_outputs_scale_consistently(branin_data):
    U, V = branin_data
    # fixed nugget: well conditioned, so both fits agree to round-off (see the gradient test)
    a = Kriging(nugget=1e-6).fit(U, V)
    b = Kriging(nugget=1e-6).fit(U, 10.0 * V + 3.0)
    W = lhs(20, [-4.0, 1.0], [9.0, 14.0], seed=10)
    np.testing.assert_allclose(b.predict(W), 10.0 * a.predict(W) + 3.0, rtol=1e-5)
    np.testing.assert_allclose(b.predict_variance(W), 100.0 * a.predict_variance(W), rtol=1e-3)


@pytest.mark.parametrize("nugget", ["auto", None, 1e-4])
def test_json_round_trip_is_identical(branin_data, nugget):
    U, V = branin_data
    model = Kriging(trend="linear", kernel="matern52", nugget=nugget).fit(U, V)
    clone = Kriging.from_dict(json.loads(json.dumps(model.to_dict())))
    W = np.vstack([lhs(50, *BRANIN_BOX, seed=11), [[20.0, -3.0]]])
    np.testing.assert_array_equal(clone.predict(W), model.predict(W))
    np.testing.assert_allclose(clone.predict_variance(W), model.predict_variance(W), rtol=1e-9)
    assert clone.get_params() == model.get_params()
    np.testing.assert_array_equal(clone.theta_, model.theta_)
    assert clone.nugget_ == model.nugget_


def test_deterministic(branin_data):
    a = Kriging(kernel="matern52").fit(*branin_data)
    b = Kriging(kernel="matern52").fit(*branin_data)
    np.testing.assert_array_equal(a.theta_, b.theta_)
    assert a.nugget_ == b.nugget_


def test_fixed_nugget_is_kept(branin_data):
    model = Kriging(nugget=1e-3).fit(*branin_data)
    assert model.nugget_ == 1e-3


def test_jitter_grows_tenfold_until_cholesky_succeeds():
    K = np.array([[1.0, 1.0 + 1e-9], [1.0 + 1e-9, 1.0]])  # one eigenvalue −1e-9
    L, nug = _cholesky(K, JITTER)
    assert 1e-9 <= nug <= 1e-8
    assert np.log10(nug / JITTER) == pytest.approx(round(np.log10(nug / JITTER)))
    np.testing.assert_allclose(L @ L.T, K + nug * np.eye(2), atol=1e-14)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"kernel": "foo"}, "kernel"),
        ({"trend": "quadratic"}, "trend"),
        ({"nugget": -1.0}, "nugget"),
        ({"nugget": "big"}, "nugget"),
        ({"nugget": float("nan")}, "nugget"),
    ],
)
def test_bad_arguments(kwargs, field):
    with pytest.raises(ValueError, match=field):
        Kriging(**kwargs).fit(np.linspace(0, 1, 8)[:, None], np.linspace(0, 1, 8) ** 2)


def test_bad_data():
    with pytest.raises(ValueError, match="more than 3"):
        Kriging(trend="linear").fit([[0.0, 0.0], [1.0, 1.0], [0.0, 1.0]], [1.0, 2.0, 3.0])
    model = Kriging().fit(np.linspace(0, 1, 8)[:, None], np.linspace(0, 1, 8) ** 2)
    with pytest.raises(ValueError, match="columns"):
        model.predict_variance(np.zeros((2, 3)))
    with pytest.raises(RuntimeError, match="not fitted"):
        Kriging().predict_variance([[0.0]])


def test_auto_nugget_keeps_interpolating_accuracy_on_noise_free_data():
    # smooth noise-free 2-D suspension-like force: the old nugget floor (1e-8) cost ~20x
    def force(U: np.ndarray) -> np.ndarray:
        u1, u2 = U[:, 0], U[:, 1]
        return 4e5 * u1 + 2.2e8 * u1**3 + 9e3 * np.tanh(u2 / 0.3) + 1e6 * u1 * u2

    rng = np.random.default_rng(5)
    U = rng.uniform([-0.03, -0.3], [0.03, 0.3], (100, 2))
    Q = rng.uniform(U.min(axis=0), U.max(axis=0), (300, 2))
    errors = {}
    for nugget in ("auto", None, 1e-8):
        model = Kriging(nugget=nugget, n_starts=2).fit(U, force(U))
        errors[nugget] = rel_rms(model.predict(Q), force(Q))
        if nugget == "auto":
            assert model.nugget_ < 1e-10
    assert errors["auto"] <= 1.2 * errors[None]
    assert errors["auto"] < 0.1 * errors[1e-8]
