"""The Hermite tables of an additive LPR element (:mod:`surrogates.models.lpr_grid`) against
the plain polynomial: within ``GRID_RTOL`` of the output range inside the box, and the
kernels' element force outside the box unchanged (the polynomial and its extension)."""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit

from railgym.vehicles.collect import default_vertical_surrogate
from railgym.vehicles.vertical.elements import rhs
from railgym.vehicles.vertical.kernels import surrogate_arrays
from railgym.vehicles.vertical.params import load_vehicle
from surrogates.models.lpr import (
    LegendreRegression,
    additive_table,
    lpr_eval_batch,
    lpr_scratch,
)
from surrogates.models.lpr_grid import GRID_MAX, GRID_RTOL, lpr_grid, lpr_grid_inside

P = load_vehicle("manchester").kernel_params().record()[0]
ELEMENTS = {
    "maxwell": default_vertical_surrogate("maxwell"),
    "maxwell-v0": default_vertical_surrogate("maxwell", "v0"),
    "static": default_vertical_surrogate("static"),
}


@njit(cache=True)
def _grid_batch(U, coef, lo, scale, top):
    out = np.empty(U.shape[0])
    for r in range(U.shape[0]):
        out[r] = lpr_grid_inside(U[r], coef, lo, scale, top)
    return out


@njit(cache=True)
def _rhs_forces(U, lpr, p):
    """Element force of the scalar right-hand side at each row ``U`` (n, 2) of (δ, δ̇)."""
    out = np.empty(U.shape[0])
    x = np.zeros(5)
    dx = np.zeros(5)
    u = np.empty(lpr.lo.shape[0])
    lw = lpr_scratch(lpr.exps, lpr.lo, lpr.up)
    for r in range(U.shape[0]):
        x[0], x[1] = U[r, 0], U[r, 1]
        out[r], _ = rhs(3, x, 0.0, 0.0, 0.0, p, lpr, u, lw, dx)
    return out


def _box_points(lo: np.ndarray, up: np.ndarray, n: int, seed: int, pad: float) -> np.ndarray:
    """``n`` random points in the box widened by ``pad`` box widths on each side, plus its
    corners."""
    rng = np.random.default_rng(seed)
    w = up - lo
    U = rng.uniform(lo - pad * w, up + pad * w, (n, lo.size))
    corners = np.array(np.meshgrid(*zip(lo, up, strict=True))).reshape(lo.size, -1).T
    return np.vstack([U, corners])


def _output_range(table: np.ndarray) -> float:
    t = np.linspace(-1.0, 1.0, 200_001)
    return sum(float(np.ptp(np.polynomial.legendre.legval(t, c))) for c in table)


@pytest.mark.parametrize("name", list(ELEMENTS))
def test_tables_stay_within_the_tolerance_of_the_polynomial_inside_the_box(name):
    lpr = surrogate_arrays(ELEMENTS[name], grid=True)
    exps, coef, lo, up, mode = ELEMENTS[name].kernel_arrays()
    U = _box_points(lo, up, 200_000, seed=1, pad=0.0)
    exact = lpr_eval_batch(U, exps, coef, lo, up, mode)
    fast = _grid_batch(U, lpr.grid, lpr.lo, lpr.grid_scale, lpr.grid_top)
    bound = GRID_RTOL * _output_range(additive_table(exps, coef))
    err = np.abs(fast - exact).max()
    assert err <= bound
    assert err > 0.0  # the tables really are evaluated
    g = lpr_grid(additive_table(exps, coef), lo, up)
    np.testing.assert_allclose(g.bound, bound, rtol=1e-3)
    assert g.error <= g.bound


@pytest.mark.parametrize("name", ["maxwell", "static"])
def test_kernel_force_outside_the_box_is_the_polynomial_bit_for_bit(name):
    """Points of a static element's (δ, δ̇) plane (the memory element's third input is δ
    there, s = 0): outside its box the gridded force equals the plain one exactly; inside it
    stays within the tolerance."""
    plain = surrogate_arrays(ELEMENTS[name])
    grid = surrogate_arrays(ELEMENTS[name], grid=True)
    U = _box_points(plain.lo[:2], plain.up[:2], 20_000, seed=2, pad=0.5)
    a, b = _rhs_forces(U, plain, P), _rhs_forces(U, grid, P)
    inside = np.ones(len(U), bool)
    for j in range(plain.lo.size):
        col = U[:, 0] if j == 2 else U[:, j]
        inside &= (col >= plain.lo[j]) & (col <= plain.up[j])
    assert (~inside).sum() > 1000 and inside.sum() > 100
    np.testing.assert_array_equal(a[~inside], b[~inside])
    bound = GRID_RTOL * _output_range(plain.table)
    assert np.abs(a[inside] - b[inside]).max() <= bound


def test_tables_of_a_fitted_additive_model_and_a_tolerance_out_of_reach():
    rng = np.random.default_rng(3)
    U = rng.uniform([-0.05, -0.3], [0.08, 0.4], (4000, 2))
    V = 1e4 * np.sin(40.0 * U[:, 0]) + 3e3 * np.tanh(8.0 * U[:, 1])
    model = LegendreRegression(degree=(12, 9)).fit(U, V)
    exps, coef, lo, up, mode = model.kernel_arrays()
    table = additive_table(exps, coef)
    g = lpr_grid(table, lo, up, rtol=1e-8)
    X = _box_points(lo, up, 50_000, seed=4, pad=0.0)
    err = np.abs(_grid_batch(X, g.coef, lo, g.scale, g.top) - model.predict(X)).max()
    assert err <= 1e-8 * _output_range(table) * (1.0 + 1e-9)
    with pytest.raises(ValueError, match=f"{GRID_MAX} grid intervals"):
        lpr_grid(table, lo, up, rtol=1e-17)


def test_only_an_additive_element_is_gridded():
    """``grid=True`` on a model with coupled terms keeps the polynomial (no tables)."""
    rng = np.random.default_rng(5)
    U = rng.uniform(-1.0, 1.0, (500, 2))
    model = LegendreRegression(degree=3, interactions=True).fit(U, U[:, 0] * U[:, 1])
    lpr = surrogate_arrays(model, grid=True)
    assert not lpr.additive and not lpr.gridded
