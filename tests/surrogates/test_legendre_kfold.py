"""The shared-factorisation k-fold scores of Legendre candidates (surrogates.legendre_kfold)
against fitting every candidate on every fold (the loop of select_kfold)."""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from surrogates.legendre_kfold import SCORE_RTOL, SharedFolds
from surrogates.models.lpr import LegendreRegression
from surrogates.passive import PassiveLegendreRegression
from surrogates.selection import factory_for, kfold_indices, select_kfold


class _LoopLPR(LegendreRegression):
    """The same model; a subclass, so select_kfold fits it on every fold."""


class _LoopPassive(PassiveLegendreRegression):
    """The same model; a subclass, so select_kfold fits it on every fold."""


LOOP = {LegendreRegression: _LoopLPR, PassiveLegendreRegression: _LoopPassive}


def _assert_same(fast: Any, loop: Any) -> None:
    """Same candidates, errors and winner; scores within SCORE_RTOL."""
    assert [r["candidate"] for r in fast.table] == [r["candidate"] for r in loop.table]
    for a, b in zip(fast.table, loop.table, strict=True):
        assert a.get("error") == b.get("error")
        for key in ("rms", "mae", "nrms"):
            if np.isnan(b[key]):
                assert np.isnan(a[key])
            else:
                assert a[key] == pytest.approx(b[key], rel=SCORE_RTOL, abs=1e-300), (a, b)
    assert fast.best == loop.best


def _problem(seed: int, n: int, d: int) -> tuple[np.ndarray, np.ndarray]:
    """Inputs of very different scales and a smooth monotone output with noise."""
    rng = np.random.default_rng(seed)
    scale = 10.0 ** rng.uniform(-3, 3, d)
    U = rng.standard_normal((n, d)) * scale
    V = np.sum(np.tanh(U / scale) + 0.3 * (U / scale) ** 3, axis=1)
    return U, 10.0 ** rng.uniform(-2, 4) * (V + rng.normal(0.0, 0.1, n))


@st.composite
def searches(draw: st.DrawFn) -> tuple[Any, list[Any], dict[str, Any], np.ndarray, np.ndarray, int]:
    """A degree search: model class, candidates, hyperparameters, data and folds."""
    d = draw(st.integers(1, 3))
    cls = draw(st.sampled_from([LegendreRegression, PassiveLegendreRegression]))
    params: dict[str, Any] = {"extrapolation": draw(st.sampled_from(["linear", "clip"]))}
    if cls is LegendreRegression and draw(st.booleans()):
        params["interactions"] = True
        cands: list[Any] = list(range(draw(st.integers(1, 5))))
    else:
        top = draw(st.integers(1, 4 if d < 3 else 3))
        cands = list(itertools.product(range(top + 1), repeat=d))
    if cls is PassiveLegendreRegression and d > 1 and draw(st.booleans()):
        params["monotone"] = tuple(draw(st.lists(st.booleans(), min_size=d, max_size=d)))
    n = draw(st.integers(8, 120))
    U, V = _problem(draw(st.integers(0, 2**32 - 1)), n, d)
    return cls, cands, params, U, V, draw(st.integers(2, min(5, n)))


# a passive input of degree 0 has no slope to constrain: its fit divides by a zero norm and
# fails (an error row in both paths)
@pytest.mark.filterwarnings("ignore:invalid value encountered in divide:RuntimeWarning")
@pytest.mark.filterwarnings("ignore:divide by zero encountered in divide:RuntimeWarning")
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(searches())
def test_shared_scores_are_the_loop_scores(search):
    """Every candidate (including those with more terms than a fold has samples) scores as
    when it is fitted on every fold; held-out points outside a fold's box included."""
    cls, cands, params, U, V, k = search
    fast = select_kfold(lambda c: cls(degree=c, **params), cands, U, V, k=k, seed=1)
    loop = select_kfold(lambda c: LOOP[cls](degree=c, **params), cands, U, V, k=k, seed=1)
    _assert_same(fast, loop)


@pytest.mark.parametrize("cls", [LegendreRegression, PassiveLegendreRegression])
def test_the_shared_path_covers_the_degree_search(cls):
    """On the memory element's kind of search every candidate is scored by the shared path,
    folds with held-out points outside their box included, with the loop's predictions."""
    U, V = _problem(3, 400, 3)
    U[7] *= 3.0  # an outlier: outside the box of the folds that hold it out
    folds = kfold_indices(U.shape[0], 5, 0)
    cands = list(itertools.product((2, 4), (2, 3), (3, 5)))
    shared = SharedFolds.prepare([cls(degree=c) for c in cands], U, V, folds)
    assert shared is not None
    assert any(f.outside.any() for f in shared.folds)
    for i, cand in enumerate(cands):
        pred = shared.predictions(i)
        assert pred is not None
        expected = np.empty_like(V)
        for fold in folds:
            train = np.setdiff1d(np.arange(V.size), fold)
            expected[fold] = cls(degree=cand).fit(U[train], V[train]).predict(U[fold])
        np.testing.assert_allclose(pred, expected, rtol=SCORE_RTOL, atol=1e-9 * np.ptp(V))
    fast = select_kfold(lambda c: cls(degree=c), cands, U, V, k=5, seed=0)
    loop = select_kfold(lambda c: LOOP[cls](degree=c), cands, U, V, k=5, seed=0)
    _assert_same(fast, loop)


def test_candidates_the_shared_path_does_not_take_are_fitted_by_the_loop():
    """Subclasses, extrapolation="raise", bad degrees and other kinds give None there; the
    search still scores them (or reports them) as the loop does."""
    U, V = _problem(5, 80, 2)
    folds = kfold_indices(U.shape[0], 4, 0)
    models = [
        _LoopLPR(degree=2),
        LegendreRegression(degree=2, extrapolation="raise"),
        LegendreRegression(degree=(1, 2, 3)),  # three degrees for two inputs
        PassiveLegendreRegression(degree=2, grid_size=1),
        LegendreRegression(degree=40),  # more terms than a fold has samples
        None,
        LegendreRegression(degree=(2, 3)),
    ]
    shared = SharedFolds.prepare(models, U, V, folds)
    assert shared is not None
    assert [shared.predictions(i) is None for i in range(len(models))] == [True] * 6 + [False]
    assert SharedFolds.prepare(models[:6], U, V, folds) is None
    cands = [(1, 1), (2, 3), (50, 50), "x"]

    def make(c: Any) -> Any:
        if c == "x":
            raise ValueError("not a degree")
        return LegendreRegression(degree=c)

    res = select_kfold(make, cands, U, V, k=4)
    assert np.isfinite(res.table[1]["rms"]) and "needs at least" in res.table[2]["error"]
    assert res.table[3]["error"] == "not a degree"
    kriging = select_kfold(factory_for("kriging"), ["gaussian"], U[:30], V[:30], k=3)
    assert np.isfinite(kriging.table[0]["rms"])


def test_a_constant_column_in_a_fold_is_left_to_the_loop():
    """A fold whose training inputs are constant in a column cannot be fitted by any
    candidate: the shared path steps aside and the loop reports the error."""
    U = np.column_stack([np.linspace(0.0, 1.0, 10), np.r_[np.zeros(9), 1.0]])
    V = U[:, 0] + U[:, 1]
    folds = kfold_indices(10, 2, 0)
    assert SharedFolds.prepare([LegendreRegression(degree=1)], U, V, folds) is None
    with pytest.raises(ValueError, match="zero width"):
        select_kfold(factory_for("lpr"), [1], U, V, k=2, seed=0)
