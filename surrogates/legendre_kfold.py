"""k-fold cross-validation of Legendre regression candidates from one factorisation per fold.

:func:`surrogates.selection.select_kfold` fits every candidate on every fold. For
:class:`~surrogates.models.lpr.LegendreRegression` and
:class:`~surrogates.passive.PassiveLegendreRegression` the candidates of a degree search share
their terms: an additive candidate ``(n_1, …, n_d)`` has the terms ``P_k(t_j)``, ``k ≤ n_j``,
a subset of those of the largest degree per input, and a total-degree candidate
(``interactions=True``) those of the largest total degree. :class:`SharedFolds` therefore
builds, per fold,

* the design matrix ``A`` of the union of the candidates' terms on that fold's training box
  (the box, mapping to ``t`` and column norms of ``fit``: each fold keeps its own box, as the
  plain loop does) and the triangular factor of ``[A / norms, V] = Q [R, g]``, ``g = Qᵀ V``.
  A candidate's columns ``S`` give ``A_S / norms_S = Q R_S``, so its least-squares problem is
  ``min ‖R_S c − g‖`` up to a constant; a QR of the small matrix ``[R_S, g]`` yields the
  triangular factor and right-hand side a QR of ``A_S / norms_S`` yields, up to the signs of
  their rows and rounding (orthogonal factorisations only: the condition number is not
  squared as in the normal equations). ``LegendreRegression`` solves the triangular system
  (its ``fit`` uses an SVD solver: the same minimiser at full rank),
  ``PassiveLegendreRegression`` runs its constrained solve
  (:func:`surrogates.passive.passive_coefficients`) on it;
* the matrix of the union's terms at the held-out inputs clipped to the box and, for the
  ``"linear"`` extrapolation, the gradient terms times the distance to the box: ``predict``
  is linear in the coefficients, so a candidate's held-out prediction is one product.

Candidates it does not cover (another class, a subclass, ``extrapolation="raise"``, invalid
hyperparameters, more terms than training samples, a rank-deficient fold, a solver error,
non-finite predictions) get ``None`` from :meth:`SharedFolds.predictions` and are fitted by
the loop, which reports their errors. The pooled scores agree with the loop's to
:data:`SCORE_RTOL`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.linalg import solve_triangular
from threadpoolctl import threadpool_limits

from surrogates.models.lpr import (
    LegendreRegression,
    design_matrix,
    legendre_derivative,
    legendre_table,
)
from surrogates.passive import (
    SLOPE_MARGIN,
    PassiveLegendreRegression,
    passive_coefficients,
    rank_deficient,
)

#: relative tolerance within which the shared path's pooled scores (rms, mae, nrms) match
#: those of fitting each candidate on each fold (checked by the tests)
SCORE_RTOL = 1e-6


@dataclass
class _Fold:
    """One fold's factorisation and held-out matrices over the union of the terms."""

    held: np.ndarray  # indices of the held-out rows
    n_train: int
    spread: float  # ptp of the training outputs
    norms: np.ndarray  # (T,) column norms of the training design matrix
    Rg: np.ndarray  # (≤ T + 1, T + 1) triangular factor of [A / norms, V]
    inside: np.ndarray  # (n_held, T) terms at the held-out inputs clipped to the box
    outside: np.ndarray  # (n_held,) bool: held-out rows outside the box
    extension: np.ndarray  # (n_outside, T) gradient terms times the distance to the box


@dataclass
class _Candidate:
    """A model the shared path can score: its columns in the union of the terms, its
    exponents (T, d) and, for the passive class, which inputs are constrained."""

    model: LegendreRegression
    columns: np.ndarray
    exponents: np.ndarray
    mono: tuple[bool, ...]


