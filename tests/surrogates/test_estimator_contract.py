"""scikit-learn estimator contract of the surrogate models (issue 8 item 7)."""

from __future__ import annotations

import inspect
import json
import re
import warnings
from importlib import resources
from typing import Any

import numpy as np
import pytest
from numpy.polynomial import legendre

from surrogates import Kriging, LegendreRegression, io
from surrogates.models import checks
from surrogates.models.lpr import design_matrix
from surrogates.passive import PassiveLegendreRegression, passivity_check
from surrogates.selection import factory_for, select_kfold, select_oob

sklearn_base = pytest.importorskip("sklearn.base")
estimator_checks = pytest.importorskip("sklearn.utils.estimator_checks")
parametrize_with_checks = estimator_checks.parametrize_with_checks

RNG = np.random.default_rng(2)
U = RNG.uniform(-1.0, 1.0, (30, 2))
V = np.sin(2.0 * U[:, 0]) + U[:, 1] ** 2

CASES = [
    (
        PassiveLegendreRegression,
        {"degree": [3, 3], "extrapolation": "clip", "grid_size": 51, "monotone": [True, False]},
    ),
    (LegendreRegression, {"degree": [3, 2], "interactions": False, "extrapolation": "clip"}),
    (LegendreRegression, {"degree": 4, "interactions": True, "extrapolation": "raise"}),
    (
        Kriging,
        {
            "trend": "linear",
            "kernel": "matern52",
            "nugget": 1e-6,
            "extrapolation": "clip",
            "n_starts": 2,
            "seed": 7,
            "max_samples": 100,
        },
    ),
]


@pytest.mark.parametrize(("cls", "params"), CASES)
def test_init_stores_parameters_as_given(cls, params):
    model = cls(**params)
    got = model.get_params()
    assert set(got) == set(cls.__init__.__code__.co_varnames[1 : len(got) + 1])
    for k, v in params.items():
        assert got[k] is v  # stored exactly, not normalised (a list stays the same list)


def test_init_does_not_validate_fit_does():
    bad = LegendreRegression(degree=-3, extrapolation="cubic")  # no error here
    assert bad.get_params()["degree"] == -3
    with pytest.raises(ValueError, match="extrapolation"):
        bad.fit(U, V)
    with pytest.raises(ValueError, match="kernel"):
        Kriging(kernel="rbf").fit(U, V)


@pytest.mark.parametrize(("cls", "params"), CASES)
def test_sklearn_clone_and_set_params(cls, params):
    model = cls(**params)
    twin = sklearn_base.clone(model)
    assert twin is not model and type(twin) is cls
    assert twin.get_params() == model.get_params()
    assert twin.set_params(extrapolation="linear") is twin
    assert twin.extrapolation == "linear" and model.extrapolation == params["extrapolation"]
    with pytest.raises(ValueError, match=r"invalid parameter\(s\) \['colour'\]"):
        twin.set_params(colour="red")


@pytest.mark.parametrize(("cls", "params"), CASES)
def test_every_hyperparameter_round_trips_through_json(cls, params):
    model = cls(**params).fit(U, V)
    d = json.loads(json.dumps(model.to_dict()))
    assert set(d["params"]) == set(cls().get_params())
    back = cls.from_dict(d)
    expected = {k: tuple(v) if isinstance(v, list) else v for k, v in params.items()}
    assert {k: back.get_params()[k] for k in params} == expected
    W = U if params["extrapolation"] == "raise" else np.vstack([U, U * 1.3])
    np.testing.assert_array_equal(back.predict(W), model.predict(W))


def test_kriging_seed_and_n_starts_change_the_search_and_are_saved():
    a = Kriging(n_starts=1, seed=0).fit(U, V)
    b = Kriging(n_starts=3, seed=5).fit(U, V)
    # more starts: no worse an optimum, up to the optimizer's stopping tolerance (the starts
    # differ by seed, and where each stops depends on the CPU's rounding)
    assert b.log_likelihood_ >= a.log_likelihood_ - 1e-4 * abs(a.log_likelihood_)
    saved = a.to_dict()["params"]
    assert saved["n_starts"] == 1 and saved["seed"] == 0 and saved["max_samples"] == 1000
    c = Kriging(n_starts=3, seed=5).fit(U, V)
    np.testing.assert_array_equal(c.theta_, b.theta_)  # seeded: reproducible bit for bit


