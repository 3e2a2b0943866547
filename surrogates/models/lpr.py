"""Legendre polynomial regression (LPR), paper section 3.3, eq. (5)–(7).

Each input ``u_j`` is mapped onto ``t_j = 2 (u_j − lower_j) / (upper_j − lower_j) − 1 ∈ [−1, 1]``
over the training box and the output is modelled as a linear combination of Legendre terms
``Π_j P_{e_tj}(t_j)``, one row ``e_t`` of :attr:`LegendreRegression.exponents_` per term.

Decoupled (additive) form, the default (paper eq. 5)::

    v ≈ c_0 + Σ_j Σ_{k=1..n_j} c_{j,k} P_k(t_j)

Eq. (5) writes one constant term per input (``α_0 p_0(u_1)`` and ``β_0 p_0(u_2)``); since
``p_0 ≡ 1`` those columns of the design matrix (6) are identical and the system is singular, so a
single constant column ``c_0`` is kept here. With ``interactions=True`` every tensor term of total
degree ≤ ``degree`` is used instead.

The paper solves the normal equations (7) ``PᵀP α = PᵀV``; that squares the condition number, so
here the columns of ``P`` are scaled to unit 2-norm and the least-squares problem is solved by an
SVD-based solver (:func:`numpy.linalg.lstsq`). ``cond_`` is the condition number of the scaled
design matrix.

With fewer samples than terms (``n < T``, e.g. scikit-learn's estimator checks at the default
degree) the coefficients are not determined by the data: ``fit`` warns
(:class:`~surrogates.models.checks.UnderdeterminedFitWarning`) and returns the least-squares
solution of smallest norm (in the column-scaled coefficients; up to
:data:`~surrogates.models.checks.MAX_UNDERDETERMINED_TERMS` terms, more are refused). The
degree searches (:mod:`surrogates.selection`) skip such a candidate, as they skip one that
cannot be fitted. A determined fit (``n ≥ T``) is unchanged by this.

The module-level numba kernels :func:`lpr_eval`, :func:`lpr_eval_batch` and
:func:`lpr_is_outside` evaluate a fitted model from the plain arrays of
:meth:`LegendreRegression.kernel_arrays`, for use inside compiled vehicle models;
:func:`lpr_eval_into` is the allocation-free form for inner loops (work arrays from
:func:`lpr_scratch`, allocated once by the caller).
"""

from __future__ import annotations

import itertools
import math
from typing import Any, ClassVar

import numpy as np
from numba import njit

from surrogates.models.base import EXTRAPOLATION_POLICIES, SurrogateModel
from surrogates.models.checks import (
    MAX_DEGREE,
    ModelFieldError,
    boolean,
    choice,
    field,
    field_array,
    legendre_degree,
    real_or_nan,
    underdetermined_fit,
)

#: extrapolation policy → integer mode understood by the numba kernels
EXTRAPOLATION_MODES = {"linear": 0, "clip": 1, "raise": 2}