class SharedFolds:
    """Held-out predictions of Legendre candidates from one factorisation per fold.

    Build it with :meth:`prepare`; :meth:`predictions` gives each candidate's pooled
    held-out predictions (what fitting it on every fold and predicting its held-out rows
    gives) or ``None`` where the loop has to fit it. Both run with one BLAS thread: their
    many small factorisations wake a thread pool otherwise, which on a loaded machine costs
    more than the arithmetic (as :class:`~surrogates.models.kriging.Kriging` fits).
    """

    def __init__(self, n: int, folds: list[_Fold], candidates: list[_Candidate | None]) -> None:
        self.n = n
        self.folds = folds
        self.candidates = candidates

    @classmethod
    def prepare(
        cls,
        models: Sequence[Any],
        U: np.ndarray,
        V: np.ndarray,
        folds: Sequence[np.ndarray],
    ) -> SharedFolds | None:
        """Factorise every fold for the union of the terms of the covered ``models``.

        Parameters
        ----------
        models : unfitted candidate models (``None`` for one that could not be built).
        U, V : validated inputs (n, d) and outputs (n,).
        folds : held-out indices of each fold (:func:`surrogates.selection.kfold_indices`).

        Returns
        -------
        SharedFolds, or ``None`` when it covers no candidate or a fold's training data
        cannot be fitted at all (constant input column, overflowing output): the loop then
        fits every candidate and reports why.
        """
        with threadpool_limits(limits=1, user_api="blas"):
            n, d = U.shape
            trains = [np.setdiff1d(np.arange(n), f, assume_unique=True) for f in folds]
            n_train = min(t.size for t in trains)
            terms: dict[tuple[int, ...], int] = {}
            cands: list[_Candidate | None] = []
            for model in models:
                cand = _candidate(model, d, n_train)
                if cand is not None:
                    for e in map(tuple, cand.exponents.tolist()):
                        terms.setdefault(e, len(terms))
                    cand.columns = np.array(
                        [terms[e] for e in map(tuple, cand.exponents.tolist())], dtype=np.int64
                    )
                cands.append(cand)
            if not terms:
                return None
            E = np.array(list(terms), dtype=np.int64)
            shared = []
            for fold, train in zip(folds, trains, strict=True):
                f = _factorise(U, V, fold, train, E)
                if f is None:
                    return None
                shared.append(f)
            return cls(n, shared, cands)

    def predictions(self, i: int) -> np.ndarray | None:
        """Pooled held-out predictions (n,) of candidate ``i``; ``None`` when the loop has to
        fit it (not covered, rank deficient on a fold, non-finite predictions)."""
        cand = self.candidates[i]
        if cand is None:
            return None
        with threadpool_limits(limits=1, user_api="blas"):
            return self._predictions(cand)

    def _predictions(self, cand: _Candidate) -> np.ndarray | None:
        pred = np.empty(self.n)
        T_union = self.folds[0].norms.size
        for fold in self.folds:
            try:
                scaled = _solve(cand, fold)
            except (ValueError, np.linalg.LinAlgError):
                scaled = None  # e.g. no slope to constrain: the loop reports its fit's error
            if scaled is None:
                return None
            coef = np.zeros(T_union)
            coef[cand.columns] = scaled / fold.norms[cand.columns]
            values = fold.inside @ coef
            if cand.model.extrapolation == "linear" and fold.extension.shape[0]:
                values[fold.outside] += fold.extension @ coef
            pred[fold.held] = values
        if not np.all(np.isfinite(pred)):
            return None
        return pred


def _candidate(model: Any, d: int, n_train: int) -> _Candidate | None:
    """The shared-path view of ``model``, or ``None`` when the loop has to fit it."""
    try:
        if type(model) is PassiveLegendreRegression:
            model._check_params()
            E, mono = model._validate(d)
        elif type(model) is LegendreRegression:
            model._check_params()
            E, mono = model.make_exponents(d), ()
        else:
            return None
    except ValueError:
        return None
    if model.extrapolation not in ("linear", "clip") or E.shape[0] > n_train:
        return None
    return _Candidate(model, np.empty(0, dtype=np.int64), E, mono)


