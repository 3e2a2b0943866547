"""Tests of the Legendre polynomial regression (paper eq. 5–7) and its numba kernels."""

from __future__ import annotations

import json

import numpy as np
import pytest
from numba import njit
from numpy.polynomial import legendre as npleg

import surrogates
from surrogates.models import model_class
from surrogates.models.checks import UnderdeterminedFitWarning
from surrogates.models.lpr import (
    LegendreRegression,
    additive_table,
    lpr_additive_inside,
    lpr_eval,
    lpr_eval_batch,
    lpr_eval_into,
    lpr_is_outside,
    lpr_scratch,
)

LOWER = np.array([-0.05, -0.3])  # e.g. relative displacement (m), relative velocity (m/s)
UPPER = np.array([0.08, 0.4])


def additive_poly(U: np.ndarray) -> np.ndarray:
    """Exact additive polynomial: cubic in u1, quartic in u2 (output in N)."""
    u1, u2 = U[:, 0], U[:, 1]
    return 1.2e3 + 4.0e5 * u1 - 2.0e8 * u1**3 + 3.0e3 * u2 - 5.0e4 * u2**2 + 8.0e4 * u2**4


def additive_poly_grad(U: np.ndarray) -> np.ndarray:
    u1, u2 = U[:, 0], U[:, 1]
    return np.column_stack([4.0e5 - 6.0e8 * u1**2, 3.0e3 - 1.0e5 * u2 + 3.2e5 * u2**3])


def box_samples(n: int, seed: int) -> np.ndarray:
    """``n`` random points in the box; the first four are its corners, so that the training
    box of a model fitted on them is exactly ``[LOWER, UPPER]``."""
    rng = np.random.default_rng(seed)
    corners = np.array([[0.0, 0.0], [0.0, 1.0], [1.0, 0.0], [1.0, 1.0]])
    return LOWER + (UPPER - LOWER) * np.vstack([corners, rng.random((n - 4, 2))])


@pytest.fixture(scope="module")
def fitted() -> LegendreRegression:
    U = box_samples(60, seed=1)
    return LegendreRegression(degree=(3, 4)).fit(U, additive_poly(U))


def outside_points(seed: int) -> np.ndarray:
    """Points inside, beyond one face, and beyond corners of the box."""
    rng = np.random.default_rng(seed)
    width = UPPER - LOWER
    return LOWER + width * rng.uniform(-0.6, 1.6, size=(40, 2))


def test_public_names() -> None:
    assert surrogates.LegendreRegression is LegendreRegression
    assert model_class("lpr") is LegendreRegression
    assert LegendreRegression.kind == "lpr"


def test_recovers_exact_additive_polynomial(fitted: LegendreRegression) -> None:
    assert fitted.n_terms_ == 1 + 3 + 4  # one shared constant column
    assert fitted.exponents_.shape == (8, 2)
    assert fitted.exponents_.dtype.kind == "i"
    assert fitted.exponents_.sum(axis=1).max() == 4
    Ut = box_samples(200, seed=2)
    Vt = additive_poly(Ut)
    err = np.max(np.abs(fitted.predict(Ut) - Vt)) / np.max(np.abs(Vt))
    assert err < 1e-10
    assert 1.0 <= fitted.cond_ < 20.0


def test_equals_numpy_legendre_fit_1d() -> None:
    rng = np.random.default_rng(3)
    x = np.sort(rng.uniform(0.0, 0.12, 80))  # m
    y = 5e4 * np.tanh(40.0 * x) + 300.0 * rng.standard_normal(80)  # noisy data, N
    for deg in (1, 4, 9):
        model = LegendreRegression(degree=deg).fit(x[:, None], y)
        ref = npleg.Legendre.fit(x, y, deg)
        xt = np.linspace(x.min(), x.max(), 101)
        np.testing.assert_allclose(model.predict(xt[:, None]), ref(xt), rtol=0, atol=1e-10 * 5e4)
        # coefficients in the mapped variable t are the Legendre-series coefficients
        np.testing.assert_allclose(model.coef_, ref.coef, rtol=0, atol=1e-10 * 5e4)


