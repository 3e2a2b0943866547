"""Passive (physically consistent) Legendre regression: fitted slopes never negative.

A suspension element ``F(δ, δ̇)`` is passive when its tangent stiffness ``∂F/∂δ`` and its
damping ``∂F/∂δ̇`` are non-negative. :class:`PassiveLegendreRegression` fits the decoupled
(additive) Legendre form of :mod:`surrogates.models.lpr`, ``F = c_0 + Σ_j f_j(u_j)``, by least
squares subject to ``f_j'(u_j) ≥ 0`` on a dense grid of each monotone input:

* inside the box: the constrained least-squares problem ``min ‖A c − V‖`` s.t. ``G c ≥ 0``
  (``G`` the slopes of every term on the grid) is turned into a least-distance problem by a
  QR factorisation of ``A`` and solved exactly by non-negative least squares (Lawson &
  Hanson 1974, *Solving Least Squares Problems*, ch. 23); the grid (Chebyshev–Lobatto points,
  endpoints included, dense where high-degree polynomials oscillate); then the exact minima
  of each slope polynomial ``f_j'`` on the box (the ends and the real roots of ``f_j''``) are
  computed and those below zero are added as constraints, a few rounds at most, so the slope
  is non-negative everywhere in the box, not only on the grid;
* with fewer samples than terms the coefficients are not determined by the data: ``fit``
  warns (:class:`~surrogates.models.checks.UnderdeterminedFitWarning`, as
  :class:`~surrogates.models.lpr.LegendreRegression`) and solves the constrained problem with
  a small ridge (:data:`RIDGE`), the smallest-norm coefficients in its limit;
* outside the box: with the additive form, ``"linear"`` extrapolation continues each
  ``f_j`` with its slope at the boundary, which is a constrained grid point, so it is
  non-negative; ``"clip"`` continues with slope zero. Neither extends a negative slope.

:func:`passivity_check` measures the slopes of any fitted model (``predict`` with its
extrapolation policy, central differences) on a grid spanning a multiple of its box.
"""

from __future__ import annotations

from numbers import Integral
from typing import Any, ClassVar

import numpy as np
from numpy.polynomial import legendre
from scipy.linalg import qr, solve_triangular
from scipy.optimize import nnls

from surrogates.models.base import SurrogateModel
from surrogates.models.checks import ModelFieldError, legendre_degree, underdetermined_fit
from surrogates.models.lpr import (
    LegendreRegression,
    design_matrix,
    legendre_derivative,
    legendre_table,
)

#: rounds of adding the violated minima of the slopes as constraints
MAX_REFINE_ROUNDS = 10
#: constrained slopes are kept above this fraction of the output range per unit of the mapped
#: input (so that the round-off of the solver cannot leave a slope slightly negative)
SLOPE_MARGIN = 1e-6
#: ridge of a fit with fewer samples than terms, as a fraction of the largest singular value of
#: the column-scaled design matrix (:func:`_ridge_factor`)
RIDGE = 1e-4
#: a loaded element's slope may fall below 0 by this fraction of its largest possible slope
#: (round-off of a file written by another machine), no more
PASSIVITY_TOLERANCE = 1e-9


