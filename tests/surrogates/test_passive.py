"""Tests of the passive (monotone) Legendre regression and the passivity check."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize

from surrogates.models.lpr import LegendreRegression
from surrogates.passive import PassiveLegendreRegression, passivity_check

LOWER = np.array([-0.05, -0.5])  # deflection (m), deflection rate (m/s)
UPPER = np.array([0.04, 0.6])


def monotone_data(seed: int, n: int = 400, noise: float = 0.05) -> tuple[np.ndarray, np.ndarray]:
    """Random non-decreasing additive function of two inputs plus noise (N).

    Each component is a random positive combination of shifted tanh steps and a linear term,
    so its slope is non-negative everywhere; the noise makes the unconstrained fit wiggle.
    """
    rng = np.random.default_rng(seed)
    U = rng.uniform(LOWER, UPPER, (n, 2))
    V = np.zeros(n)
    for j in range(2):
        x = (U[:, j] - LOWER[j]) / (UPPER[j] - LOWER[j])
        w = rng.uniform(0.0, 1.0, 4)
        centres = rng.uniform(0.0, 1.0, 4)
        sharp = rng.uniform(2.0, 30.0, 4)
        V += 1e4 * (
            rng.uniform(0.0, 0.3) * x + w @ np.tanh(sharp[:, None] * (x - centres[:, None]))
        )
    scale = np.std(V)
    return U, V + noise * scale * rng.standard_normal(n)


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    deg=st.tuples(st.integers(2, 14), st.integers(2, 14)),
    extrapolation=st.sampled_from(["linear", "clip"]),
)
def test_constrained_fit_has_no_negative_slope_inside_or_outside(seed, deg, extrapolation):
    U, V = monotone_data(seed)
    model = PassiveLegendreRegression(degree=deg, extrapolation=extrapolation).fit(U, V)
    check = passivity_check(model, scale=3.0, n=121)
    slopes = check["slopes"]
    tol = 1e-6 * np.max(np.abs(slopes), axis=0)  # central-difference round-off
    assert np.all(check["min_slope"] >= -tol), check["min_slope"]
    # the fitted verification grid agrees: analytic slopes are non-negative
    assert np.all(model.min_slope_ >= -1e-9 * np.max(np.abs(slopes), axis=0))
    # outside the box the points exist and are checked too
    outside = np.any((check["points"] < model.lower_) | (check["points"] > model.upper_), axis=1)
    assert outside.mean() > 0.8


def test_unconstrained_fit_of_the_same_data_goes_negative():
    """The property above is not vacuous: noisy monotone data give negative slopes."""
    U, V = monotone_data(3, noise=0.2)
    free = LegendreRegression(degree=(14, 14)).fit(U, V)
    assert np.any(passivity_check(free, scale=3.0, n=121)["min_slope"] < 0)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_error_close_to_unconstrained_on_passive_data(seed):
    U, V = monotone_data(seed, n=600)
    Ut, Vt = monotone_data(seed + 100, n=2000, noise=0.0)
    free = LegendreRegression(degree=(10, 10)).fit(U, V)
    passive = PassiveLegendreRegression(degree=(10, 10)).fit(U, V)
    inside = np.all((Ut >= free.lower_) & (Ut <= free.upper_), axis=1)
    e_free = np.sqrt(np.mean((free.predict(Ut[inside]) - Vt[inside]) ** 2))
    e_pass = np.sqrt(np.mean((passive.predict(Ut[inside]) - Vt[inside]) ** 2))
    assert e_pass <= 1.05 * e_free
    # training residual: the constrained optimum cannot beat the unconstrained one
    r_free = np.sum((free.predict(U) - V) ** 2)
    r_pass = np.sum((passive.predict(U) - V) ** 2)
    assert r_free <= r_pass * (1 + 1e-12)


def test_feasible_least_squares_solution_is_returned_unchanged():
    """Noise-free data from a monotone polynomial in the span: both fits are exact."""
    rng = np.random.default_rng(5)
    U = rng.uniform(LOWER, UPPER, (300, 2))
    V = 2e5 * U[:, 0] + 1e7 * U[:, 0] ** 3 + 3e4 * U[:, 1] + 5e3 * U[:, 1] ** 3
    free = LegendreRegression(degree=(3, 3)).fit(U, V)
    passive = PassiveLegendreRegression(degree=(3, 3)).fit(U, V)
    np.testing.assert_allclose(passive.coef_, free.coef_, rtol=1e-9, atol=1e-6)


def test_matches_an_independent_qp_solver():
    """The NNLS least-distance solution equals SLSQP on the same grid constraints."""
    U, V = monotone_data(7, n=200, noise=0.3)
    deg = (6, 6)
    model = PassiveLegendreRegression(degree=deg, grid_size=41).fit(U, V)
    free = LegendreRegression(degree=deg).fit(U, V)
    E = free.exponents_
    t = free._map(U)
    A = np.column_stack(
        [
            np.polynomial.legendre.legval(t[:, 0], np.eye(7)[e[0]])
            * np.polynomial.legendre.legval(t[:, 1], np.eye(7)[e[1]])
            for e in E
        ]
    )
    grid = -np.cos(np.pi * np.arange(41) / 40)
    G = np.zeros((82, E.shape[0]))
    for i, e in enumerate(E):
        for j in range(2):
            if e[j] > 0 and e[1 - j] == 0:
                G[41 * j : 41 * (j + 1), i] = np.polynomial.legendre.legval(
                    grid, np.polynomial.legendre.legder(np.eye(7)[e[j]])
                )
    s = np.linalg.norm(A, axis=0)
    B, y = A / s, V / np.std(V)  # well-scaled problem for SLSQP
    res = minimize(
        lambda c: np.sum((B @ c - y) ** 2),
        np.zeros(E.shape[0]),
        jac=lambda c: 2 * B.T @ (B @ c - y),
        constraints=[{"type": "ineq", "fun": lambda c: G / s @ c, "jac": lambda c: G / s}],
        method="SLSQP",
        options={"ftol": 1e-12, "maxiter": 1000},
    )
    assert res.success, res.message
    assert np.min(G / s @ res.x) > -1e-8
    r_qp = np.sum((B @ res.x - y) ** 2)
    r_ours = np.sum((model.predict(U) / np.std(V) - y) ** 2)
    assert r_ours == pytest.approx(r_qp, rel=1e-4)
    assert r_ours > 1.001 * np.sum((free.predict(U) / np.std(V) - y) ** 2)  # constraints bind
    np.testing.assert_allclose(model.predict(U) / np.std(V), B @ res.x, atol=5e-3)


def test_partial_monotone_leaves_other_inputs_free():
    U, V = monotone_data(2, noise=0.0)
    V = V - 4e4 * U[:, 1] ** 2  # not monotone in the second input
    model = PassiveLegendreRegression(degree=(6, 6), monotone=(True, False)).fit(U, V)
    assert model.min_slope_[0] >= -1e-9 * abs(model.min_slope_[0]) - 1e-6
    assert np.isnan(model.min_slope_[1])
    check = passivity_check(model, scale=1.0, n=101)
    assert check["min_slope"][1] < 0  # the quadratic is kept


def test_scikit_learn_contract_and_round_trip():
    params = {"degree": (5, 7), "extrapolation": "clip", "grid_size": 51, "monotone": True}
    model = PassiveLegendreRegression(**params)
    assert model.get_params() == params
    bad = PassiveLegendreRegression(degree=-1)  # stored as given, rejected in fit
    U, V = monotone_data(0)
    with pytest.raises(ValueError, match="degree"):
        bad.fit(U, V)
    with pytest.raises(ValueError, match="grid_size"):
        PassiveLegendreRegression(grid_size=1).fit(U, V)
    with pytest.raises(ValueError, match="monotone"):
        PassiveLegendreRegression(monotone=(True,)).fit(U, V)
    model.fit(U, V)
    again = PassiveLegendreRegression.from_dict(model.to_dict())
    np.testing.assert_array_equal(again.predict(U * 2), model.predict(U * 2))


def test_passivity_check_finds_the_negative_slope_of_a_known_model():
    """Linear extrapolation of F = −(δ − δ0)² beyond the box continues the boundary slope."""
    g0, g1 = np.meshgrid(np.linspace(0.0, 1.0, 11), np.linspace(-1.0, 1.0, 5))
    U = np.column_stack([g0.ravel(), g1.ravel()])
    V = -(U[:, 0] ** 2) + U[:, 1]
    model = LegendreRegression(degree=(2, 1)).fit(U, V)
    check = passivity_check(model, scale=3.0, n=61)
    assert check["min_slope"][0] == pytest.approx(-2.0, rel=1e-5)  # slope at δ = 1
    assert check["argmin"][0][0] >= 1.0
    assert check["min_slope"][1] == pytest.approx(1.0, rel=1e-6)
    with pytest.raises(ValueError, match="scale"):
        passivity_check(model, scale=0.0)