class LegendreRegression(SurrogateModel):
    """Least-squares Legendre polynomial regression on the training box.

    Parameters
    ----------
    degree
        Polynomial degree: one int for every input, or a tuple ``(n_1, n_2, ...)`` with one
        degree per input (additive form only).
    interactions
        ``False``: decoupled additive form (paper eq. 5). ``True``: all tensor terms
        ``Π_j P_{e_j}(t_j)`` with ``Σ_j e_j ≤ degree`` (needs an int ``degree``).
    extrapolation
        ``"linear"``, ``"clip"`` or ``"raise"``; see :mod:`surrogates.models.base`.

    Attributes
    ----------
    coef_ : ndarray (T,)
        Coefficient of each term, in the output's units, for the mapped inputs ``t``.
    exponents_ : ndarray of int (T, d)
        Legendre degree of each input in each term; row 0 is the constant term.
    n_terms_ : int
        Number of terms ``T``.
    cond_ : float
        2-norm condition number of the column-scaled design matrix (of its rank-``r`` part,
        ``s_1 / s_r``, when the fit had fewer samples than terms).
    """

    kind: ClassVar[str] = "lpr"

    def __init__(
        self,
        degree: int | tuple[int, ...] = 5,
        interactions: bool = False,
        extrapolation: str = "linear",
    ) -> None:
        self.degree = degree
        self.interactions = interactions
        self.extrapolation = extrapolation

    def _check_params(self) -> None:
        super()._check_params()
        degree = legendre_degree(self.degree)
        if boolean(self.interactions, "interactions") and isinstance(degree, tuple):
            raise ModelFieldError(
                f"degree must be a single int when interactions=True (total degree), "
                f"got {self.degree!r}"
            )

    # ------------------------------------------------------------------ fitting
    def _fit(self, U: np.ndarray, V: np.ndarray) -> None:
        n, d = U.shape
        degree = legendre_degree(self.degree)
        if self.interactions and isinstance(degree, int):  # _check_params rejects a tuple here
            T = math.comb(degree + d, d)
        else:
            degrees = degree if isinstance(degree, tuple) else (degree,) * d
            if len(degrees) != d:
                raise ValueError(f"degree has {len(degrees)} entries but X has {d} columns")
            T = 1 + sum(degrees)
        if n < T:
            underdetermined_fit(n, T, f"degree={self.degree!r} (interactions={self.interactions})")
        E = self.make_exponents(d)
        A = design_matrix(self._map(U), E)
        norms = np.linalg.norm(A, axis=0)
        if n < T:  # a column that vanishes on every sample gets the coefficient 0
            norms = np.where(norms > 0.0, norms, 1.0)
        coef_scaled, _, rank, s = np.linalg.lstsq(A / norms, V, rcond=None)
        if n >= T and rank < T:
            raise ValueError(
                f"degree={self.degree!r} is too high for the data: the design matrix has rank "
                f"{rank} < {T} terms (too few distinct values in some column of X)"
            )
        self.coef_ = coef_scaled / norms
        self.exponents_ = E
        self.n_terms_ = T
        # under-determined: the condition number of the part that the samples determine
        self.cond_ = float(s[0] / s[-1]) if n >= T else float(s[0] / s[rank - 1])

    def make_exponents(self, d: int) -> np.ndarray:
        """Exponent table (T, d) for ``d`` inputs; row 0 is the constant term."""
        degree = legendre_degree(self.degree)
        if self.interactions and isinstance(degree, int):
            rows = [
                e
                for total in range(degree + 1)
                for e in itertools.product(range(total + 1), repeat=d)
                if sum(e) == total
            ]
            return np.array(rows, dtype=np.int64)[:, ::-1].copy()
        degrees = degree if isinstance(degree, tuple) else (degree,) * d
        if len(degrees) != d:
            raise ValueError(f"degree has {len(degrees)} entries but X has {d} columns")
        table = [np.zeros(d, dtype=np.int64)]
        for j, n_j in enumerate(degrees):
            for k in range(1, n_j + 1):
                e = np.zeros(d, dtype=np.int64)
                e[j] = k
                table.append(e)
        return np.array(table, dtype=np.int64)

    # --------------------------------------------------------------- evaluation
    def _map(self, U: np.ndarray) -> np.ndarray:
        """Inputs (n, d) → mapped variables ``t`` in [−1, 1] on the training box."""
        # same arithmetic as the numba kernels (scale from lpr_scratch)
        return (U - self.lower_) * (2.0 / (self.upper_ - self.lower_)) - 1.0

    def _predict_inside(self, U: np.ndarray) -> np.ndarray:
        return design_matrix(self._map(U), self.exponents_) @ self.coef_

    def _gradient_inside(self, U: np.ndarray) -> np.ndarray:
        """Analytic gradient (n, d) in output units per input unit."""
        E = self.exponents_
        d = E.shape[1]
        P = legendre_table(self._map(U), int(E.max()))
        dP = legendre_derivative(P)
        cols = np.arange(d)[None, :]
        F = P[:, cols, E]  # (n, T, d): P_{e_tj}(t_j)
        D = dP[:, cols, E]
        dt_du = 2.0 / (self.upper_ - self.lower_)
        G = np.empty_like(U)
        for j in range(d):
            Fj = F.copy()
            Fj[:, :, j] = D[:, :, j]
            G[:, j] = (np.prod(Fj, axis=2) @ self.coef_) * dt_du[j]
        return G

    def kernel_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
        """Plain arrays for the numba kernels :func:`lpr_eval` / :func:`lpr_eval_batch`.

        Returns
        -------
        exponents : int64 (T, d)
        coef : float64 (T,)
            Coefficients of the terms in the mapped variables ``t``.
        lower, upper : float64 (d,)
            Training box in input units.
        mode : int
            0 linear extrapolation, 1 clip, 2 raise (:func:`lpr_eval` and
            :func:`lpr_eval_batch` raise; :func:`lpr_eval_into` leaves it to its caller).
        """
        self._check_fitted()
        return (
            np.ascontiguousarray(self.exponents_, dtype=np.int64),
            np.ascontiguousarray(self.coef_, dtype=np.float64).copy(),
            np.ascontiguousarray(self.lower_, dtype=np.float64).copy(),
            np.ascontiguousarray(self.upper_, dtype=np.float64).copy(),
            EXTRAPOLATION_MODES[
                choice(self.extrapolation, "extrapolation", EXTRAPOLATION_POLICIES)
            ],
        )

    # -------------------------------------------------------------- persistence
    def _state(self) -> dict[str, Any]:
        return {"coef": self.coef_, "exponents": self.exponents_, "cond": self.cond_}

    def _set_state(self, d: dict[str, Any]) -> None:
        coef = field_array(field(d, "coef", "model.state"), "model.state.coef", (None,))
        if coef.size == 0:
            raise ModelFieldError("model.state.coef must have at least one entry")
        with np.errstate(over="ignore"):
            bound = np.abs(coef).sum()  # |P_k| <= 1 on the box: bounds every prediction there
        if not np.isfinite(bound):
            raise ModelFieldError("model.state.coef: the sum of magnitudes overflows float64")
        E = field_array(
            field(d, "exponents", "model.state"),
            "model.state.exponents",
            (None, self.n_features_in_),
            integer=True,
            low=0,
            high=MAX_DEGREE,
        )
        if E.shape[0] != coef.size:
            raise ModelFieldError(
                f"model.state.coef has {coef.size} entries but model.state.exponents has "
                f"{E.shape[0]} rows: one coefficient per term is needed"
            )
        try:
            expected = self.make_exponents(self.n_features_in_)
        except ValueError:
            raise ModelFieldError(
                f"model.params.degree={self.degree!r} does not fit the model's "
                f"{self.n_features_in_} inputs (model.domain)"
            ) from None
        if expected.shape != E.shape or not np.array_equal(expected, E):
            raise ModelFieldError(
                f"model.state.exponents ({E.shape[0]} terms) are not the terms of "
                f"model.params degree={self.degree!r}, interactions={self.interactions!r} "
                f"for {self.n_features_in_} inputs ({expected.shape[0]} terms)"
            )
        self.coef_ = coef
        self.exponents_ = E
        self.n_terms_ = coef.size
        self.cond_ = real_or_nan(field(d, "cond", "model.state"), "model.state.cond")