def test_degree_20_well_conditioned_unlike_monomials() -> None:
    x = np.linspace(0.0, 3.0, 201)
    y = np.exp(x)
    model = LegendreRegression(degree=20).fit(x[:, None], y)
    xt = np.random.default_rng(4).uniform(0.0, 3.0, 500)
    rel_err = np.max(np.abs(model.predict(xt[:, None]) - np.exp(xt))) / np.exp(3.0)
    assert rel_err < 1e-12
    assert model.cond_ < 10.0
    cond_monomial = np.linalg.cond(np.vander(x, 21))
    assert cond_monomial > 1e8 * model.cond_
    # a Runge-type force law still converges geometrically (rate ≈ 1/(0.2 + √1.04) per degree)
    xr = np.linspace(-1.0, 1.0, 401)
    yr = 1.0 / (1.0 + 25.0 * xr**2)
    errs = [
        np.max(np.abs(LegendreRegression(degree=n).fit(xr[:, None], yr).predict(xr[:, None]) - yr))
        for n in (10, 20)
    ]
    assert errs[1] < 0.15 * errs[0]
    assert errs[1] < 0.05


def test_interactions_recover_product_additive_cannot() -> None:
    g = np.linspace(-1.0, 1.0, 11)
    U = np.array([(a, b) for a in g for b in g]) * [0.02, 0.5] + [0.01, 0.0]
    V = (U[:, 0] - 0.01) * U[:, 1] * 1e4  # a bilinear (friction-like) law
    full = LegendreRegression(degree=2, interactions=True).fit(U, V)
    assert full.n_terms_ == 6
    Ut = U[::7] * 0.9 + [0.001, 0.0]
    Vt = (Ut[:, 0] - 0.01) * Ut[:, 1] * 1e4
    assert np.max(np.abs(full.predict(Ut) - Vt)) < 1e-10 * np.max(np.abs(V))
    # on a symmetric grid u1·u2 is orthogonal to every additive function: the fit is zero
    add = LegendreRegression(degree=5).fit(U, V)
    assert np.max(np.abs(add.predict(U))) < 1e-10 * np.max(np.abs(V))
    rms_res = np.sqrt(np.mean((add.predict(U) - V) ** 2))
    assert rms_res == pytest.approx(np.sqrt(np.mean(V**2)), rel=1e-10)


def test_interactions_exponents_total_degree() -> None:
    U = np.random.default_rng(5).random((40, 3))
    model = LegendreRegression(degree=3, interactions=True).fit(U, U.sum(axis=1))
    E = model.exponents_
    assert E.shape == (20, 3)  # C(3 + 3, 3)
    assert len({tuple(e) for e in E}) == 20
    assert E.sum(axis=1).max() == 3
    assert np.all(E[0] == 0)


def test_analytic_gradient(fitted: LegendreRegression) -> None:
    U = box_samples(30, seed=6) * 0.9 + 0.05 * (LOWER + UPPER)
    G = fitted._gradient_inside(U)
    np.testing.assert_allclose(G, additive_poly_grad(U), rtol=1e-8, atol=1e-6)
    h = 1e-6 * (UPPER - LOWER)
    for j in range(2):
        e = np.zeros(2)
        e[j] = h[j]
        fd = (fitted.predict(U + e) - fitted.predict(U - e)) / (2 * h[j])
        np.testing.assert_allclose(G[:, j], fd, rtol=1e-6)
    # with interactions as well
    Ui = box_samples(80, seed=7)
    Vi = np.sin(20 * Ui[:, 0]) * np.cos(3 * Ui[:, 1])
    mi = LegendreRegression(degree=6, interactions=True).fit(Ui, Vi)
    Gi = mi._gradient_inside(U)
    for j in range(2):
        e = np.zeros(2)
        e[j] = h[j]
        fd = (mi.predict(U + e) - mi.predict(U - e)) / (2 * h[j])
        np.testing.assert_allclose(Gi[:, j], fd, rtol=1e-6, atol=1e-8 * np.abs(Gi).max())


