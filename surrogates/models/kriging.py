"""Kriging (Gaussian-process) regression with a constant or linear trend.

The model is ``F(u) = f(u)·β + Z(u)`` with ``Z`` a zero-mean Gaussian process of variance
``σ²`` and an anisotropic correlation ``k`` (Gaussian or Matérn-5/2, one length scale per
input). Inputs are scaled to the unit box ``[0, 1]^d`` of the training domain and outputs are
z-scored. The log length scales (and the log nugget when ``nugget="auto"``) maximise the
concentrated (profile) log-likelihood

``ln L = -n/2 ln σ̂² - 1/2 ln|R|``,  ``σ̂² = (y - Fβ̂)ᵀ R⁻¹ (y - Fβ̂) / n``,

with ``β̂`` the generalised least-squares trend; it is optimised with analytic gradients by
L-BFGS-B from a few deterministic Latin-hypercube starts.
"""

from __future__ import annotations

from numbers import Real
from typing import Any, ClassVar

import numpy as np
from scipy.linalg import LinAlgError, cholesky, qr, solve_triangular
from scipy.linalg.lapack import dpotri
from scipy.optimize import minimize

from surrogates.models.base import SurrogateModel, as_inputs

KERNELS = ("gaussian", "matern52")
TRENDS = ("constant", "linear")

#: bounds of the length scales in units of the training-box width
LENGTH_SCALE_BOUNDS = (1e-3, 1e2)
#: bounds of the estimated nugget, relative to the process variance
NUGGET_BOUNDS = (1e-8, 1.0)
#: first diagonal jitter of an interpolating model (nugget off)
JITTER = 1e-14

_SQRT5 = np.sqrt(5.0)
_CHUNK = 2048