def test_old_files_without_the_new_fields_still_load(tmp_path):
    doc = io.model_to_document(Kriging(n_starts=1).fit(U, V))
    for key in ("n_starts", "seed", "max_samples"):
        del doc["model"]["params"][key]
    path = tmp_path / "old.json"
    path.write_text(json.dumps(doc))
    old = io.load(path)
    assert (old.n_starts, old.seed, old.max_samples) == (4, 0, 1000)
    name = "vertical_lpr_static.json"  # the paper's static element, written before this test
    with resources.as_file(resources.files("railgym") / "data" / name) as p:
        packaged = io.load(p)
    assert packaged.get_params() == {
        "degree": (14, 10),
        "interactions": False,
        "extrapolation": "linear",
    }


# ----------------------------------------------------------------- scikit-learn interplay
#: the estimators as checked, each as constructed by default and each check of
#: ``check_estimator`` run with no exclusion; the checks' data sets have 10-50 samples of up to
#: 10 features, fewer than the 1 + 5·d terms of a default Legendre fit, which then returns the
#: minimum-norm coefficients with a warning (``test_underdetermined_fit_is_minimum_norm``)
CHECKED = [LegendreRegression(), PassiveLegendreRegression(), Kriging()]


with warnings.catch_warnings():  # the models do not inherit from sklearn.base.BaseEstimator
    warnings.filterwarnings("ignore", "Estimator .* does not inherit from `sklearn.base")
    EVERY_CHECK = parametrize_with_checks(CHECKED)


@pytest.mark.filterwarnings("ignore::surrogates.models.checks.UnderdeterminedFitWarning")
@EVERY_CHECK
def test_sklearn_check_estimator(estimator, check):
    check(estimator)


@pytest.mark.filterwarnings("ignore:Estimator .* does not inherit from `sklearn.base")
@pytest.mark.filterwarnings("ignore:Skipping check")
@pytest.mark.filterwarnings("ignore::surrogates.models.checks.UnderdeterminedFitWarning")
@pytest.mark.parametrize("model", CHECKED, ids=lambda m: type(m).__name__)
def test_check_estimator_passes_whole(model):
    results = estimator_checks.check_estimator(model, on_fail=None)
    failed = [(r["check_name"], repr(r["exception"])) for r in results if r["status"] == "failed"]
    assert failed == []
    passed = {r["check_name"] for r in results if r["status"] == "passed"}
    assert sum(r["status"] == "passed" for r in results) >= 50 and len(passed) >= 45
    assert {
        "check_fit1d",
        "check_fit_score_takes_y",
        "check_n_features_in_after_fitting",
        "check_estimators_dtypes",
        "check_estimators_nan_inf",
        "check_regressors_no_decision_function",
        "check_regressors_int",
        "check_estimators_unfitted",
        "check_regressors_train",  # R² > 0.5 on scikit-learn's regression data
    } <= passed
    # what scikit-learn itself skips: the pandas and array-API variants, when pandas or
    # SCIPY_ARRAY_API are missing from the environment
    skipped = {r["check_name"] for r in results if r["status"] == "skipped"}
    assert skipped <= {"check_array_api_input", "check_regressor_data_not_an_array"}


@pytest.mark.parametrize(
    ("cls", "params"),
    [(LegendreRegression, {}), (PassiveLegendreRegression, {"monotone": False})],
)
def test_underdetermined_fit_is_minimum_norm(cls, params):
    """Fewer samples than terms: one UnderdeterminedFitWarning naming both counts, pointing
    at the caller, and the least-squares coefficients of smallest norm (column-scaled), which
    here (full row rank) interpolate the samples; the passive fit without a constraint is the
    ridge limit of it."""
    rng = np.random.default_rng(5)
    X = rng.uniform(-1.0, 1.0, (12, 4))
    y = np.sin(2.0 * X[:, 0]) + X[:, 1] ** 2 - X[:, 2] + 0.3 * X[:, 3]
    model = cls(degree=5, **params)
    with pytest.warns(checks.UnderdeterminedFitWarning) as record:
        model.fit(X, y)
    assert len(record) == 1 and record[0].filename == __file__
    text = str(record[0].message)
    assert re.match(r"X has 12 samples but degree=5 .*needs at least 21 \(one per term\)", text)
    assert model.n_terms_ == 21 and np.isfinite(model.cond_) and model.cond_ >= 1.0
    A = design_matrix(model._map(X), model.exponents_)
    norms = np.linalg.norm(A, axis=0)
    smallest = np.linalg.pinv(A / norms) @ y
    tol = 1e-12 if cls is LegendreRegression else 1e-5  # the passive ridge: RIDGE = 1e-4
    np.testing.assert_allclose(model.coef_ * norms, smallest, rtol=0, atol=tol)
    np.testing.assert_allclose(model.predict(X), y, atol=tol)
    back = cls.from_dict(json.loads(json.dumps(model.to_dict())))
    np.testing.assert_array_equal(back.predict(X), model.predict(X))