class PassiveLegendreRegression(LegendreRegression):
    """Additive Legendre regression with non-negative slopes in the monotone inputs.

    Parameters
    ----------
    degree
        One int for every input or a tuple with one degree per input.
    extrapolation
        ``"linear"`` (slope at the boundary, non-negative), ``"clip"`` or ``"raise"``.
    grid_size
        Constraint points per monotone input (Chebyshev–Lobatto points on the box).
    monotone
        ``True`` (every input non-decreasing) or one bool per input; inputs marked
        ``False`` are fitted without a slope constraint.

    Attributes
    ----------
    coef_, exponents_, n_terms_, cond_
        As :class:`~surrogates.models.lpr.LegendreRegression` (always ``interactions=False``).
    min_slope_ : ndarray (d,)
        Smallest slope of each input on the box (exact minimum of the slope polynomial),
        output units per input unit (``nan`` for unconstrained inputs).
    n_constraints_ : int
        Grid points constrained in the final solve.
    """

    kind: ClassVar[str] = "lpr_passive"
    interactions = False  # additive form only (fixed, not a parameter)

    def __init__(
        self,
        degree: int | tuple[int, ...] = 5,
        extrapolation: str = "linear",
        grid_size: int = 201,
        monotone: bool | tuple[bool, ...] = True,
    ) -> None:
        self.degree = degree
        self.extrapolation = extrapolation
        self.grid_size = grid_size
        self.monotone = monotone

    # ------------------------------------------------------------------ fitting
    def _validate(self, d: int) -> tuple[np.ndarray, tuple[bool, ...]]:
        """Check the hyperparameters for ``d`` inputs; returns (exponents, monotone flags)."""
        E = LegendreRegression(degree=legendre_degree(self.degree)).make_exponents(d)
        gs = self.grid_size
        if isinstance(gs, bool) or not isinstance(gs, Integral) or gs < 2:
            raise ValueError(f"grid_size must be an integer >= 2, got {gs!r}")
        mono = self.monotone
        if isinstance(mono, (bool, np.bool_)):
            return E, (bool(mono),) * d
        if (
            isinstance(mono, (tuple, list))
            and len(mono) == d
            and all(isinstance(m, (bool, np.bool_)) for m in mono)
        ):
            return E, tuple(bool(m) for m in mono)
        raise ValueError(f"monotone must be True/False or {d} bools (one per input), got {mono!r}")

    def _fit(self, U: np.ndarray, V: np.ndarray) -> None:
        n, d = U.shape
        E, mono = self._validate(d)
        T = E.shape[0]
        if n < T:
            underdetermined_fit(n, T, f"degree={self.degree!r}")
        A = design_matrix(self._map(U), E)
        norms = np.linalg.norm(A, axis=0)
        if n >= T:
            Q, R = qr(A / norms, mode="economic")
            s = np.linalg.svd(R, compute_uv=False)
            if rank_deficient(s):
                raise ValueError(
                    f"degree={self.degree!r} is too high for the data: the design matrix is "
                    f"rank deficient (too few distinct values in some column of X)"
                )
            f = Q.T @ V
            cond = float(s[0] / s[-1])
        else:  # a column that vanishes on every sample gets the coefficient 0
            norms = np.where(norms > 0.0, norms, 1.0)
            R, f, cond = _ridge_factor(A / norms, V)
        margin = SLOPE_MARGIN * float(np.ptp(V))
        coef_scaled, minima, n_constraints = passive_coefficients(
            R, f, E, norms, mono, self.grid_size, margin
        )
        self.coef_ = coef_scaled / norms
        self.exponents_ = E
        self.n_terms_ = T
        self.cond_ = cond
        self.n_constraints_ = n_constraints
        dt_du = 2.0 / (self.upper_ - self.lower_)
        self.min_slope_ = np.array(
            [minima[j][1].min() * dt_du[j] if j in minima else np.nan for j in range(d)]
        )

    # -------------------------------------------------------------- persistence
    def _set_state(self, d: dict[str, Any]) -> None:
        """Read the state and check what fit guarantees: ``grid_size`` and ``monotone`` fit
        the inputs, and every monotone input's slope is non-negative on the box (a file
        edited into an active element is refused, naming the input)."""
        super()._set_state(d)
        try:
            _, mono = self._validate(self.n_features_in_)
        except ValueError as exc:
            raise ModelFieldError(f"model.params.{exc}") from None
        dt_du = 2.0 / (self.upper_ - self.lower_)
        min_slope = np.full(self.n_features_in_, np.nan)
        for j in (i for i, m in enumerate(mono) if m):
            _, slope = _slope_minima(self.coef_, self.exponents_, j)
            own = (self.exponents_[:, j] > 0) & (
                self.exponents_.sum(axis=1) == self.exponents_[:, j]
            )
            k = self.exponents_[own, j]
            scale = float(np.sum(np.abs(self.coef_[own]) * k * (k + 1) / 2))  # bounds |f_j'|
            if slope.min() < -PASSIVITY_TOLERANCE * scale:
                raise ModelFieldError(
                    f"model.state.coef: the slope of input {j} reaches "
                    f"{slope.min() * dt_du[j]:.6g} per input unit on the training box; a "
                    f"passive element (monotone={self.monotone!r}) needs it >= 0"
                )
            min_slope[j] = slope.min() * dt_du[j]
        self.min_slope_ = min_slope