class Kriging(SurrogateModel):
    """Ordinary (``trend="constant"``) or universal (``trend="linear"``) Kriging.

    Parameters
    ----------
    trend : {"constant", "linear"}
        Regression part ``f(u)``: a constant, or a constant plus one slope per input.
    kernel : {"gaussian", "matern52"}
        Anisotropic correlation function.
    nugget : "auto", float or None
        ``"auto"``: estimated with the length scales (floor ``NUGGET_BOUNDS[0]``);
        a positive float: fixed, relative to the process variance; ``0`` or ``None``:
        interpolating, with a jitter of ``JITTER`` that grows ×10 whenever the
        Cholesky factorisation fails (the final value is kept in ``nugget_``).
    extrapolation : {"linear", "clip", "raise"}
        Policy for inputs outside the training box (see :mod:`surrogates.models.base`).

    Attributes
    ----------
    theta_ : ndarray (d,)
        Length scales in input units.
    nugget_ : float
        Diagonal added to the correlation matrix (estimated, fixed or final jitter).
    beta_ : ndarray (p,)
        Trend coefficients in standardised units (unit-box inputs, z-scored outputs).
    sigma2_ : float
        Process variance in output units².
    weights_ : ndarray (n,)
        ``R⁻¹ (y - Fβ)`` in standardised units.
    X_, y_ : ndarray
        Training inputs (n, d) and outputs (n,).
    log_likelihood_ : float
        Maximised concentrated log-likelihood (standardised units, constants dropped).
    """

    kind: ClassVar[str] = "kriging"
    #: number of optimiser starts (the first from the centre of the search box)
    n_starts: ClassVar[int] = 4
    #: seed of the Latin hypercube of starting points
    seed: ClassVar[int] = 0

    def __init__(
        self,
        trend: str = "constant",
        kernel: str = "gaussian",
        nugget: str | float | None = "auto",
        extrapolation: str = "linear",
    ) -> None:
        super().__init__(extrapolation=extrapolation)
        self.trend = trend
        self.kernel = kernel
        self.nugget = nugget
        self._check_params()

    # ------------------------------------------------------------------ public API
    def predict_variance(self, U: Any) -> np.ndarray:
        """Kriging predictive variance (mean-squared error) at ``U`` (n, d) → (n,), output units².

        Evaluated at the given points (no extrapolation policy): it tends to ``sigma2_``
        far from the data and is ≈ 0 at the training points of an interpolating model.
        """
        self._check_fitted()
        U = as_inputs(U)
        if U.shape[1] != self.n_features_in_:
            raise ValueError(
                f"U has {U.shape[1]} columns, the model was fitted on {self.n_features_in_}"
            )
        out = np.empty(U.shape[0])
        for s in range(0, U.shape[0], _CHUNK):
            xs = self._scale(U[s : s + _CHUNK])
            r, _ = _correlation(xs, self._Xs, self._ell, self.kernel)
            v = solve_triangular(self._L, r.T, lower=True, check_finite=False)
            u = self._Ft.T @ v - _trend_matrix(xs, self.trend).T
            w = solve_triangular(self._Rq, u, trans="T", check_finite=False)
            mse = 1.0 - np.sum(v * v, axis=0) + np.sum(w * w, axis=0)
            out[s : s + _CHUNK] = self.sigma2_ * np.maximum(mse, 0.0)
        return out

    # ------------------------------------------------------------- for the base class
    def _fit(self, U: np.ndarray, V: np.ndarray) -> None:
        self._check_params()
        n, d = U.shape
        p = 1 + d if self.trend == "linear" else 1
        if n <= p:
            raise ValueError(
                f"U has {n} rows; Kriging with trend={self.trend!r} needs more than {p}"
            )
        self.X_ = U.copy()
        self.y_ = V.copy()
        self.y_mean_ = float(V.mean())
        self.y_std_ = float(V.std()) or 1.0
        Xs = self._scale(U)
        ys = (V - self.y_mean_) / self.y_std_
        F = _trend_matrix(Xs, self.trend)
        D2 = (Xs[:, None, :] - Xs[None, :, :]) ** 2
        D2 = np.ascontiguousarray(np.moveaxis(D2, 2, 0)).reshape(d, n * n)
        auto = self.nugget == "auto"
        fixed = 0.0 if auto else self._fixed_nugget()

        lo = [np.log(LENGTH_SCALE_BOUNDS[0])] * d + ([np.log(NUGGET_BOUNDS[0])] if auto else [])
        hi = [np.log(LENGTH_SCALE_BOUNDS[1])] * d + ([np.log(NUGGET_BOUNDS[1])] if auto else [])
        starts = self._starts(d, auto)

        def objective(q: np.ndarray) -> tuple[float, np.ndarray]:
            return _neg_log_likelihood(q, D2, ys, F, self.kernel, auto, fixed)

        best = None
        for q0 in starts:
            res = minimize(
                objective, q0, jac=True, method="L-BFGS-B", bounds=list(zip(lo, hi, strict=True))
            )
            if best is None or res.fun < best.fun:
                best = res
        q = best.x
        width = self.upper_ - self.lower_
        self.theta_ = np.exp(q[:d]) * width
        nug = float(np.exp(q[d])) if auto else fixed
        self._ell = self.theta_ / width
        K, _ = _correlation(Xs, Xs, self._ell, self.kernel)
        L, self.nugget_ = _cholesky(K, nug)
        Ft = solve_triangular(L, F, lower=True, check_finite=False)
        yt = solve_triangular(L, ys, lower=True, check_finite=False)
        Qq, Rq = qr(Ft, mode="economic", check_finite=False)
        self.beta_ = solve_triangular(Rq, Qq.T @ yt, check_finite=False)
        res_t = yt - Ft @ self.beta_
        self.sigma2_ = float(res_t @ res_t / n) * self.y_std_**2
        self.weights_ = solve_triangular(L, res_t, lower=True, trans="T", check_finite=False)
        self.log_likelihood_ = -float(best.fun)
        self._Xs, self._L, self._Ft, self._Rq = Xs, L, Ft, Rq

    def _predict_inside(self, U: np.ndarray) -> np.ndarray:
        out = np.empty(U.shape[0])
        for s in range(0, U.shape[0], _CHUNK):
            xs = self._scale(U[s : s + _CHUNK])
            r, _ = _correlation(xs, self._Xs, self._ell, self.kernel)
            m = _trend_matrix(xs, self.trend) @ self.beta_ + r @ self.weights_
            out[s : s + _CHUNK] = self.y_mean_ + self.y_std_ * m
        return out

    def _gradient_inside(self, U: np.ndarray) -> np.ndarray:
        """Analytic gradient of the mean prediction (n, d), output units per input unit."""
        width = self.upper_ - self.lower_
        G = np.empty_like(U)
        for s in range(0, U.shape[0], _CHUNK):
            xs = self._scale(U[s : s + _CHUNK])
            _, g = _correlation(xs, self._Xs, self._ell, self.kernel)
            diff = xs[:, None, :] - self._Xs[None, :, :]
            dm = -np.einsum("mn,mnk->mk", g * self.weights_, diff) / self._ell**2
            if self.trend == "linear":
                dm += self.beta_[1:]
            G[s : s + _CHUNK] = self.y_std_ * dm / width
        return G

    def _state(self) -> dict[str, Any]:
        return {
            "theta": self.theta_,
            "nugget": self.nugget_,
            "beta": self.beta_,
            "sigma2": self.sigma2_,
            "weights": self.weights_,
            "X": self.X_,
            "y": self.y_,
            "y_mean": self.y_mean_,
            "y_std": self.y_std_,
            "log_likelihood": self.log_likelihood_,
        }

    def _set_state(self, d: dict[str, Any]) -> None:
        for key in ("theta", "nugget", "beta", "sigma2", "weights", "X", "y", "y_mean", "y_std"):
            if key not in d:
                raise ValueError(f"Kriging state is missing the field {key!r}")
        self.theta_ = np.asarray(d["theta"], dtype=float)
        self.nugget_ = float(d["nugget"])
        self.beta_ = np.asarray(d["beta"], dtype=float)
        self.sigma2_ = float(d["sigma2"])
        self.weights_ = np.asarray(d["weights"], dtype=float)
        self.X_ = np.asarray(d["X"], dtype=float).reshape(-1, self.n_features_in_)
        self.y_ = np.asarray(d["y"], dtype=float)
        self.y_mean_ = float(d["y_mean"])
        self.y_std_ = float(d["y_std"])
        self.log_likelihood_ = float(d.get("log_likelihood", np.nan))
        self._ell = self.theta_ / (self.upper_ - self.lower_)
        self._Xs = self._scale(self.X_)
        K, _ = _correlation(self._Xs, self._Xs, self._ell, self.kernel)
        self._L = cholesky(K + self.nugget_ * np.eye(K.shape[0]), lower=True, check_finite=False)
        self._Ft = solve_triangular(
            self._L, _trend_matrix(self._Xs, self.trend), lower=True, check_finite=False
        )
        self._Rq = qr(self._Ft, mode="economic", check_finite=False)[1]

    # ------------------------------------------------------------------ helpers
    def _check_params(self) -> None:
        if self.trend not in TRENDS:
            raise ValueError(f"trend must be one of {TRENDS}, got {self.trend!r}")
        if self.kernel not in KERNELS:
            raise ValueError(f"kernel must be one of {KERNELS}, got {self.kernel!r}")
        if self.nugget != "auto":
            self._fixed_nugget()

    def _fixed_nugget(self) -> float:
        """The fixed nugget, or the starting jitter when the nugget is off."""
        nug = self.nugget
        if nug is None:
            return JITTER
        if isinstance(nug, bool) or not isinstance(nug, Real):
            raise ValueError(f"nugget must be 'auto', a number >= 0 or None, got {nug!r}")
        if not np.isfinite(nug) or nug < 0:
            raise ValueError(f"nugget must be finite and >= 0, got {nug!r}")
        return float(nug) if nug > 0 else JITTER

    def _scale(self, U: np.ndarray) -> np.ndarray:
        return (U - self.lower_) / (self.upper_ - self.lower_)

    def _starts(self, d: int, auto: bool) -> list[np.ndarray]:
        """Deterministic starting points (log space): the centre and a Latin hypercube."""
        m = d + int(auto)
        lo = np.array([np.log(0.05)] * d + ([np.log(1e-8)] if auto else []))
        hi = np.array([np.log(2.0)] * d + ([np.log(1e-2)] if auto else []))
        rng = np.random.default_rng(self.seed)
        k = self.n_starts - 1
        lhs = (np.argsort(rng.random((k, m)), axis=0) + rng.random((k, m))) / max(k, 1)
        return [0.5 * (lo + hi)] + [lo + (hi - lo) * row for row in lhs]


