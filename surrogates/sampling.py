"""Space-filling choice of training samples from a data set (paper section 3.2).

``select(X, m)`` picks ``m`` rows of ``X`` that fill the data as evenly as possible (maximin:
the smallest pairwise distance of the chosen rows is as large as possible) and returns them
with the other rows, the out-of-bag samples. Distances are measured after scaling every
column of ``X`` to [0, 1] (constant columns are left out), so the choice does not depend on
the units of the inputs.

Methods
-------
``"greedy"``
    farthest-point maximin: start from the row nearest the centroid, then repeatedly add the
    row farthest from those chosen (deterministic, O(n·m)).
``"ga"`` (default)
    genetic algorithm on index subsets after Taheri & Ahmadian (2016): the fitness is the
    smallest pairwise distance, ties broken by the Morris–Mitchell criterion φ_p. The initial
    population holds the greedy design and greedy designs from random start rows; children come
    from a cut crossover (one parent's rows on one side of a random hyperplane, the other
    parent's on the other side) and mutations that move one row of the closest pair to the best
    of a few unchosen rows nearby. The best designs survive each generation (elitism), so the
    result is never worse than ``"greedy"``.
``"random"``
    uniform choice without replacement.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numba import njit

from surrogates.models.checks import random_seed

METHODS = ("ga", "greedy", "random")
GA_DEFAULTS: dict[str, Any] = {
    "population": 30,
    "generations": 200,
    "elite": 2,
    "swaps": 2,
    "candidates": 24,
    "p": 50.0,
}

Seed = int | np.random.Generator | None
Progress = Callable[[int, int], None] | None


# --------------------------------------------------------------------------------------
# kernels


@njit(cache=True)
def _sqdist(Xn: np.ndarray, a: int, b: int) -> float:
    s = 0.0
    for k in range(Xn.shape[1]):
        diff = Xn[a, k] - Xn[b, k]
        s += diff * diff
    return s


@njit(cache=True)
def _closest_pair(Xn: np.ndarray, idx: np.ndarray) -> tuple[float, int, int]:
    """Smallest squared distance among rows ``idx`` and its positions in ``idx``."""
    m = idx.shape[0]
    best, bi, bj = np.inf, 0, 0
    for i in range(m):
        for j in range(i + 1, m):
            d2 = _sqdist(Xn, idx[i], idx[j])
            if d2 < best:
                best, bi, bj = d2, i, j
    return best, bi, bj


@njit(cache=True)
def _fitness(Xn: np.ndarray, idx: np.ndarray, p: float) -> tuple[float, float]:
    """(smallest pairwise distance, φ_p) of rows ``idx``; φ_p = (Σ d_ij^-p)^(1/p).

    Computed as φ_p = (1/d_min)·(Σ (d_min/d_ij)^p)^(1/p), which neither overflows nor
    underflows; (inf, 0) for fewer than two rows and (0, inf) for coincident rows.
    """
    m = idx.shape[0]
    if m < 2:
        return np.inf, 0.0
    d2min, _, _ = _closest_pair(Xn, idx)
    if d2min == 0.0:
        return 0.0, np.inf
    half_p = 0.5 * p
    cutoff = d2min * np.exp(80.0 / p)  # farther pairs add < e^-40 each: skip them
    s = 0.0
    for i in range(m):
        for j in range(i + 1, m):
            d2 = _sqdist(Xn, idx[i], idx[j])
            if d2 < cutoff:
                s += (d2min / d2) ** half_p
    dmin = np.sqrt(d2min)
    return dmin, s ** (1.0 / p) / dmin


@njit(cache=True)
def _fitness_all(Xn: np.ndarray, pop: np.ndarray, p: float) -> tuple[np.ndarray, np.ndarray]:
    P = pop.shape[0]
    dmin, phi = np.empty(P), np.empty(P)
    for k in range(P):
        dmin[k], phi[k] = _fitness(Xn, pop[k], p)
    return dmin, phi


@njit(cache=True)
def _greedy(Xn: np.ndarray, m: int, start: int) -> np.ndarray:
    """Farthest-point maximin: ``m`` rows in the order chosen, starting from row ``start``."""
    n = Xn.shape[0]
    chosen = np.empty(m, np.int64)
    mind = np.full(n, np.inf)  # squared distance to the nearest chosen row; -1 once chosen
    j = start
    for s in range(m):
        chosen[s] = j
        mind[j] = -1.0
        best, bestd = -1, -1.0
        for i in range(n):
            if mind[i] >= 0.0:
                d2 = _sqdist(Xn, i, j)
                if d2 < mind[i]:
                    mind[i] = d2
                if mind[i] > bestd:
                    best, bestd = i, mind[i]
        j = best
    return chosen


@njit(cache=True)
def _crossover(
    Xn: np.ndarray,
    A: np.ndarray,
    B: np.ndarray,
    w: np.ndarray,
    r: int,
    member: np.ndarray,
    child: np.ndarray,
) -> None:
    """Cut crossover: the ``r`` rows of A lowest along direction ``w``, then B's highest.

    Makes ``m`` distinct rows (A's next rows fill up where B's repeat A's); marks them in
    ``member``.
    """
    m, d = A.shape[0], Xn.shape[1]
    pa, pb = np.zeros(m), np.zeros(m)
    for q in range(m):
        for k in range(d):
            pa[q] += Xn[A[q], k] * w[k]
            pb[q] += Xn[B[q], k] * w[k]
    oa, ob = np.argsort(pa), np.argsort(-pb)
    n_child = 0
    for q in range(r):
        child[n_child] = A[oa[q]]
        member[A[oa[q]]] = True
        n_child += 1
    for q in range(m):
        if n_child == m:
            break
        b = B[ob[q]]
        if not member[b]:
            child[n_child] = b
            member[b] = True
            n_child += 1
    q = r
    while n_child < m:  # B's rows were mostly A's own: fill up with A's remaining rows
        a = A[oa[q]]
        if not member[a]:
            child[n_child] = a
            member[a] = True
            n_child += 1
        q += 1


@njit(cache=True)
def _mutate(
    Xn: np.ndarray, child: np.ndarray, member: np.ndarray, pick: np.ndarray, cand: np.ndarray
) -> None:
    """``len(pick)`` swaps: one row of the closest pair goes to the best of a few unchosen rows.

    ``pick`` (swaps,) and ``cand`` (swaps, candidates) are uniform [0, 1) numbers that choose
    the row of the pair and the candidates, drawn within 2 d_min of the row where possible.
    """
    n, m = Xn.shape[0], child.shape[0]
    outside = np.empty(n - m, np.int64)
    n_out = 0
    for i in range(n):
        if not member[i]:
            outside[n_out] = i
            n_out += 1
    near = np.empty(n - m, np.int64)  # positions in ``outside``
    for k in range(pick.shape[0]):
        d2, i, j = _closest_pair(Xn, child)
        pos = i if pick[k] < 0.5 else j
        old = child[pos]
        n_near = 0
        if d2 > 0.0:
            for q in range(n - m):
                if _sqdist(Xn, outside[q], old) < 4.0 * d2:
                    near[n_near] = q
                    n_near += 1
        best_q, best_d2 = -1, -1.0
        for c in range(cand.shape[1]):
            if n_near > 0:
                q = near[min(int(cand[k, c] * n_near), n_near - 1)]
            else:
                q = min(int(cand[k, c] * (n - m)), n - m - 1)
            row = outside[q]
            cd2 = np.inf
            for s in range(m):
                if s != pos:
                    dd = _sqdist(Xn, row, child[s])
                    if dd < cd2:
                        cd2 = dd
            if cd2 > best_d2:
                best_q, best_d2 = q, cd2
        child[pos] = outside[best_q]
        member[outside[best_q]] = True
        member[old] = False
        outside[best_q] = old


@njit(cache=True)
def _generation(
    Xn: np.ndarray,
    pop: np.ndarray,
    dmin: np.ndarray,
    phi: np.ndarray,
    order: np.ndarray,
    elite: int,
    p: float,
    tour: np.ndarray,
    w: np.ndarray,
    cut: np.ndarray,
    pick: np.ndarray,
    cand: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One generation: keep the ``elite`` best (``order`` best first), breed the rest.

    Child ``c`` uses the random draws ``tour[c]`` (4 individuals for two binary tournaments),
    ``w[c]``, ``cut[c]`` (crossover) and ``pick[c]``, ``cand[c]`` (mutation).
    """
    P, m = pop.shape
    n = Xn.shape[0]
    rank = np.empty(P, np.int64)
    for r in range(P):
        rank[order[r]] = r
    new, new_dmin, new_phi = np.empty_like(pop), np.empty(P), np.empty(P)
    for e in range(elite):
        new[e] = pop[order[e]]
        new_dmin[e], new_phi[e] = dmin[order[e]], phi[order[e]]
    member = np.zeros(n, np.bool_)
    parents = np.empty(2, np.int64)
    for c in range(elite, P):
        for s in range(2):
            a, b = tour[c, 2 * s], tour[c, 2 * s + 1]
            parents[s] = a if rank[a] < rank[b] else b
        child = new[c]
        if parents[0] == parents[1]:
            child[:] = pop[parents[0]]
            for q in range(m):
                member[child[q]] = True
        else:
            _crossover(Xn, pop[parents[0]], pop[parents[1]], w[c], cut[c], member, child)
        _mutate(Xn, child, member, pick[c], cand[c])
        for q in range(m):
            member[child[q]] = False
        new_dmin[c], new_phi[c] = _fitness(Xn, child, p)
    return new, new_dmin, new_phi


# --------------------------------------------------------------------------------------
# helpers


def normalise(X: Any) -> np.ndarray:
    """``X`` (n, d) scaled column-wise to the unit hypercube, constant columns left out.

    Constant columns add nothing to any distance; if all are constant, one zero column remains.

    Raises ``ValueError`` naming ``X`` for a bad shape, no rows or non-finite values.
    """
    X = np.asarray(X, dtype=float)
    if X.ndim == 1:
        X = X[:, None]
    if X.ndim != 2 or X.shape[0] == 0 or X.shape[1] == 0:
        raise ValueError(f"X must have shape (n, d) with n, d >= 1, got {X.shape}")
    if not np.all(np.isfinite(X)):
        row, col = np.argwhere(~np.isfinite(X))[0]
        raise ValueError(f"X has a non-finite value at row {row}, column {col}")
    lo = X.min(axis=0)
    span = X.max(axis=0) - lo
    keep = span > 0.0
    if not keep.any():
        return np.zeros((X.shape[0], 1))
    return np.ascontiguousarray((X[:, keep] - lo[keep]) / span[keep])


def _rows(Xn: np.ndarray, idx: Any) -> np.ndarray:
    if idx is None:
        return np.arange(Xn.shape[0], dtype=np.int64)
    idx = np.asarray(idx)
    if idx.ndim != 1 or not np.issubdtype(idx.dtype, np.integer):
        raise ValueError("idx must be a 1-D array of integer row indices")
    if idx.size and (idx.min() < -Xn.shape[0] or idx.max() >= Xn.shape[0]):
        raise ValueError(f"idx has row indices outside [0, {Xn.shape[0]})")
    return np.ascontiguousarray(idx % Xn.shape[0], dtype=np.int64)


def min_distance(X: Any, idx: Any = None) -> float:
    """Smallest pairwise distance among rows ``idx`` (default all) of ``X`` in its unit cube.

    ``X`` is scaled by the range of all its rows (as in :func:`select`); inf for < 2 rows.
    """
    Xn = normalise(X)
    return float(_fitness(Xn, _rows(Xn, idx), 1.0)[0])


def phi_p(X: Any, idx: Any = None, p: float = 50.0) -> float:
    """Morris–Mitchell criterion φ_p = (Σ_{i<j} d_ij^-p)^(1/p) of rows ``idx`` in X's unit cube.

    Smaller is better; φ_p → 1/d_min as p → ∞. Computed without overflow; 0 for < 2 rows,
    inf for coincident rows.
    """
    if not (np.isfinite(p) and p > 0):
        raise ValueError(f"p must be a positive number, got {p}")
    Xn = normalise(X)
    return float(_fitness(Xn, _rows(Xn, idx), float(p))[1])


def _count(value: Any, name: str, low: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise ValueError(f"{name} must be an integer, got {value!r}")
    if value < low:
        raise ValueError(f"{name} must be >= {low}, got {value}")
    return int(value)


def _centroid_start(Xn: np.ndarray) -> int:
    return int(np.argmin(((Xn - Xn.mean(axis=0)) ** 2).sum(axis=1)))


def _ga(
    Xn: np.ndarray, m: int, rng: np.random.Generator, progress: Progress, **opts: Any
) -> np.ndarray:
    unknown = sorted(set(opts) - set(GA_DEFAULTS))
    if unknown:
        raise ValueError(f"unknown GA option(s) {unknown}; known: {sorted(GA_DEFAULTS)}")
    o = {**GA_DEFAULTS, **opts}
    P = _count(o["population"], "population", 2)
    G = _count(o["generations"], "generations", 0)
    elite = _count(o["elite"], "elite", 1)
    if elite >= P:
        raise ValueError(f"elite must be < population = {P}, got {elite}")
    swaps = _count(o["swaps"], "swaps", 0)
    cands = _count(o["candidates"], "candidates", 1)
    p = float(o["p"])
    if not (np.isfinite(p) and p > 0):
        raise ValueError(f"p must be a positive number, got {o['p']!r}")

    n = Xn.shape[0]
    greedy = _greedy(Xn, m, _centroid_start(Xn))
    if m < 2 or m == n:
        if progress:
            progress(1, 1)
        return greedy
    pop = np.empty((P, m), np.int64)
    pop[0] = greedy
    for k, start in enumerate(rng.choice(n, size=P - 1, replace=P - 1 > n), start=1):
        pop[k] = _greedy(Xn, m, int(start))
    dmin, phi = _fitness_all(Xn, pop, p)
    d = Xn.shape[1]
    for g in range(G):
        order = np.lexsort((phi, -dmin))
        draws = (
            rng.integers(0, P, size=(P, 4)),
            rng.standard_normal((P, d)),
            rng.integers(1, m, size=P),
            rng.random((P, swaps)),
            rng.random((P, swaps, cands)),
        )
        pop, dmin, phi = _generation(Xn, pop, dmin, phi, order, elite, p, *draws)
        if progress:
            progress(g + 1, G)
    return pop[np.lexsort((phi, -dmin))[0]]


# --------------------------------------------------------------------------------------
# public entry point


def select(
    X: Any,
    m: int,
    method: str = "ga",
    seed: Seed = None,
    *,
    progress: Progress = None,
    **ga_options: Any,
) -> tuple[np.ndarray, np.ndarray]:
    """Choose ``m`` space-filling training rows of ``X``; the rest are out-of-bag.

    Parameters
    ----------
    X : data (n, d), or (n,) for one input; any units (columns are scaled to [0, 1]).
    m : number of training rows, 1 <= m <= n.
    method : ``"ga"``, ``"greedy"`` or ``"random"`` (see the module docstring).
    seed : seed or ``np.random.Generator`` of ``"ga"`` and ``"random"``; ``"greedy"`` is
        deterministic.
    progress : optional ``callback(i, total)`` after each GA generation (once, with
        ``(1, 1)``, for the other methods).
    ga_options : ``population`` (30), ``generations`` (200), ``elite`` (2, designs kept
        unchanged per generation), ``swaps`` (2, mutations per child), ``candidates`` (24,
        unchosen rows tried per mutation), ``p`` (50, exponent of φ_p).

    Returns
    -------
    (train_idx, oob_idx) : disjoint int arrays covering ``range(n)``; ``train_idx`` sorted,
    of length ``m``; ``oob_idx`` sorted.
    """
    Xn = normalise(X)
    n = Xn.shape[0]
    m = _count(m, "m", 1)
    if m > n:
        raise ValueError(f"m = {m} exceeds the number of rows n = {n}")
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    if progress is not None and not callable(progress):
        raise ValueError("progress must be callable(i, total) or None")
    if method != "ga" and ga_options:
        raise ValueError(f"options {sorted(ga_options)} only apply to method='ga'")
    rng = np.random.default_rng(random_seed(seed, "seed"))
    if method == "ga":
        chosen = _ga(Xn, m, rng, progress, **ga_options)
    else:
        if method == "greedy":
            chosen = _greedy(Xn, m, _centroid_start(Xn))
        else:
            chosen = rng.choice(n, size=m, replace=False)
        if progress:
            progress(1, 1)
    mask = np.zeros(n, dtype=bool)
    mask[chosen] = True
    return np.flatnonzero(mask), np.flatnonzero(~mask)