def _ridge_factor(As: np.ndarray, V: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Triangular factor ``R`` (T, T), right-hand side ``f`` and condition number of an
    under-determined fit (``As`` (n, T), n < T, the column-scaled design matrix): the QR of
    ``[As; λ I]`` with ``λ = RIDGE · s_max(As)``, so that :func:`passive_coefficients`
    minimises ``‖As c − V‖² + λ² ‖c‖²`` under the slope constraints (the least-squares
    coefficients of smallest norm in the limit of a small ``λ``). The condition number is
    that of the rank-``r`` part of ``As``, ``s_1 / s_r``."""
    n, T = As.shape
    s = np.linalg.svd(As, compute_uv=False)
    rank = max(int(np.sum(s > s[0] * max(n, T) * np.finfo(float).eps)), 1)
    Q, R = qr(np.vstack([As, RIDGE * s[0] * np.eye(T)]), mode="economic")
    f = Q.T @ np.concatenate([V, np.zeros(T)])
    return R, f, float(s[0] / s[rank - 1])


def rank_deficient(s: np.ndarray) -> bool:
    """Whether the singular values ``s`` (descending) of the column-scaled design matrix are
    too spread for the passive fit: ``s_min <= s_max · T · eps`` for ``T`` terms."""
    return bool(s[-1] <= s[0] * s.size * np.finfo(float).eps)


def passive_coefficients(
    R: np.ndarray,
    f: np.ndarray,
    E: np.ndarray,
    norms: np.ndarray,
    mono: tuple[bool, ...],
    grid_size: int,
    margin: float,
) -> tuple[np.ndarray, dict[int, tuple[np.ndarray, np.ndarray]], int]:
    """The constrained solve of :meth:`PassiveLegendreRegression.fit` from a factorisation.

    Parameters
    ----------
    R, f : triangular factor (T, T) of the column-scaled design matrix ``A / norms = Q R``
        and ``f = Qᵀ V`` (any factor with ``‖A c / norms − V‖² = ‖R c − f‖² + const`` gives
        the same minimiser).
    E : exponents (T, d) of the additive terms. norms : column norms (T,) of ``A``.
    mono : whether each input is constrained. grid_size : constraint points per input.
    margin : smallest slope kept on the constrained points, output units per mapped unit.

    Returns
    -------
    (coef_scaled, minima, n_constraints) : coefficients of the scaled columns (T,), the
    slope minima ``{j: (t, slope)}`` of each constrained input at the last round (mapped
    units, :func:`_slope_minima`) and the number of constrained points in the final solve.
    """
    d = E.shape[1]
    k = np.arange(grid_size)
    grid = -np.cos(np.pi * k / (grid_size - 1))  # Chebyshev–Lobatto, ends included
    points = [grid if m else np.empty(0) for m in mono]
    for _ in range(MAX_REFINE_ROUNDS):
        coef_scaled = _lsi(R, f, _slope_rows(points, E) / norms, margin)
        minima = {j: _slope_minima(coef_scaled / norms, E, j) for j in range(d) if mono[j]}
        bad = {j for j, (_, slope) in minima.items() if slope.min() < 0.0}
        if not bad:
            break
        for j in bad:
            t_min, slope = minima[j]
            points[j] = np.concatenate([points[j], t_min[slope < 0.5 * margin]])
    return coef_scaled, minima, int(sum(p.size for p in points))


def _slope_minima(coef: np.ndarray, E: np.ndarray, j: int) -> tuple[np.ndarray, np.ndarray]:
    """Candidate minima of the slope ``f_j'(t)`` on [−1, 1] (the ends and the real roots of
    ``f_j''``) and the slopes there, in mapped units; ``coef`` of the additive terms ``E``."""
    own = np.all(np.delete(E, j, axis=1) == 0, axis=1) & (E[:, j] > 0)
    series = np.zeros(int(E[:, j].max()) + 1)
    series[E[own, j]] = coef[own]
    d1 = legendre.legder(series)
    roots = legendre.legroots(legendre.legder(series, 2)) if series.size > 2 else np.empty(0)
    roots = roots[np.isreal(roots)].real
    t = np.concatenate([[-1.0, 1.0], roots[(roots > -1.0) & (roots < 1.0)]])
    return t, legendre.legval(t, d1)


def _slope_rows(points: list[np.ndarray], E: np.ndarray) -> np.ndarray:
    """Rows ``∂(term)/∂t_j`` at ``points[j]`` (mapped units), stacked over inputs j → (m, T)."""
    nmax = int(E.max())
    rows = []
    for j, t in enumerate(points):
        if t.size == 0:
            continue
        dP = legendre_derivative(legendre_table(t, max(nmax, 1)))
        own = np.all(np.delete(E, j, axis=1) == 0, axis=1) & (E[:, j] > 0)
        block = np.zeros((t.size, E.shape[0]))
        block[:, own] = dP[:, E[own, j]]
        rows.append(block)
    if not rows:
        return np.zeros((0, E.shape[0]))
    return np.vstack(rows)


def _lsi(R: np.ndarray, f: np.ndarray, G: np.ndarray, margin: float) -> np.ndarray:
    """``argmin ‖R c − f‖`` subject to ``G c ≥ margin`` (``R`` upper triangular, invertible).

    With ``w = R c − f`` the problem is the least-distance programme ``min ‖w‖`` s.t.
    ``H w ≥ h``, ``H = G R⁻¹``, ``h = margin − H f``, solved by NNLS of
    ``[Hᵀ; hᵀ] u ≈ e_{T+1}`` (Lawson & Hanson, ch. 23). The programme is feasible whenever
    every constrained row has a non-constant term, as the additive Legendre rows do.
    """
    c_free = solve_triangular(R, f)
    if G.shape[0] == 0 or np.all(G @ c_free >= margin):
        return c_free
    H = solve_triangular(R, G.T, trans="T").T  # G R⁻¹
    h = margin - H @ f
    # scaling rows and the whole right-hand side leaves the feasible set unchanged and
    # keeps the NNLS well conditioned
    rows = np.linalg.norm(H, axis=1)
    H, h = H / rows[:, None], h / rows
    alpha = max(float(np.max(np.abs(h))), np.finfo(float).tiny)
    M = np.vstack([H.T, h[None, :] / alpha])
    e = np.zeros(M.shape[0])
    e[-1] = 1.0
    u, _ = nnls(M, e, maxiter=50 * M.shape[1])
    r = M @ u - e
    w = -alpha * r[:-1] / r[-1]
    return solve_triangular(R, w + f)


def passivity_check(
    model: SurrogateModel, scale: float = 3.0, n: int = 301
) -> dict[str, np.ndarray | float]:
    """Slopes of a fitted model on a grid spanning ``scale`` × its training box.

    The grid (``n`` points per input, ``n**d`` in all) is centred on the box; slopes are
    central differences of :meth:`~surrogates.models.base.SurrogateModel.predict` (the
    model's extrapolation policy applies) with a step of 1e-6 of the box width. The model's
    ``n_out_of_domain_`` counter is left as it was.

    Returns
    -------
    dict
        ``min_slope`` (d,) the smallest slope per input (output units per input unit),
        ``argmin`` (d, d) the grid point of each, ``negative_fraction`` (d,) the share of grid
        points with a negative slope, ``slopes`` (n**d, d) and ``points`` (n**d, d).
    """
    if not (np.isfinite(scale) and scale > 0):
        raise ValueError(f"scale must be a positive number, got {scale!r}")
    if isinstance(n, bool) or not isinstance(n, Integral) or n < 2:
        raise ValueError(f"n must be an integer >= 2, got {n!r}")
    lower, upper = model.domain_
    centre, half = 0.5 * (lower + upper), 0.5 * scale * (upper - lower)
    axes = [np.linspace(c - h, c + h, n) for c, h in zip(centre, half, strict=True)]
    P = np.stack([g.ravel() for g in np.meshgrid(*axes, indexing="ij")], axis=1)
    count = model.n_out_of_domain_
    slopes = np.empty_like(P)
    for j in range(P.shape[1]):
        h = 1e-6 * (upper[j] - lower[j])
        Pp, Pm = P.copy(), P.copy()
        Pp[:, j] += h
        Pm[:, j] -= h
        slopes[:, j] = (model.predict(Pp) - model.predict(Pm)) / (2.0 * h)
    model.n_out_of_domain_ = count
    idx = np.argmin(slopes, axis=0)
    return {
        "min_slope": slopes[idx, np.arange(P.shape[1])],
        "argmin": P[idx],
        "negative_fraction": np.mean(slopes < 0.0, axis=0),
        "slopes": slopes,
        "points": P,
    }