def _trend_matrix(xs: np.ndarray, trend: str) -> np.ndarray:
    """Regression matrix ``f(x)`` (m, p) at unit-box inputs ``xs`` (m, d)."""
    ones = np.ones((xs.shape[0], 1))
    return np.hstack([ones, xs]) if trend == "linear" else ones


def _correlation(
    xa: np.ndarray, xb: np.ndarray, ell: np.ndarray, kernel: str
) -> tuple[np.ndarray, np.ndarray]:
    """Correlation ``k`` (m, n) between unit-box points and the factor ``g`` with
    ``∂k/∂ln ℓ_j = g · Δ_j²/ℓ_j²`` and ``∂k/∂x_j = -g · Δ_j/ℓ_j²``."""
    z = xa[:, None, :] / ell - xb[None, :, :] / ell
    s = np.einsum("mnk,mnk->mn", z, z)
    if kernel == "gaussian":
        k = np.exp(-0.5 * s)
        return k, k
    r = _SQRT5 * np.sqrt(s)
    e = np.exp(-r)
    return (1.0 + r + r * r / 3.0) * e, (5.0 / 3.0) * (1.0 + r) * e


def _cholesky(K: np.ndarray, nugget: float) -> tuple[np.ndarray, float]:
    """Lower Cholesky factor of ``K + nugget·I``; the nugget grows ×10 until it succeeds."""
    eye = np.eye(K.shape[0])
    while True:
        try:
            return cholesky(K + nugget * eye, lower=True, check_finite=False), nugget
        except LinAlgError:
            if nugget >= 1.0:
                raise
            nugget *= 10.0