# ---------------------------------------------------------------------- helpers
def legendre_table(t: np.ndarray, nmax: int) -> np.ndarray:
    """``P_k(t)`` for k = 0..nmax, shape ``t.shape + (nmax + 1,)``.

    Bonnet recurrence ``P_{k+1} = (2k+1)/(k+1)·t·P_k − k/(k+1)·P_{k−1}``.
    """
    P = np.empty(t.shape + (nmax + 1,))
    P[..., 0] = 1.0
    if nmax >= 1:
        P[..., 1] = t
    for k in range(1, nmax):
        # same arithmetic as the numba kernels (constants from lpr_scratch)
        P[..., k + 1] = (2 * k + 1) / (k + 1) * t * P[..., k] - k / (k + 1) * P[..., k - 1]
    return P


def legendre_derivative(P: np.ndarray) -> np.ndarray:
    """``P'_k(t)`` from the table ``P`` of :func:`legendre_table`:
    ``P'_{k+1} = P'_{k−1} + (2k+1) P_k``."""
    nmax = P.shape[-1] - 1
    dP = np.empty_like(P)
    dP[..., 0] = 0.0
    if nmax >= 1:
        dP[..., 1] = 1.0
    for k in range(1, nmax):
        dP[..., k + 1] = dP[..., k - 1] + (2 * k + 1) * P[..., k]
    return dP


def design_matrix(t: np.ndarray, E: np.ndarray) -> np.ndarray:
    """Design matrix (n, T): column ``t`` is ``Π_j P_{E[t, j]}(t_j)``."""
    P = legendre_table(t, int(E.max()))
    return np.prod(P[:, np.arange(E.shape[1])[None, :], E], axis=2)


