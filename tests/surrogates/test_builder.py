import numpy as np
import pytest

import surrogates
from surrogates import build


def _suspension_data(n=1001, seed=0):
    """A smooth additive nonlinear force: progressive spring + asymmetric damper (N)."""
    rng = np.random.default_rng(seed)
    du = rng.normal(0, 0.01, n)
    dv = rng.normal(0, 0.08, n)
    F = 8.6e5 * du * (1 + 300 * du**2) + 4e4 * dv + 2e4 * np.tanh(5 * dv)
    return np.column_stack([du, dv]), F


def test_build_lpr_pipeline_report():
    U, V = _suspension_data()
    model, report = build(U, V, kind="lpr", m=101, sampling="greedy", selection="oob", seed=0)
    assert isinstance(model, surrogates.LegendreRegression)
    assert report.m == 101 and report.n == 1001
    assert report.train_idx.size == 101 and report.oob_idx.size == 900
    assert set(report.train_idx).isdisjoint(report.oob_idx)
    # the spring part is an exact cubic: the chosen displacement degree is 3 or more
    assert report.chosen[0] >= 3
    assert report.oob_nrms < 1e-3
    assert report.training_time_s >= report.fit_time_s > 0
    lo, hi = report.domain
    np.testing.assert_allclose(lo, U[report.train_idx].min(axis=0))
    assert "chosen" in report.format() and report.to_dict()["m"] == 101


def test_build_kfold_and_seed_reproducible():
    U, V = _suspension_data(n=400, seed=2)
    m1, r1 = build(U, V, m=81, sampling="random", selection="kfold", seed=5)
    m2, r2 = build(U, V, m=81, sampling="random", selection="kfold", seed=5)
    np.testing.assert_array_equal(r1.train_idx, r2.train_idx)
    assert r1.chosen == r2.chosen
    np.testing.assert_array_equal(m1.predict(U), m2.predict(U))


def test_build_rejects_bad_arguments():
    U, V = _suspension_data(n=50)
    with pytest.raises(ValueError, match="no out-of-bag"):
        build(U, V, m=50)
    with pytest.raises(ValueError, match="selection"):
        build(U, V, m=20, selection="aic")
    with pytest.raises(ValueError, match="V must have shape"):
        build(U, V[:-1], m=20)