def test_underdetermined_passive_fit_keeps_its_slopes_non_negative():
    rng = np.random.default_rng(8)
    X = rng.uniform(-1.0, 1.0, (9, 3))
    y = X[:, 0] ** 3 - 0.5 * X[:, 1] + np.cos(3.0 * X[:, 2])  # decreasing in parts
    with pytest.warns(checks.UnderdeterminedFitWarning, match="needs at least 16"):
        model = PassiveLegendreRegression(degree=5).fit(X, y)
    assert np.all(model.min_slope_ >= 0.0)
    assert np.all(passivity_check(model, scale=1.0, n=41)["min_slope"] >= -1e-9)


def test_underdetermined_candidates_are_still_skipped_by_the_searches():
    """The degree searches skip a candidate with more terms than samples, as when fit
    refused it: its row carries the reason and no score, and no warning escapes."""
    rng = np.random.default_rng(6)
    X = rng.uniform(-1.0, 1.0, (40, 2))
    y = np.sin(2.0 * X[:, 0]) + X[:, 1] ** 2
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        oob = select_oob(factory_for("lpr"), [(2, 2), (20, 20)], X[:30], y[:30], X[30:], y[30:])
        kfold = select_kfold(factory_for("lpr"), [(2, 2), (20, 20)], X, y, k=4)
        passive = select_kfold(
            lambda c: PassiveLegendreRegression(degree=c), [(2, 2), (20, 20)], X, y, k=4
        )
    for res in (oob, kfold, passive):
        assert res.best == (2, 2)
        assert np.isfinite(res.table[0]["rms"]) and np.isnan(res.table[1]["rms"])
        assert "needs at least 41 (one per term)" in res.table[1]["error"]
    with pytest.raises(ValueError, match=r"20,20: X has 30 samples but degree=\(20, 20\)"):
        select_oob(factory_for("lpr"), [(20, 20)], X[:30], y[:30], X[30:], y[30:])


def test_an_absurd_underdetermined_fit_is_still_refused():
    X = np.random.default_rng(7).uniform(-1.0, 1.0, (30, 2))
    assert 20301 > checks.MAX_UNDERDETERMINED_TERMS
    with pytest.raises(ValueError, match=r"needs at least 20301 .*only up to 1000 terms"):
        LegendreRegression(degree=200, interactions=True).fit(X, X[:, 0])


def test_fit_predict_score_take_scikit_learns_names():
    for cls in (LegendreRegression, PassiveLegendreRegression, Kriging):
        assert list(inspect.signature(cls.fit).parameters) == ["self", "X", "y"]
        assert list(inspect.signature(cls.predict).parameters) == ["self", "X"]
        assert list(inspect.signature(cls.score).parameters) == ["self", "X", "y", "sample_weight"]
    model = LegendreRegression(degree=2).fit(X=U, y=V)
    assert model.n_features_in_ == 2
    assert model.score(X=U, y=V) == model.score(U, V)


def test_a_1d_x_is_refused_as_scikit_learn_does():
    x = U[:, 0]
    for model in (LegendreRegression(degree=2), PassiveLegendreRegression(degree=2), Kriging()):
        with pytest.raises(ValueError, match=r"X must be 2-D .*Reshape your data"):
            model.fit(x, V)
        model.fit(x[:, None], V)  # one input is one column
        assert model.n_features_in_ == 1
        with pytest.raises(ValueError, match=r"X must be 2-D .*reshape\(-1, 1\)"):
            model.predict(x)
        with pytest.raises(ValueError, match=r"X must be 2-D .*reshape\(-1, 1\)"):
            model.score(x, V)
    with pytest.raises(ValueError, match="X must be 2-D"):
        model.predict_variance(x)


def test_score_checks_the_feature_count():
    model = LegendreRegression(degree=2).fit(U, V)
    with pytest.raises(ValueError, match="X has 1 features, but LegendreRegression is expecting 2"):
        model.score(U[:, :1], V)


def _fit_data() -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(20240611)
    X = rng.uniform(-2.0, 3.0, (200, 2))
    y = np.sin(2.0 * X[:, 0]) + X[:, 1] ** 3 - 0.5 * X[:, 0] * X[:, 1]
    return X, y


def _models() -> dict[str, Any]:
    return {
        "additive": LegendreRegression(degree=(7, 5)),
        "interactions": LegendreRegression(degree=6, interactions=True),
        "passive": PassiveLegendreRegression(degree=(6, 4), monotone=(True, False)),
    }


def test_refitting_gives_bit_identical_coefficients():
    """Seeded fits reproduce bit for bit on the same machine (the bytes, not a pinned hash:
    another CPU's BLAS may round differently)."""
    X, y = _fit_data()
    for name, model in _models().items():
        twin = sklearn_base.clone(model)
        first = np.ascontiguousarray(model.fit(X, y).coef_, dtype=np.float64).tobytes()
        again = np.ascontiguousarray(twin.fit(X, y).coef_, dtype=np.float64).tobytes()
        assert first == again, name


