"""Kriging (Gaussian-process) regression with a constant or linear trend.

The model is ``F(u) = f(u)·β + Z(u)`` with ``Z`` a zero-mean Gaussian process of variance
``σ²`` and an anisotropic correlation ``k`` (Gaussian or Matérn-5/2, one length scale per
input). Inputs are scaled to the unit box ``[0, 1]^d`` of the training domain and outputs are
z-scored. The log length scales (and the log nugget when ``nugget="auto"``) maximise the
concentrated (profile) log-likelihood

``ln L = -n/2 ln σ̂² - 1/2 ln|R|``,  ``σ̂² = (y - Fβ̂)ᵀ R⁻¹ (y - Fβ̂) / n``,

with ``β̂`` the generalised least-squares trend; it is optimised with analytic gradients by
L-BFGS-B from a few deterministic Latin-hypercube starts.

:meth:`Kriging.kernel_arrays` gives the fitted model as plain arrays (:class:`KrigingArrays`)
and :func:`kriging_eval_into` predicts one point from them inside compiled (numba) vehicle
models, with the same extrapolation guard as :meth:`Kriging.predict`.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from typing import Any, ClassVar, NamedTuple

import numpy as np
from numba import njit
from scipy.linalg import LinAlgError, cholesky, qr, solve_triangular
from scipy.linalg.lapack import dpotri
from scipy.optimize import OptimizeResult, minimize
from threadpoolctl import threadpool_limits

from surrogates.models.base import SurrogateModel
from surrogates.models.checks import (
    ModelFieldError,
    choice,
    field,
    field_array,
    integer,
    non_negative,
    positive,
    random_seed,
    real,
    real_or_nan,
)
from surrogates.models.lpr import EXTRAPOLATION_MODES

KERNELS = ("gaussian", "matern52")
TRENDS = ("constant", "linear")

#: bounds of the length scales in units of the training-box width
LENGTH_SCALE_BOUNDS = (1e-3, 1e2)
#: bounds of the estimated nugget, relative to the process variance
NUGGET_BOUNDS = (1e-12, 1.0)
#: relative tolerance of L-BFGS-B on the log-likelihood (its change per iteration)
LIKELIHOOD_FTOL = 1e-6
#: default largest training set accepted by :meth:`Kriging.fit`: its fit time grows as n³
#: (measured in ``python -m benchmarks``, docs/benchmarks.md)
MAX_SAMPLES = 1000
#: first diagonal jitter of an interpolating model (nugget off)
JITTER = 1e-14

_SQRT5 = np.sqrt(5.0)
_CHUNK = 2048


class KrigingArrays(NamedTuple):
    """A fitted :class:`Kriging` as plain arrays for :func:`kriging_eval_into`."""

    xs: np.ndarray  #: float64 (n, d) training inputs in the unit box
    xs_ell: np.ndarray  #: float64 (n, d) ``xs / ℓ``
    ell: np.ndarray  #: float64 (d,) length scales in units of the box width
    weights: np.ndarray  #: float64 (n,) ``R⁻¹ (y − Fβ)`` (standardised units)
    beta: np.ndarray  #: float64 (p,) trend coefficients: 1 (constant) or 1 + d (linear)
    lo: np.ndarray  #: float64 (d,) lower corner of the training box, input units
    up: np.ndarray  #: float64 (d,) upper corner
    y_mean: float  #: output mean, output units
    y_std: float  #: output standard deviation, output units
    kernel: int  #: 0 Gaussian, 1 Matérn-5/2 (index in ``KERNELS``)
    mode: int  #: extrapolation mode (``surrogates.models.lpr.EXTRAPOLATION_MODES``)


def _serial_blas(fit: Callable[..., None]) -> Callable[..., None]:
    """Run ``fit`` with one BLAS thread: its hundreds of small factorisations (n ≤ a few
    thousand) each wake a thread pool otherwise, which on a loaded machine costs far more
    than the arithmetic (``python -m benchmarks``: a 201-point fit under load)."""

    @functools.wraps(fit)
    def serial(*args: Any, **kwargs: Any) -> None:
        with threadpool_limits(limits=1, user_api="blas"):
            fit(*args, **kwargs)

    return serial


class Kriging(SurrogateModel):
    """Ordinary (``trend="constant"``) or universal (``trend="linear"``) Kriging.

    Parameters
    ----------
    trend : {"constant", "linear"}
        Regression part ``f(u)``: a constant, or a constant plus one slope per input.
    kernel : {"gaussian", "matern52"}
        Anisotropic correlation function.
    nugget : "auto", float or None
        ``"auto"``: estimated with the length scales by maximum likelihood down to
        ``NUGGET_BOUNDS[0]``; the interpolating model (nugget off) is a candidate of the same
        search, so noise-free data keep the accuracy of an interpolating fit;
        a positive float: fixed, relative to the process variance; ``0`` or ``None``:
        interpolating, with a jitter of ``JITTER`` that grows ×10 whenever the
        Cholesky factorisation fails (the final value is kept in ``nugget_``).
    extrapolation : {"linear", "clip", "raise"}
        Policy for inputs outside the training box (see :mod:`surrogates.models.base`).
    n_starts : int
        Number of optimiser starts (the first from the centre of the search box, the others
        from a Latin hypercube).
    seed : int
        Seed of the Latin hypercube of starting points.
    max_samples : int or None
        Largest number of training samples ``fit`` accepts (each likelihood evaluation costs
        O(n³) time and O(d·n²) memory); ``None`` removes the check. To fit more points either
        raise it (``Kriging(max_samples=5000)``) or pick a space-filling subset with
        :func:`surrogates.select`.

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

    def __init__(
        self,
        trend: str = "constant",
        kernel: str = "gaussian",
        nugget: str | float | None = "auto",
        extrapolation: str = "linear",
        n_starts: int = 4,
        seed: int = 0,
        max_samples: int | None = MAX_SAMPLES,
    ) -> None:
        self.trend = trend
        self.kernel = kernel
        self.nugget = nugget
        self.extrapolation = extrapolation
        self.n_starts = n_starts
        self.seed = seed
        self.max_samples = max_samples

    # ------------------------------------------------------------------ public API
    def predict_variance(self, X: Any) -> np.ndarray:
        """Kriging predictive variance (mean-squared error) at ``X``, output units².

        Evaluated at the given points (no extrapolation policy): it tends to ``sigma2_``
        far from the data and is ≈ 0 at the training points of an interpolating model.

        Parameters
        ----------
        X : array-like (n, d)
            Inputs U of the paper (2-D, ``d = n_features_in_`` columns), input units.

        Returns
        -------
        ndarray (n,)
        """
        self._check_fitted()
        U = self._check_inputs(X)
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

    def kernel_arrays(self) -> KrigingArrays:
        """Plain arrays of the fitted model for the numba predictor :func:`kriging_eval_into`
        (copies: later changes to the model do not reach them)."""
        self._check_fitted()

        def arr(a: np.ndarray) -> np.ndarray:
            return np.ascontiguousarray(a, dtype=np.float64).copy()

        return KrigingArrays(
            arr(self._Xs),
            arr(self._Xs / self._ell),
            arr(self._ell),
            arr(self.weights_),
            arr(self.beta_),
            arr(self.lower_),
            arr(self.upper_),
            float(self.y_mean_),
            float(self.y_std_),
            KERNELS.index(self.kernel),
            EXTRAPOLATION_MODES[self.extrapolation],
        )

    # ------------------------------------------------------------- for the base class
    @_serial_blas
    def _fit(self, U: np.ndarray, V: np.ndarray) -> None:
        n, d = U.shape
        p = 1 + d if self.trend == "linear" else 1
        if n <= p:
            raise ValueError(
                f"X has {n} rows; Kriging with trend={self.trend!r} needs more than {p}"
            )
        if self.max_samples is not None and n > self.max_samples:
            raise ValueError(
                f"Kriging.fit got {n} samples, more than max_samples={self.max_samples} "
                f"(every likelihood evaluation costs O(n³) time and O(d·n²) memory); pass "
                f"Kriging(max_samples={n}) or max_samples=None to proceed, or fit on a "
                f"space-filling subset from surrogates.select"
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

        def search(estimate: bool, fixed: float, starts: list[np.ndarray]) -> OptimizeResult:
            bounds = [np.log(LENGTH_SCALE_BOUNDS)] * d + [np.log(NUGGET_BOUNDS)] * estimate
            best = None
            for q0 in starts:
                res = minimize(
                    _neg_log_likelihood,
                    q0,
                    args=(D2, ys, F, self.kernel, estimate, fixed),
                    jac=True,
                    method="L-BFGS-B",
                    bounds=bounds,
                    options={"ftol": LIKELIHOOD_FTOL},
                )
                if best is None or res.fun < best.fun:
                    best = res
            assert best is not None  # n_starts >= 1
            return best

        best = search(auto, 0.0 if auto else self._fixed_nugget(), self._starts(d, auto))
        nug = float(np.exp(best.x[d])) if auto else self._fixed_nugget()
        if auto:
            # noise-free data: the likelihood rises as the nugget falls, and L-BFGS-B stops
            # on or near the lower bound with length scales that are too short. There the
            # interpolating model (jitter JITTER, grown x10 while the Cholesky factorisation
            # fails), searched from the estimate's length scales, is kept when its
            # likelihood is higher.
            if nug < 1e3 * NUGGET_BOUNDS[0]:
                interp = search(False, JITTER, [best.x[:d]])
                if interp.fun < best.fun:
                    best, nug = interp, JITTER
        q = best.x
        width = self.upper_ - self.lower_
        self.theta_ = np.exp(q[:d]) * width
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
        self._kernel_arrays = self.kernel_arrays()

    def _predict_inside(self, U: np.ndarray) -> np.ndarray:
        """Mean prediction (n,) by the compiled predictor the vehicle kernels run."""
        out = np.empty(U.shape[0])
        _mean_batch(np.ascontiguousarray(U), self._arrays(), out, np.empty((0, U.shape[1])))
        return out

    def _gradient_inside(self, U: np.ndarray) -> np.ndarray:
        """Analytic gradient of the mean prediction (n, d), output units per input unit."""
        G = np.empty(U.shape)
        _mean_batch(np.ascontiguousarray(U), self._arrays(), np.empty(U.shape[0]), G)
        return G

    def _arrays(self) -> KrigingArrays:
        """:meth:`kernel_arrays`, made at fit and at load (``predict`` changes no attribute)."""
        arrays: KrigingArrays = self._kernel_arrays
        return arrays

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
        d_in = self.n_features_in_

        def get(key: str) -> Any:
            return field(d, key, "model.state")

        X = field_array(get("X"), "model.state.X", (None, d_in))
        n = X.shape[0]
        p = 1 + d_in if self.trend == "linear" else 1
        if n <= p:
            raise ModelFieldError(f"model.state.X has {n} rows, Kriging needs more than {p}")
        if self.max_samples is not None and n > self.max_samples:
            raise ModelFieldError(
                f"model.state.X has {n} rows, more than model.params.max_samples={self.max_samples}"
            )
        self.theta_ = field_array(get("theta"), "model.state.theta", (d_in,), low=0, strict=True)
        self.nugget_ = non_negative(get("nugget"), "model.state.nugget")
        self.beta_ = field_array(get("beta"), "model.state.beta", (p,))
        self.sigma2_ = non_negative(get("sigma2"), "model.state.sigma2")
        self.weights_ = field_array(get("weights"), "model.state.weights", (n,))
        self.X_ = X
        self.y_ = field_array(get("y"), "model.state.y", (n,))
        self.y_mean_ = real(get("y_mean"), "model.state.y_mean")
        self.y_std_ = positive(get("y_std"), "model.state.y_std")
        self.log_likelihood_ = (
            real_or_nan(get("log_likelihood"), "model.state.log_likelihood")
            if "log_likelihood" in d
            else float("nan")
        )
        self._ell = self.theta_ / (self.upper_ - self.lower_)
        self._Xs = self._scale(self.X_)
        K, _ = _correlation(self._Xs, self._Xs, self._ell, self.kernel)
        try:
            self._L = cholesky(K + self.nugget_ * np.eye(n), lower=True, check_finite=False)
        except LinAlgError:
            raise ModelFieldError(
                "model.state.theta / model.state.nugget give a correlation matrix that is "
                "not positive definite"
            ) from None
        self._Ft = solve_triangular(
            self._L, _trend_matrix(self._Xs, self.trend), lower=True, check_finite=False
        )
        self._Rq = qr(self._Ft, mode="economic", check_finite=False)[1]
        self._kernel_arrays = self.kernel_arrays()

    # ------------------------------------------------------------------ helpers
    def _check_params(self) -> None:
        super()._check_params()
        choice(self.trend, "trend", TRENDS)
        choice(self.kernel, "kernel", KERNELS)
        if self.nugget != "auto":
            self._fixed_nugget()
        integer(self.n_starts, "n_starts", 1, 1000)
        integer(self.seed, "seed", 0)
        if self.max_samples is not None:
            integer(self.max_samples, "max_samples", 2)

    def _fixed_nugget(self) -> float:
        """The fixed nugget, or the starting jitter when the nugget is off."""
        nug = self.nugget
        if nug is None:
            return JITTER
        if isinstance(nug, str):
            raise ModelFieldError(f"nugget must be 'auto', a number >= 0 or None, got {nug!r}")
        value = non_negative(nug, "nugget")
        return value if value > 0 else JITTER

    def _scale(self, U: np.ndarray) -> np.ndarray:
        return (U - self.lower_) / (self.upper_ - self.lower_)

    def _starts(self, d: int, auto: bool) -> list[np.ndarray]:
        """Deterministic starting points (log space): the centre and a Latin hypercube."""
        m = d + int(auto)
        lo = np.array([np.log(0.05)] * d + ([np.log(1e-8)] if auto else []))
        hi = np.array([np.log(2.0)] * d + ([np.log(1e-2)] if auto else []))
        rng = np.random.default_rng(random_seed(self.seed, "seed"))
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
    Rl = dpotri(L, lower=1)[0]  # lower triangle of R⁻¹; the upper one is L's, zero
    Rinv = Rl + Rl.T
    np.fill_diagonal(Rinv, np.diag(Rl))
    W = np.outer(alpha, alpha) / sigma2 - Rinv
    grad = -0.5 * (D2 @ (W * g).ravel()) / ell2
    if auto:
        grad = np.append(grad, -0.5 * nug * np.trace(W))
    return nll, grad


def kriging_scratch(d: int) -> np.ndarray:
    """Work array of :func:`kriging_eval_into` for ``d`` inputs, float64 (3, d)."""
    return np.empty((3, d))


@njit(cache=True, error_model="numpy", inline="always")
def _mean_at(k: KrigingArrays, work: np.ndarray, grad: bool) -> float:
    """Mean at the unit-box point ``work[1, :d]`` (output units); with ``grad`` also its
    gradient (output units per input unit) into ``work[2, :d]``."""
    d = k.lo.shape[0]
    n = k.weights.shape[0]
    for j in range(d):
        work[2, j] = 0.0
    acc = 0.0
    for i in range(n):
        s = 0.0
        for j in range(d):
            z = work[1, j] / k.ell[j] - k.xs_ell[i, j]
            s += z * z
        if k.kernel == 0:
            r = math.exp(-0.5 * s)
            g = r
        else:
            rr = 2.23606797749979 * math.sqrt(s)  # √5 · distance
            e = math.exp(-rr)
            r = (1.0 + rr + rr * rr / 3.0) * e
            g = (5.0 / 3.0) * (1.0 + rr) * e
        acc += r * k.weights[i]
        if grad:
            gw = g * k.weights[i]
            for j in range(d):
                work[2, j] += gw * (work[1, j] - k.xs[i, j])
    linear = k.beta.shape[0] > 1
    trend = k.beta[0]
    if linear:
        for j in range(d):
            trend += work[1, j] * k.beta[j + 1]
    if grad:
        for j in range(d):
            dm = -work[2, j] / (k.ell[j] * k.ell[j])
            if linear:
                dm += k.beta[j + 1]
            work[2, j] = k.y_std * dm / (k.up[j] - k.lo[j])
    return k.y_mean + k.y_std * (trend + acc)


@njit(cache=True, error_model="numpy", inline="always")
def kriging_eval_into(u: np.ndarray, k: KrigingArrays, work: np.ndarray) -> float:
    """Mean prediction of a fitted :class:`Kriging` at one point ``u`` (d,), input units.

    The same compiled arithmetic as :meth:`Kriging.predict`: inside the box the trend plus
    the correlation-weighted sum over the training points; outside, the value at the clipped
    point, extended with the analytic gradient there for mode 0 (``"linear"``) or held for
    mode 1 (``"clip"``). Mode 2 (``"raise"``) is treated like 0: the caller honours it (tests
    the box itself) and checks the result (±inf when a linear extension overflows).

    ``k`` comes from :meth:`Kriging.kernel_arrays` (or is any named tuple with the fields of
    :class:`KrigingArrays`); ``work`` is float64 with at least 3 rows
    of ``d`` (:func:`kriging_scratch`, or any larger array such as the vertical kernels'
    ``lpr_scratch``), overwritten, so one work array serves one thread. Costs O(n·d) for n
    training points; allocates nothing.
    """
    d = u.shape[0]
    outside = False
    for j in range(d):
        uc = min(max(u[j], k.lo[j]), k.up[j])
        if uc != u[j]:
            outside = True
        work[0, j] = uc
        work[1, j] = (uc - k.lo[j]) / (k.up[j] - k.lo[j])
    grad = outside and k.mode != 1
    value = _mean_at(k, work, grad)
    if not grad:
        return value
    ext = 0.0
    for j in range(d):
        ext += work[2, j] * (u[j] - work[0, j])
    return value + ext


@njit(cache=True, error_model="numpy")
def _mean_batch(U: np.ndarray, k: KrigingArrays, out: np.ndarray, G: np.ndarray) -> None:
    """Mean ``out`` (m,) at the rows of ``U`` (m, d) inside the box, and the gradient ``G``
    (m, d) unless ``G`` has no rows."""
    d = U.shape[1]
    grad = G.shape[0] > 0
    work = np.empty((3, d))
    for m in range(U.shape[0]):
        for j in range(d):
            work[1, j] = (U[m, j] - k.lo[j]) / (k.up[j] - k.lo[j])
        out[m] = _mean_at(k, work, grad)
        if grad:
            for j in range(d):
                G[m, j] = work[2, j]
