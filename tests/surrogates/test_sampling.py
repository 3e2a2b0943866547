"""Space-filling sampling (paper section 3.2): maximin quality, partition, determinism, errors."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.distance import pdist

from surrogates.sampling import min_distance, phi_p, select

SEEDS = range(5)


def quick(X: np.ndarray, m: int, method: str, seed: int = 0) -> np.ndarray:
    """Training rows of ``select``, with a short GA (20 generations) where quality is moot."""
    options = {"generations": 20} if method == "ga" else {}
    return select(X, m, method, seed=seed, **options)[0]


@pytest.fixture(scope="module")
def cloud() -> np.ndarray:
    """1001 uniform random points in [0, 1]²."""
    return np.random.default_rng(2016).random((1001, 2))


def test_ga_beats_greedy_beats_random(cloud: np.ndarray) -> None:
    greedy = min_distance(cloud, select(cloud, 51, "greedy")[0])
    ga = [min_distance(cloud, select(cloud, 51, "ga", seed=s)[0]) for s in SEEDS]
    rand = [min_distance(cloud, select(cloud, 51, "random", seed=s)[0]) for s in SEEDS]
    assert min(ga) >= greedy  # elitism: never worse than the greedy design it starts from
    assert np.mean(ga) >= 1.1 * greedy  # and the search really improves on it
    assert greedy >= 2.0 * np.mean(rand)


def test_ga_finds_the_maximin_optimum_on_a_line() -> None:
    X = np.linspace(0.0, 1.0, 101)  # spacing 0.01; optimum for 11 rows: every 10th, d = 0.1
    assert min_distance(X, select(X, 11, "greedy")[0]) < 0.09
    for s in range(3):
        train, _ = select(X, 11, "ga", seed=s)
        np.testing.assert_array_equal(train, np.arange(0, 101, 10))


def test_ga_finds_the_nine_point_optimum_in_a_square() -> None:
    g = np.linspace(0.0, 1.0, 21)
    X = np.column_stack([np.repeat(g, 21), np.tile(g, 21)])
    train, _ = select(X, 9, "ga", seed=3)
    # optimal spreading of 9 points in a square: the 3 × 3 grid, d = 0.5
    assert min_distance(X, train) == pytest.approx(0.5, abs=1e-12)
    assert sorted(map(tuple, X[train])) == [(a, b) for a in (0, 0.5, 1) for b in (0, 0.5, 1)]


@pytest.mark.parametrize("method", ["ga", "greedy", "random"])
@pytest.mark.parametrize("m", [1, 2, 17, 59, 60])
def test_partition(method: str, m: int) -> None:
    X = np.random.default_rng(m).normal(size=(60, 3))
    options = {"generations": 10} if method == "ga" else {}
    train, oob = select(X, m, method, seed=1, **options)
    assert np.issubdtype(train.dtype, np.integer) and np.issubdtype(oob.dtype, np.integer)
    assert len(train) == m and len(oob) == 60 - m
    assert np.all(np.diff(train) > 0) and np.all(np.diff(oob) > 0)
    np.testing.assert_array_equal(np.sort(np.concatenate([train, oob])), np.arange(60))


def test_same_seed_same_result_different_seed_differs(cloud: np.ndarray) -> None:
    for method in ("ga", "random"):
        a, b, c = (quick(cloud, 31, method, seed) for seed in (7, 7, 8))
        np.testing.assert_array_equal(a, b)
        assert not np.array_equal(a, c)
    gen = select(cloud, 31, "random", seed=np.random.default_rng(7))[0]
    np.testing.assert_array_equal(gen, select(cloud, 31, "random", seed=7)[0])
    np.testing.assert_array_equal(
        select(cloud, 31, "greedy", seed=1)[0], select(cloud, 31, "greedy", seed=2)[0]
    )


def test_choice_ignores_units_and_constant_columns(cloud: np.ndarray) -> None:
    scaled = cloud * np.array([1e3, 1e-3]) + np.array([-5.0, 2.0])
    np.testing.assert_array_equal(select(scaled, 41, "greedy")[0], select(cloud, 41, "greedy")[0])
    padded = np.column_stack([cloud, np.full(len(cloud), 9.81)])
    for method in ("ga", "greedy"):
        np.testing.assert_array_equal(quick(padded, 41, method), quick(cloud, 41, method))


def test_duplicated_rows_are_not_both_chosen(cloud: np.ndarray) -> None:
    X = np.repeat(cloud[:200], 2, axis=0)
    for method in ("ga", "greedy"):
        assert min_distance(X, quick(X, 50, method)) > 0.0


def test_progress_callback() -> None:
    X = np.random.default_rng(0).random((200, 2))
    calls: list[tuple[int, int]] = []
    select(X, 20, "ga", seed=0, generations=7, progress=lambda i, n: calls.append((i, n)))
    assert calls == [(i, 7) for i in range(1, 8)]
    calls.clear()
    select(X, 20, "greedy", progress=lambda i, n: calls.append((i, n)))
    assert calls == [(1, 1)]


def test_min_distance_and_phi_p() -> None:
    g = np.array([0.0, 0.5, 1.0])
    grid = np.column_stack([np.repeat(g, 3), np.tile(g, 3)])
    assert min_distance(grid) == pytest.approx(0.5, abs=1e-15)
    for p in (2.0, 50.0):
        brute = np.sum(pdist(grid) ** -p) ** (1.0 / p)
        assert phi_p(grid, p=p) == pytest.approx(brute, rel=1e-12)
    assert min_distance(grid, [0, 8]) == pytest.approx(np.sqrt(2.0))  # opposite corners
    # a near-coincident pair: Σ d^-50 overflows a float, φ_50 does not (→ 1/d_min)
    X = np.array([[0.0, 0.0], [1.0, 1.0], [0.3, 0.3], [0.3, 0.3 + 1e-9]])
    with np.errstate(over="ignore"):
        assert np.sum(pdist(X) ** -50.0) == np.inf
    assert phi_p(X) == pytest.approx(1e9, rel=1e-6)
    assert min_distance(X[:1]) == np.inf and phi_p(X[:1]) == 0.0
    assert phi_p(np.array([[0.0, 1.0], [0.0, 1.0], [1.0, 0.0]])) == np.inf


@pytest.mark.parametrize(
    ("args", "kwargs", "match"),
    [
        ((np.arange(5.0), 0), {}, "m must be >= 1"),
        ((np.arange(5.0), 6), {}, "exceeds the number of rows"),
        ((np.arange(5.0), 2.5), {}, "m must be an integer"),
        ((np.arange(5.0), True), {}, "m must be an integer"),
        ((np.arange(5.0), 2), {"method": "lhs"}, "method must be one of"),
        ((np.array([0.0, 1.0, np.nan, 3.0]), 2), {}, "X has a non-finite value at row 2"),
        ((np.zeros((2, 2, 2)), 1), {}, "X must have shape"),
        ((np.arange(5.0), 2), {"population_size": 10}, "unknown GA option"),
        ((np.arange(5.0), 2), {"method": "greedy", "generations": 3}, "only apply to"),
        ((np.arange(5.0), 2), {"population": 4, "elite": 4}, "elite must be < population"),
        ((np.arange(5.0), 2), {"progress": 3}, "progress must be callable"),
    ],
)
def test_errors(args: tuple, kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        select(*args, **kwargs)