def _neg_log_likelihood(
    q: np.ndarray,
    D2: np.ndarray,
    y: np.ndarray,
    F: np.ndarray,
    kernel: str,
    auto: bool,
    fixed_nugget: float,
) -> tuple[float, np.ndarray]:
    """Negative concentrated log-likelihood and its gradient w.r.t. ``q = ln ℓ (, ln ν)``.

    ``D2`` (d, n²) holds the squared unit-box differences of the training points.
    """
    d = D2.shape[0]
    n = y.size
    ell2 = np.exp(2.0 * q[:d])
    s = (D2 / ell2[:, None]).sum(axis=0).reshape(n, n)
    if kernel == "gaussian":
        K = np.exp(-0.5 * s)
        g = K
    else:
        r = _SQRT5 * np.sqrt(s)
        e = np.exp(-r)
        K = (1.0 + r + r * r / 3.0) * e
        g = (5.0 / 3.0) * (1.0 + r) * e
    nug = float(np.exp(q[d])) if auto else fixed_nugget
    L, nug = _cholesky(K, nug)
    Ft = solve_triangular(L, F, lower=True, check_finite=False)
    yt = solve_triangular(L, y, lower=True, check_finite=False)
    beta = np.linalg.lstsq(Ft, yt, rcond=None)[0]
    res = yt - Ft @ beta
    sigma2 = max(float(res @ res) / n, 1e-300)
    nll = 0.5 * n * np.log(sigma2) + float(np.sum(np.log(np.diag(L))))
    alpha = solve_triangular(L, res, lower=True, trans="T", check_finite=False)
    Rinv = dpotri(L, lower=1)[0]
    Rinv = np.tril(Rinv) + np.tril(Rinv, -1).T
    W = np.outer(alpha, alpha) / sigma2 - Rinv
    grad = -0.5 * (D2 @ (W * g).ravel()) / ell2
    if auto:
        grad = np.append(grad, -0.5 * nug * np.trace(W))
    return nll, grad