@pytest.mark.parametrize("interactions", [False, True])
def test_numba_kernels_match_predict(interactions: bool) -> None:
    U = box_samples(70, seed=8)
    V = np.sin(15 * U[:, 0]) + U[:, 1] ** 3 + (U[:, 0] * U[:, 1] if interactions else 0.0)
    model = LegendreRegression(degree=5, interactions=interactions).fit(U, V)
    E, c, lo, hi, mode = model.kernel_arrays()
    assert E.dtype == np.int64 and E.shape == (model.n_terms_, 2)
    assert c.dtype == np.float64 and lo.dtype == np.float64 and hi.dtype == np.float64
    assert mode == 0
    Uq = outside_points(seed=9)
    ref = model.predict(Uq)
    np.testing.assert_allclose(lpr_eval_batch(Uq, E, c, lo, hi, mode), ref, rtol=0, atol=1e-10)
    for u, r in zip(Uq, ref, strict=True):
        assert abs(lpr_eval(u, E, c, lo, hi, mode) - r) < 1e-10
        assert lpr_is_outside(u, lo, hi) == bool(np.any((u < lo) | (u > hi)))
    # mode 2 ("raise"): lpr_eval_into extends linearly (its callers check), the others raise
    work = lpr_scratch(E, lo, hi)
    for u, r in zip(Uq, ref, strict=True):
        assert abs(lpr_eval_into(u, E, c, lo, hi, 2, work) - r) < 1e-10
    outside = np.array([lpr_is_outside(u, lo, hi) for u in Uq])
    assert outside.any()
    with pytest.raises(ValueError, match="extrapolation='raise'"):
        lpr_eval_batch(Uq, E, c, lo, hi, 2)
    with pytest.raises(ValueError, match="extrapolation='raise'"):
        lpr_eval(Uq[outside][0], E, c, lo, hi, 2)
    np.testing.assert_allclose(
        lpr_eval_batch(Uq[~outside], E, c, lo, hi, 2), ref[~outside], rtol=0, atol=1e-10
    )
    # clip policy
    clip = LegendreRegression(degree=5, interactions=interactions, extrapolation="clip").fit(U, V)
    E, c, lo, hi, mode = clip.kernel_arrays()
    assert mode == 1
    np.testing.assert_allclose(
        lpr_eval_batch(Uq, E, c, lo, hi, mode), clip.predict(Uq), rtol=0, atol=1e-10
    )


@pytest.mark.parametrize(
    ("d", "params"),
    [
        (1, {"degree": 7}),
        (1, {"degree": 0}),
        (2, {"degree": 0}),
        (2, {"degree": (2, 9)}),
        (3, {"degree": 4, "interactions": True}),
        (3, {"degree": (3, 1, 5), "extrapolation": "clip"}),
        (3, {"degree": (3, 1, 5)}),
        (4, {"degree": (2, 3, 1, 2)}),
    ],
)
def test_eval_into_reuses_one_work_array(d: int, params: dict) -> None:
    """One work array serves every point, equals lpr_eval exactly and predict to rounding."""
    rng = np.random.default_rng(20 + d)
    lo, hi = -np.linspace(0.1, 0.3, d), np.linspace(0.2, 0.5, d)
    U = lo + (hi - lo) * rng.random((120, d))
    V = np.sin(4 * U).sum(axis=1) + U.prod(axis=1) * 3.0
    model = LegendreRegression(**params).fit(U, V)
    E, c, lo, hi, mode = model.kernel_arrays()
    work = lpr_scratch(E, lo, hi)
    assert work.shape == (d + 4, max(int(E.max()) + 1, d, 2))
    Uq = lo + (hi - lo) * rng.uniform(-0.5, 1.5, (60, d))
    ref = model.predict(Uq)
    got = np.array([lpr_eval_into(u, E, c, lo, hi, mode, work) for u in Uq])
    np.testing.assert_array_equal(got, [lpr_eval(u, E, c, lo, hi, mode) for u in Uq])
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12 * np.abs(ref).max())
    with pytest.raises(ValueError, match="work must come from lpr_scratch"):
        lpr_eval_into(Uq[0], E, c, lo, hi, mode, np.zeros((d + 3, work.shape[1])))


@njit
def _eval_many(n, u, E, c, lo, hi, mode, work):
    s = 0.0
    for _ in range(n):
        s += lpr_eval_into(u, E, c, lo, hi, mode, work)
    return s


@njit
def _eval_many_allocating(n, u, E, c, lo, hi, mode):
    s = 0.0
    for _ in range(n):
        s += lpr_eval(u, E, c, lo, hi, mode)
    return s