def _map(U: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """:meth:`LegendreRegression._map` on the box ``[lower, upper]`` (same arithmetic)."""
    return (U - lower) * (2.0 / (upper - lower)) - 1.0


def _factorise(
    U: np.ndarray, V: np.ndarray, held: np.ndarray, train: np.ndarray, E: np.ndarray
) -> _Fold | None:
    """One fold's :class:`_Fold` for the terms ``E``; ``None`` when ``fit`` would refuse
    its training data for every candidate."""
    Ut, Vt = U[train], V[train]
    lower, upper = Ut.min(axis=0), Ut.max(axis=0)
    with np.errstate(over="ignore"):
        width = upper - lower
    if not (np.all(width > 0) and np.all(np.isfinite(width)) and np.isfinite(np.std(Vt))):
        return None
    A = design_matrix(_map(Ut, lower, upper), E)
    norms = np.linalg.norm(A, axis=0)
    Rg = _triangular(np.column_stack([A / norms, Vt]))
    del A
    Uh = U[held]
    Uc = np.clip(Uh, lower, upper)
    outside = np.any(Uc != Uh, axis=1)
    inside = design_matrix(_map(Uc, lower, upper), E)
    extension = _extension(Uh[outside], Uc[outside], E, lower, upper)
    return _Fold(held, train.size, float(np.ptp(Vt)), norms, Rg, inside, outside, extension)


def _triangular(M: np.ndarray) -> np.ndarray:
    """Upper triangular factor (min(m, p), p) of the QR factorisation of ``M`` (m, p)."""
    return np.asarray(np.linalg.qr(M, mode="r"))


def _extension(
    Uo: np.ndarray, Uco: np.ndarray, E: np.ndarray, lower: np.ndarray, upper: np.ndarray
) -> np.ndarray:
    """Terms (n_out, T) of the linear extension ``∇F(u_b)·(u − u_b)`` at the points ``Uo``
    outside the box (``Uco`` clipped onto it): the gradient of
    :meth:`LegendreRegression._gradient_inside` per term."""
    if Uo.shape[0] == 0:
        return np.zeros((0, E.shape[0]))
    d = E.shape[1]
    P = legendre_table(_map(Uco, lower, upper), int(E.max()))
    dP = legendre_derivative(P)
    cols = np.arange(d)[None, :]
    F = P[:, cols, E]  # (n, T, d): P_{e_tj}(t_j)
    D = dP[:, cols, E]
    dt_du = 2.0 / (upper - lower)
    out = np.zeros((Uo.shape[0], E.shape[0]))
    for j in range(d):
        Fj = F.copy()
        Fj[:, :, j] = D[:, :, j]
        out += np.prod(Fj, axis=2) * (dt_du[j] * (Uo[:, j] - Uco[:, j]))[:, None]
    return out


def _solve(cand: _Candidate, fold: _Fold) -> np.ndarray | None:
    """Coefficients of the scaled columns of ``cand`` fitted on ``fold``'s training rows, or
    ``None`` when its fit would find the design matrix rank deficient."""
    S = cand.columns
    T = S.size
    Rg = fold.Rg
    r = _triangular(np.column_stack([Rg[:, S], Rg[:, -1]]))
    R, g = r[:T, :T], r[:T, T]
    s = np.linalg.svd(R, compute_uv=False)
    if type(cand.model) is PassiveLegendreRegression:
        if rank_deficient(s):
            return None
        margin = SLOPE_MARGIN * fold.spread
        grid_size = cand.model.grid_size
        coef, _, _ = passive_coefficients(
            R, g, cand.exponents, fold.norms[S], cand.mono, grid_size, margin
        )
        return coef
    # numpy.linalg.lstsq's rank (rcond=None) on the (n_train, T) scaled design matrix
    if not s[-1] > np.finfo(float).eps * max(fold.n_train, T) * s[0]:
        return None
    return solve_triangular(R, g)