@pytest.mark.parametrize(
    ("name", "exponents"),
    [
        ("additive", [(i, 0) for i in range(8)] + [(0, j) for j in range(1, 6)]),
        ("interactions", [(a, b) for a in range(7) for b in range(7) if a + b <= 6]),
    ],
)
def test_fits_are_the_least_squares_projection(name, exponents):
    """An unconstrained fit's predictions at its samples are the projection of ``y`` onto the
    span of its terms, computed independently with numpy's Legendre basis and ``lstsq``."""
    X, y = _fit_data()
    model = _models()[name].fit(X, y)
    t = 2.0 * (X - X.min(0)) / (X.max(0) - X.min(0)) - 1.0
    unit = np.eye(8)
    design = np.stack(
        [
            legendre.legval(t[:, 0], unit[a]) * legendre.legval(t[:, 1], unit[b])
            for a, b in exponents
        ],
        axis=1,
    )
    coef, *_ = np.linalg.lstsq(design, y, rcond=None)
    assert model.n_terms_ == len(exponents)
    np.testing.assert_allclose(model.predict(X), design @ coef, rtol=0.0, atol=1e-10)


def test_predict_reports_the_feature_count_as_scikit_learn_does():
    model = LegendreRegression(degree=2).fit(U, V)
    with pytest.raises(ValueError, match="X has 1 features, but LegendreRegression is expecting 2"):
        model.predict(U[:, :1])
    with pytest.raises(ValueError, match="Reshape your data"):
        model.predict(U[0])


@pytest.mark.parametrize(("cls", "params"), CASES)
def test_score_is_r2_and_sklearn_sees_a_regressor(cls, params):
    metrics = pytest.importorskip("sklearn.metrics")
    base = pytest.importorskip("sklearn.base")
    model = cls(**params).fit(U, V)
    W = np.clip(U * 0.9 + 0.05, -1, 1)
    y = np.cos(W[:, 0]) + W[:, 1]
    w = np.linspace(0.5, 2.0, y.size)
    assert model.score(W, y) == pytest.approx(metrics.r2_score(y, model.predict(W)), rel=1e-12)
    assert model.score(W, y, sample_weight=w) == pytest.approx(
        metrics.r2_score(y, model.predict(W), sample_weight=w), rel=1e-12
    )
    assert base.is_regressor(model) and base.is_regressor(cls())


def test_pipeline_grid_search_and_cross_validation():
    pytest.importorskip("sklearn")
    from sklearn.model_selection import GridSearchCV, KFold, cross_val_score
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import StandardScaler

    rng = np.random.default_rng(4)
    X = rng.uniform(-1.0, 1.0, (120, 2))
    y = np.sin(2.0 * X[:, 0]) + X[:, 1] ** 3
    folds = KFold(4, shuffle=True, random_state=0)
    pipe = make_pipeline(StandardScaler(), LegendreRegression(extrapolation="clip"))
    scores = cross_val_score(pipe, X, y, cv=folds)  # default scoring: the estimator's score
    assert scores.shape == (4,) and np.all(scores > 0.99)
    search = GridSearchCV(LegendreRegression(), {"degree": [1, 3, 7]}, cv=folds).fit(X, y)
    assert search.best_params_ == {"degree": 7}  # sin and cubic need more than degree 3
    assert search.cv_results_["mean_test_score"][0] < 0.95 < search.best_score_


def test_not_fitted_is_scikit_learns_error_once_it_is_imported():
    exceptions = pytest.importorskip("sklearn.exceptions")
    with pytest.raises(exceptions.NotFittedError, match="not fitted"):
        Kriging().predict(U)
    with pytest.raises(RuntimeError, match="not fitted"):  # as before scikit-learn
        LegendreRegression().predict(U)


def test_surrogates_io_without_railgym(tmp_path):
    """``import surrogates; surrogates.io.save(...)`` works in a fresh interpreter without
    scikit-learn or railgym being imported."""
    import subprocess
    import sys

    code = (
        "import sys, numpy as np, surrogates\n"
        "x = np.arange(10.0)[:, None]\n"
        "m = surrogates.LegendreRegression(degree=2).fit(x, x[:, 0] ** 2)\n"
        f"surrogates.io.save(m, {str(tmp_path / 'm.json')!r})\n"
        f"print(surrogates.io.load({str(tmp_path / 'm.json')!r}).score(x, x[:, 0] ** 2))\n"
        "assert 'railgym' not in sys.modules and 'sklearn' not in sys.modules\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert float(out.stdout) == pytest.approx(1.0, abs=1e-12)