def test_eval_into_does_not_allocate(fitted: LegendreRegression) -> None:
    nrt = pytest.importorskip("numba.core.runtime._nrt_python")
    if not hasattr(nrt, "memsys_enable_stats"):
        pytest.skip("this numba cannot count NRT allocations")
    from numba.core.runtime import rtsys

    E, c, lo, hi, mode = fitted.kernel_arrays()
    work = lpr_scratch(E, lo, hi)
    u = np.array([0.1, 0.5])  # outside in u2: the gradient path runs too
    args = (u, E, c, lo, hi, mode)

    def allocations(fn, *extra):
        nrt.memsys_enable_stats()
        try:
            before = rtsys.get_allocation_stats().alloc
            fn(*extra)
            return rtsys.get_allocation_stats().alloc - before
        finally:
            nrt.memsys_disable_stats()

    _eval_many(1, *args, work)
    _eval_many_allocating(1, *args)
    assert allocations(_eval_many, 1, *args, work) == allocations(_eval_many, 500, *args, work)
    assert allocations(_eval_many_allocating, 500, *args) >= 500
    assert _eval_many(3, *args, work) == 3 * lpr_eval(*args)


def test_extrapolation_policies() -> None:
    U = box_samples(40, seed=10)
    V = 2.0e4 * U[:, 0] - 3.0e3 * U[:, 1] + 50.0  # linear spring + damper law
    far = np.array([[1e3, -1e3], [-0.2, 0.1], [0.0, 5.0], [0.01, 0.0]])
    exact = 2.0e4 * far[:, 0] - 3.0e3 * far[:, 1] + 50.0

    lin = LegendreRegression(degree=4).fit(U, V)
    np.testing.assert_allclose(lin.predict(far), exact, rtol=1e-10)
    assert lin.n_out_of_domain_ == 3
    lin.predict(far[:2])
    assert lin.n_out_of_domain_ == 5

    Vn = np.exp(10 * U[:, 0]) * (1 + U[:, 1] ** 2)
    for policy in ("linear", "clip"):
        m = LegendreRegression(degree=(6, 3), extrapolation=policy).fit(U, Vn)
        assert np.all(np.isfinite(m.predict(far * 1e6)))
    clip = LegendreRegression(degree=(6, 3), extrapolation="clip").fit(U, Vn)
    np.testing.assert_array_equal(
        clip.predict(far), clip.predict(np.clip(far, clip.lower_, clip.upper_))
    )

    strict = LegendreRegression(degree=3, extrapolation="raise").fit(U, V)
    np.testing.assert_allclose(strict.predict(U), V, rtol=1e-10)
    with pytest.raises(ValueError, match="outside the training domain"):
        strict.predict(far)


@pytest.mark.parametrize(
    "params", [{"degree": (3, 4)}, {"degree": 4, "interactions": True, "extrapolation": "clip"}]
)
def test_to_dict_round_trip(params: dict) -> None:
    U = box_samples(50, seed=11)
    V = np.cos(30 * U[:, 0]) * U[:, 1] + U[:, 1] ** 2
    model = LegendreRegression(**params).fit(U, V)
    clone = LegendreRegression.from_dict(json.loads(json.dumps(model.to_dict())))
    assert clone.get_params() == model.get_params()
    Uq = outside_points(seed=12)
    np.testing.assert_array_equal(clone.predict(Uq), model.predict(Uq))
    np.testing.assert_array_equal(clone.exponents_, model.exponents_)
    assert clone.cond_ == model.cond_
    assert clone.n_terms_ == model.n_terms_
    for a, b in zip(clone.kernel_arrays(), model.kernel_arrays(), strict=True):
        np.testing.assert_array_equal(a, b)


def test_bad_input() -> None:
    U = box_samples(7, seed=13)
    V = U.sum(axis=1)
    with pytest.warns(UnderdeterminedFitWarning, match="needs at least 9"):
        LegendreRegression(degree=4).fit(U, V)  # under-determined: minimum norm, a warning
    with pytest.raises(ValueError, match="degree"):
        LegendreRegression(degree=-1).fit(U, V)
    with pytest.raises(ValueError, match="degree"):
        LegendreRegression(degree=2.5).fit(U, V)
    with pytest.raises(ValueError, match="interactions"):
        LegendreRegression(degree=(2, 3), interactions=True).fit(U, V)
    with pytest.raises(ValueError, match="degree has 3 entries"):
        LegendreRegression(degree=(1, 2, 3)).fit(U, V)
    x = np.repeat([0.0, 1.0, 2.0], 5)  # 3 distinct values cannot carry degree 4
    with pytest.raises(ValueError, match="rank"):
        LegendreRegression(degree=4).fit(x[:, None], x**2)
    with pytest.raises(ValueError, match="exponents"):
        state = LegendreRegression(degree=2).fit(U, V).to_dict()
        state["state"]["exponents"] = state["state"]["exponents"][:-1]
        LegendreRegression.from_dict(state)
    with pytest.raises(RuntimeError, match="not fitted"):
        LegendreRegression().kernel_arrays()