# ----------------------------------------------------------------- numba kernels
@njit(cache=True)
def lpr_is_outside(u: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> bool:
    """True if the point ``u`` (d,) lies outside the box ``[lower, upper]``."""
    for j in range(u.shape[0]):
        if u[j] < lower[j] or u[j] > upper[j]:
            return True
    return False


@njit(cache=True)
def lpr_scratch(exponents: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Work array of one model for :func:`lpr_eval_into`, float64 (d + 4, L).

    ``L = max(nmax + 1, d, 2)``, ``nmax`` the largest Legendre degree in ``exponents`` (T, d).
    Rows ``0..d−1`` receive ``P_k(t_j)`` and row ``d`` ``P'_k`` (k < L); rows ``d+1, d+2``
    hold the recurrence constants ``(2k+1)/(k+1)`` and ``k/(k+1)``, row ``d+3`` the scales
    ``2/(upper_j − lower_j)`` of the map to ``t`` (1/input unit). Allocate once per model
    (``lower, upper`` (d,) its training box) and reuse it for every point.
    """
    d = exponents.shape[1]
    nmax = 0
    for i in range(exponents.shape[0]):
        for j in range(d):
            if exponents[i, j] > nmax:
                nmax = exponents[i, j]
    width = max(nmax + 1, d, 2)
    work = np.zeros((d + 4, width))
    for k in range(1, width):
        work[d + 1, k] = (2 * k + 1) / (k + 1)
        work[d + 2, k] = k / (k + 1)
    for j in range(d):
        work[d + 3, j] = 2.0 / (upper[j] - lower[j])
    return work


@njit(cache=True)
def lpr_eval(
    u: np.ndarray,
    exponents: np.ndarray,
    coef: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    mode: int,
) -> float:
    """Evaluate a fitted LPR model at one point ``u`` (d,) in input units.

    Outside the box the value at the clipped point is used; for ``mode`` 0 it is extended
    linearly with the gradient there (``mode`` 1: clip only); ``mode`` 2 raises
    ``ValueError``, as does a linear extension that overflows float64. Arrays as returned by
    :meth:`LegendreRegression.kernel_arrays`. Allocates its work array on every call; loops
    over many points should use :func:`lpr_eval_into` with one :func:`lpr_scratch`.
    """
    work = lpr_scratch(exponents, lower, upper)
    return _checked(
        u, lpr_eval_into(u, exponents, coef, lower, upper, mode, work), lower, upper, mode
    )


@njit(cache=True)
def _checked(u: np.ndarray, value: float, lower: np.ndarray, upper: np.ndarray, mode: int) -> float:
    """``value`` of :func:`lpr_eval_into` at ``u``, or ``ValueError`` for the ``"raise"``
    policy outside the box and for an overflowing linear extension."""
    if mode == 2 and lpr_is_outside(u, lower, upper):
        raise ValueError("input outside the training domain (extrapolation='raise')")
    if not np.isfinite(value):
        raise ValueError("linear extrapolation overflows float64: input too far outside the domain")
    return value


@njit(cache=True, inline="always")
def lpr_eval_into(
    u: np.ndarray,
    exponents: np.ndarray,
    coef: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    mode: int,
    work: np.ndarray,
) -> float:
    """Allocation-free :func:`lpr_eval`; ``work`` is :func:`lpr_scratch` of the same model
    (its rows ``0..d`` are overwritten, so one work array serves one thread).

    It does not raise for ``mode`` 2 (treated like 0) nor check the result: a caller that
    honours the ``"raise"`` policy tests :func:`lpr_is_outside` itself, as the vehicle kernels
    do; the result is ±inf when a linear extension overflows.

    Inlined into the calling numba function: as a separate call its array arguments' reference
    counting costs more than the evaluation (measured 4.2 vs 2.5 µs per vehicle control step).
    """
    d = u.shape[0]
    T = exponents.shape[0]
    nmax = work.shape[1] - 1
    if work.shape[0] != d + 4:
        raise ValueError("work must come from lpr_scratch of the same model")
    outside = False
    value = 0.0
    if d == 2:
        # two inputs (the vehicle case): interleaved recurrences, unrolled term products
        u0 = min(max(u[0], lower[0]), upper[0])
        u1 = min(max(u[1], lower[1]), upper[1])
        outside = u0 != u[0] or u1 != u[1]
        t0 = (u0 - lower[0]) * work[5, 0] - 1.0
        t1 = (u1 - lower[1]) * work[5, 1] - 1.0
        work[0, 0] = 1.0
        work[1, 0] = 1.0
        work[0, 1] = t0
        work[1, 1] = t1
        a0, a1, b0, b1 = 1.0, 1.0, t0, t1
        for k in range(1, nmax):
            n0 = work[3, k] * t0 * b0 - work[4, k] * a0
            n1 = work[3, k] * t1 * b1 - work[4, k] * a1
            work[0, k + 1] = n0
            work[1, k + 1] = n1
            a0, b0, a1, b1 = b0, n0, b1, n1
        for i in range(T):
            value += coef[i] * work[0, exponents[i, 0]] * work[1, exponents[i, 1]]
    else:
        for j in range(d):
            uc = min(max(u[j], lower[j]), upper[j])
            if uc != u[j]:
                outside = True
            t = (uc - lower[j]) * work[d + 3, j] - 1.0
            work[j, 0] = 1.0
            work[j, 1] = t
            for k in range(1, nmax):
                work[j, k + 1] = work[d + 1, k] * t * work[j, k] - work[d + 2, k] * work[j, k - 1]
        for i in range(T):
            term = coef[i]
            for j in range(d):
                term *= work[j, exponents[i, j]]
            value += term
    if not outside or mode == 1:
        return value
    for j in range(d):
        uc = min(max(u[j], lower[j]), upper[j])
        if uc == u[j]:
            continue
        # P'_k(t_j) by P'_{k+1} = P'_{k-1} + (2k+1) P_k, then the chain rule dt/du
        work[d, 0] = 0.0
        work[d, 1] = 1.0
        for k in range(1, nmax):
            work[d, k + 1] = work[d, k - 1] + (2 * k + 1) * work[j, k]
        g = 0.0
        for i in range(T):
            term = coef[i] * work[d, exponents[i, j]]
            for m in range(d):
                if m != j:
                    term *= work[m, exponents[i, m]]
            g += term
        value += g * work[d + 3, j] * (u[j] - uc)
    return value


def additive_table(exponents: np.ndarray, coef: np.ndarray) -> np.ndarray | None:
    """Coefficients of an additive model as a table (d, nmax + 1): entry ``[j, k]`` multiplies
    ``P_k(t_j)`` (the constant term in ``[0, 0]``), for :func:`lpr_additive_inside`; ``None``
    when a term couples two inputs (``interactions=True``)."""
    E = np.asarray(exponents, dtype=np.int64)
    if np.any(np.count_nonzero(E, axis=1) > 1):
        return None
    table = np.zeros((E.shape[1], int(E.max()) + 1))
    for e, c in zip(E, coef, strict=True):
        j = int(np.argmax(e)) if e.any() else 0
        table[j, e[j]] += c
    return table


@njit(cache=True, inline="always")
def additive_terms(table: np.ndarray, j: int) -> int:
    """Terms of input ``j`` that an additive sum over ``table`` (from :func:`additive_table`)
    evaluates: up to its last nonzero coefficient (at least ``P_0, P_1``, at most the table
    width). The exact zeros after it add nothing to a sum inside the box (finite ``P_k``), so
    stopping there gives the same bits."""
    k = table.shape[1] - 1
    while k > 1 and table[j, k] == 0.0:
        k -= 1
    return k + 1


@njit(cache=True, inline="always")
def lpr_additive_inside(
    u: np.ndarray, table: np.ndarray, lower: np.ndarray, work: np.ndarray
) -> float:
    """Value of an additive model at a point ``u`` (d,) inside its box, summing
    ``table[j, k]·P_k(t_j)`` along the Legendre recurrence (no work array written, no term
    loop); ``table`` from :func:`additive_table`, ``work`` from :func:`lpr_scratch` (its
    recurrence constants and scales are read). Equal to :func:`lpr_eval_into` up to rounding.
    """
    d = u.shape[0]
    n = table.shape[1]
    if d == 2:
        # the vehicle's static element: two interleaved recurrences
        t0 = (u[0] - lower[0]) * work[5, 0] - 1.0
        t1 = (u[1] - lower[1]) * work[5, 1] - 1.0
        s0 = table[0, 0] + table[1, 0]
        s1 = 0.0
        if n > 1:
            s0 += table[0, 1] * t0
            s1 += table[1, 1] * t1
        a0, a1, b0, b1 = 1.0, 1.0, t0, t1
        m0, m1 = additive_terms(table, 0), additive_terms(table, 1)
        mi = min(m0, m1)
        for k in range(1, mi - 1):
            ck = work[3, k]
            ek = work[4, k]
            n0 = ck * t0 * b0 - ek * a0
            n1 = ck * t1 * b1 - ek * a1
            s0 += table[0, k + 1] * n0
            s1 += table[1, k + 1] * n1
            a0, b0, a1, b1 = b0, n0, b1, n1
        for k in range(max(mi - 1, 1), m0 - 1):  # the longer chain on its own
            n0 = work[3, k] * t0 * b0 - work[4, k] * a0
            s0 += table[0, k + 1] * n0
            a0, b0 = b0, n0
        for k in range(max(mi - 1, 1), m1 - 1):
            n1 = work[3, k] * t1 * b1 - work[4, k] * a1
            s1 += table[1, k + 1] * n1
            a1, b1 = b1, n1
        return s0 + s1
    if d == 3:
        # the vehicle's memory element: three interleaved recurrences (independent chains)
        t0 = (u[0] - lower[0]) * work[6, 0] - 1.0
        t1 = (u[1] - lower[1]) * work[6, 1] - 1.0
        t2 = (u[2] - lower[2]) * work[6, 2] - 1.0
        s0 = table[0, 0] + table[1, 0] + table[2, 0]
        s1 = 0.0
        s2 = 0.0
        if n > 1:
            s0 += table[0, 1] * t0
            s1 += table[1, 1] * t1
            s2 += table[2, 1] * t2
        a0, a1, a2, b0, b1, b2 = 1.0, 1.0, 1.0, t0, t1, t2
        m0, m1, m2 = additive_terms(table, 0), additive_terms(table, 1), additive_terms(table, 2)
        mi = min(m0, m1, m2)
        for k in range(1, mi - 1):
            ck = work[4, k]
            ek = work[5, k]
            n0 = ck * t0 * b0 - ek * a0
            n1 = ck * t1 * b1 - ek * a1
            n2 = ck * t2 * b2 - ek * a2
            s0 += table[0, k + 1] * n0
            s1 += table[1, k + 1] * n1
            s2 += table[2, k + 1] * n2
            a0, b0, a1, b1, a2, b2 = b0, n0, b1, n1, b2, n2
        for k in range(max(mi - 1, 1), m0 - 1):  # the longer chains on their own
            n0 = work[4, k] * t0 * b0 - work[5, k] * a0
            s0 += table[0, k + 1] * n0
            a0, b0 = b0, n0
        for k in range(max(mi - 1, 1), m1 - 1):
            n1 = work[4, k] * t1 * b1 - work[5, k] * a1
            s1 += table[1, k + 1] * n1
            a1, b1 = b1, n1
        for k in range(max(mi - 1, 1), m2 - 1):
            n2 = work[4, k] * t2 * b2 - work[5, k] * a2
            s2 += table[2, k + 1] * n2
            a2, b2 = b2, n2
        return s0 + s1 + s2
    # one partial sum per input (the constants in the first), added in input order: the
    # arithmetic of the vertical lane kernel's blocks
    c0 = table[0, 0]
    for j in range(1, d):
        c0 = c0 + table[j, 0]
    value = 0.0
    for j in range(d):
        t = (u[j] - lower[j]) * work[d + 3, j] - 1.0
        a = 1.0
        b = t
        s = c0 if j == 0 else 0.0
        if n > 1:
            s += table[j, 1] * t
        for k in range(1, additive_terms(table, j) - 1):
            nb = work[d + 1, k] * t * b - work[d + 2, k] * a
            s += table[j, k + 1] * nb
            a = b
            b = nb
        value = s if j == 0 else value + s
    return value


@njit(cache=True)
def lpr_eval_batch(
    U: np.ndarray,
    exponents: np.ndarray,
    coef: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    mode: int,
) -> np.ndarray:
    """:func:`lpr_eval` for each row of ``U`` (n, d) → (n,), raising like it."""
    n = U.shape[0]
    out = np.empty(n)
    work = lpr_scratch(exponents, lower, upper)
    for r in range(n):
        value = lpr_eval_into(U[r], exponents, coef, lower, upper, mode, work)
        out[r] = _checked(U[r], value, lower, upper, mode)
    return out
