import numpy as np
import pytest

from surrogates.selection import factory_for, kfold_indices, select_kfold, select_oob


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