@pytest.mark.parametrize("degree", [(4,), (2, 9), (14, 14, 9), (3, 0, 5), (2, 3, 1, 2)])
def test_additive_fast_path_equals_predict_inside_the_box(degree) -> None:
    """The vehicle kernels' additive path (coefficient table summed along the recurrence)."""
    d = len(degree)
    rng = np.random.default_rng(d)
    lo, hi = -np.linspace(0.1, 0.3, d), np.linspace(0.2, 0.5, d)
    U = lo + (hi - lo) * rng.random((400, d))
    V = np.sin(4 * U).sum(axis=1) + np.exp(U[:, 0])
    model = LegendreRegression(degree=degree).fit(U, V)
    E, c, lo, hi, _ = model.kernel_arrays()
    table = additive_table(E, c)
    work = lpr_scratch(E, lo, hi)
    Uq = lo + (hi - lo) * rng.random((100, d))
    got = np.array([lpr_additive_inside(u, table, lo, work) for u in Uq])
    np.testing.assert_allclose(got, model.predict(Uq), rtol=0, atol=1e-12 * np.abs(V).max())
    if d >= 2:
        coupled = LegendreRegression(degree=3, interactions=True).fit(U[:, :2], V)
        assert additive_table(*coupled.kernel_arrays()[:2]) is None


def _additive_full_width(u, table, lower, work) -> float:
    """Every input's recurrence to the table width (its zero terms too), in the order of the
    kernel's two- and three-input paths."""
    d, n = table.shape
    s = [table[0, 0]] + [0.0] * (d - 1)
    for j in range(1, d):
        s[0] = s[0] + table[j, 0]
    t = [(u[j] - lower[j]) * work[d + 3, j] - 1.0 for j in range(d)]
    for j in range(d):
        s[j] += table[j, 1] * t[j]
        a, b = 1.0, t[j]
        for k in range(1, n - 1):
            nx = work[d + 1, k] * t[j] * b - work[d + 2, k] * a
            s[j] += table[j, k + 1] * nx
            a, b = b, nx
    total = s[0]
    for j in range(1, d):
        total = total + s[j]
    return total


@pytest.mark.parametrize("degree", [(14, 14, 20), (20, 3, 9), (2, 9), (9, 1)])
def test_additive_fast_path_stops_at_each_degree_with_the_same_bits(degree) -> None:
    """Stopping each input's recurrence at its own degree drops only exact zero terms: the
    same bits as summing to the table width, also where the sum is zero or -0.0."""
    d = len(degree)
    rng = np.random.default_rng(11)
    lo, hi = -np.linspace(0.1, 0.3, d), np.linspace(0.2, 0.5, d)
    U = lo + (hi - lo) * rng.random((500, d))
    model = LegendreRegression(degree=degree).fit(U, np.cos(5 * U).sum(axis=1))
    E, c, lo, hi, _ = model.kernel_arrays()
    table = additive_table(E, c)
    assert table.shape[1] == max(degree) + 1
    work = lpr_scratch(E, lo, hi)
    Uq = np.vstack([lo + (hi - lo) * rng.random((300, d)), lo, hi, 0.5 * (lo + hi)])
    got = np.array([lpr_additive_inside(u, table, lo, work) for u in Uq])
    want = np.array([_additive_full_width(u, table, lo, work) for u in Uq])
    assert got.tobytes() == want.tobytes()
    zero = np.zeros_like(table)
    zero[0, 0] = -0.0
    assert np.signbit(lpr_additive_inside(Uq[0], zero, lo, work)) == np.signbit(
        _additive_full_width(Uq[0], zero, lo, work)
    )
