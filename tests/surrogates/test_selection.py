import numpy as np
import pytest

from surrogates.selection import (
    DEFAULT_MAX_DEGREE,
    default_candidates,
    factory_for,
    kfold_indices,
    select_kfold,
    select_oob,
)


def _noisy_poly(n, seed):
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1, 1, n)
    # true degree 4 in Legendre terms, noise 1 % of the signal range
    v = 1.0 + 2.0 * u - 3.0 * u**2 + 0.5 * u**3 + 4.0 * u**4
    return u[:, None], v + rng.normal(0, 0.05, n)


@pytest.mark.parametrize("method", ["oob", "kfold"])
def test_selection_picks_true_degree(method):
    U, V = _noisy_poly(400, seed=3)
    make = factory_for("lpr")
    cands = list(range(1, 11))
    if method == "oob":
        res = select_oob(make, cands, U[:200], V[:200], U[200:], V[200:])
    else:
        res = select_kfold(make, cands, U, V, k=10, seed=0)
    assert res.best == 4
    assert [r["candidate"] for r in res.table] == cands
    rms = {r["candidate"]: r["rms"] for r in res.table}
    # underfitting is clearly worse; the noise floor is reached at the true degree
    assert rms[3] > 2 * rms[4]
    assert rms[4] == pytest.approx(0.05, rel=0.25)


def test_candidates_with_too_many_terms_are_reported_not_fitted():
    U, V = _noisy_poly(8, seed=0)
    res = select_oob(factory_for("lpr"), [1, 2, 12], U[:6], V[:6], U[6:], V[6:])
    rows = {r["candidate"]: r for r in res.table}
    assert np.isnan(rows[12]["rms"]) and np.isfinite(rows[2]["rms"])


def test_kfold_indices_partition():
    folds = kfold_indices(23, k=5, seed=1)
    allidx = np.sort(np.concatenate(folds))
    np.testing.assert_array_equal(allidx, np.arange(23))
    assert {len(f) for f in folds} <= {4, 5}
    np.testing.assert_array_equal(np.concatenate(kfold_indices(23, 5, 1)), np.concatenate(folds))
    with pytest.raises(ValueError, match="k must be"):
        kfold_indices(5, k=10)


def test_default_degree_search_is_not_capped_at_10_for_two_inputs():
    cands = default_candidates("lpr", 2)
    assert max(max(c) for c in cands) == DEFAULT_MAX_DEGREE[2] > 10
    assert len(cands) == DEFAULT_MAX_DEGREE[2] ** 2
    assert default_candidates("lpr", 3) == list(range(1, 11))


def test_a_winner_at_the_search_cap_is_flagged():
    """A degree-7 polynomial in u1 searched up to 5 wins at the cap of input 0 only."""
    rng = np.random.default_rng(0)
    U = rng.uniform(-1, 1, (400, 2))
    V = np.polynomial.legendre.legval(U[:, 0], [0, 1, 0.5, 0.3, 0.2, 0.2, 0.1, 0.3]) + U[:, 1]
    V += rng.normal(0.0, 1e-3, V.size)
    cands = [(a, b) for a in range(1, 6) for b in range(1, 4)]
    res = select_kfold(factory_for("lpr"), cands, U, V, k=5)
    assert res.best[0] == 5 and res.at_cap() == [0]
    assert "largest candidate degree of input(s) [0]" in res.format()
    wide = select_kfold(factory_for("lpr"), [(a, 1) for a in range(5, 14)], U, V, k=5)
    assert 7 <= wide.best[0] < 13 and wide.at_cap() == [1]  # u2 had a single candidate
