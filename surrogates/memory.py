"""Surrogate elements with memory: the Maxwell-state feature form.

A static map ``F̂(δ, δ̇)`` cannot represent an element whose force depends on its history,
e.g. a damper in series with a bush stiffness (Maxwell element). The ``"maxwell"`` feature
form adds one internal state, a first-order filtered deflection ``s``::

    ṡ = (δ − s)/τ,        inputs u = (δ, δ̇, ζ),   ζ = δ − s,   F ≈ F̂(u)

``ζ`` obeys ``ζ̇ = δ̇ − ζ/τ``: it is ``τ`` times the first-order low-passed velocity, equal to
``τ·δ̇`` below ``1/(2πτ)`` and to the high-passed deflection above. For a linear spring ``k``
in series with a linear damper ``c`` and ``τ = c/k``, ``s`` is exactly the damper's
displacement and ``F = k·ζ``. The paper's memoryless form is ``"static"``, ``u = (δ, δ̇)``.

A ``"maxwell"`` element may carry a nonlinear **relaxation law** instead of the linear one:
``ṡ = g(δ − s)`` with ``g`` a monotone piecewise-linear function of ``ζ`` (knots ``zeta``,
values ``rate``, continued linearly beyond the end knots; ``g(0) = 0``). With
``g(ζ) = v_d(k·ζ)`` it is exactly a stiffness ``k`` in series with a nonlinear dashpot of
force–velocity law ``v_d`` (e.g. a damper with direction-dependent slopes and a blow-off
knee: :func:`two_slope_relaxation`); the linear law ``g(ζ) = ζ/τ`` is the plain form.
The law is fitted with the element (:func:`fit_relaxation`); its ``tau`` is the shortest
time constant of the law (its steepest segment), which bounds the integration step.

The ``"maxwell_product"`` form has the same state and a fourth input, the product
``δ·ζ``::

    inputs u = (δ, δ̇, ζ, δ·ζ),        F ≈ F̂(u)

An additive polynomial in ``(δ, δ̇, ζ)`` gives the memory branch a stiffness ``∂F/∂ζ`` that
does not depend on ``δ``. In an air spring it does: the gas in the bellows (volume
``V_b = V_b0 − A·δ``, area ``A``, polytropic index ``n``, pressure ``p0``) pushes with
``F ≈ n·p0·A²·ζ/V_b``, stiffer in compression. The product input carries the first term of
that coupling while the map stays additive (one polynomial per input, the slopes of
``δ, δ̇, ζ`` constrained as before, the product's not).

Training features are built from sampled time histories by :func:`maxwell_state`, the exact
solution of the ζ equation for a deflection linear between samples (first-order hold);
inside a vehicle kernel ``s`` is integrated with the other states (``ṡ = (δ − s)/τ``,
``s = δ`` at a static start). ``τ`` is a hyperparameter chosen like the degree by k-fold
cross-validation (:func:`select_tau`, built on :func:`surrogates.selection.select_kfold`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np
from numba import njit
from scipy.optimize import minimize

from surrogates.features import finite_vector, time_base
from surrogates.models import SurrogateModel
from surrogates.models.checks import ModelFieldError
from surrogates.selection import SelectionResult, select_kfold

#: documented feature forms: name → input names
FEATURE_FORMS = {
    "static": ("delta", "delta_dot"),
    "maxwell": ("delta", "delta_dot", "zeta"),
    "maxwell_product": ("delta", "delta_dot", "zeta", "delta_zeta"),
}
#: the feature forms with the Maxwell state ``s`` (a time constant ``tau``)
MEMORY_FORMS = ("maxwell", "maxwell_product")
#: known physics a vehicle kernel may add to the fitted element (``"bump_stop"``: the
#: vehicle's bump-stop law beyond the free travel, the element fitted on ``F − F_bump``)
KNOWN_PHYSICS = ("bump_stop",)


class ElementForm(NamedTuple):
    """Feature form of a fitted element (the ``features`` block of a model file)."""

    form: str  #: a key of :data:`FEATURE_FORMS`
    tau: float | None  #: Maxwell time constant, s (``None`` for ``"static"``)
    known_physics: tuple[str, ...]  #: entries of :data:`KNOWN_PHYSICS`
    #: nonlinear relaxation law ``(zeta knots m, rates m/s)`` of a ``"maxwell"`` element;
    #: ``None``: the linear law ``ṡ = (δ − s)/τ``
    relaxation: tuple[np.ndarray, np.ndarray] | None = None


def element_form(
    features: Mapping[str, Any] | None, n_inputs: int | None = None, source: str = "model"
) -> ElementForm:
    """Validated :class:`ElementForm` of a ``features`` mapping (``None`` or no ``form``
    key: the static form, as in schema version 1 files).

    Raises :class:`~surrogates.models.checks.ModelFieldError` naming ``features.form``,
    ``features.tau`` or ``features.known_physics`` (prefixed by ``source``); ``n_inputs``,
    when given, must be 3 for ``"maxwell"`` and 4 for ``"maxwell_product"`` (``"static"`` is
    any memoryless map; the vertical kernels take it with the 2 inputs δ, δ̇).
    """
    features = features or {}
    form = features.get("form", "static")
    if not isinstance(form, str) or form not in FEATURE_FORMS:
        raise ModelFieldError(
            f"{source}: field 'features.form' must be one of {sorted(FEATURE_FORMS)}, got {form!r}"
        )
    tau = features.get("tau")
    if form in MEMORY_FORMS:
        try:
            tau = _tau(tau)
        except ValueError as exc:
            raise ModelFieldError(f"{source}: field 'features.tau': {exc}") from None
    elif tau is not None:
        raise ModelFieldError(f"{source}: field 'features.tau' must be null for form 'static'")
    known = features.get("known_physics", [])
    if not isinstance(known, list | tuple) or not all(k in KNOWN_PHYSICS for k in known):
        raise ModelFieldError(
            f"{source}: field 'features.known_physics' must list entries of "
            f"{list(KNOWN_PHYSICS)}, got {known!r}"
        )
    relaxation = None
    if features.get("relaxation") is not None:
        if form != "maxwell":
            raise ModelFieldError(
                f"{source}: field 'features.relaxation' needs form 'maxwell', got {form!r}"
            )
        try:
            relaxation = relaxation_law(features["relaxation"])
        except ValueError as exc:
            raise ModelFieldError(f"{source}: field 'features.relaxation': {exc}") from None
    if form in MEMORY_FORMS and n_inputs is not None and n_inputs != len(FEATURE_FORMS[form]):
        raise ModelFieldError(
            f"{source}: feature form {form!r} has {len(FEATURE_FORMS[form])} inputs "
            f"{FEATURE_FORMS[form]}, the model has {n_inputs}"
        )
    return ElementForm(form, tau, tuple(known), relaxation)


def relaxation_law(law: Any) -> tuple[np.ndarray, np.ndarray]:
    """Validated relaxation law ``(zeta, rate)`` of a mapping ``{"zeta": [...], "rate":
    [...]}`` (or a pair): at least 3 knots, knots and rates finite and strictly increasing
    (a monotone law: the state relaxes towards ``δ``), ``0`` among the knots with rate 0.

    Raises ``ValueError`` naming ``zeta`` or ``rate``.
    """
    if isinstance(law, Mapping):
        if set(law) != {"zeta", "rate"}:
            raise ValueError(f"must hold exactly the keys 'zeta' and 'rate', got {sorted(law)}")
        z, r = law["zeta"], law["rate"]
    elif (
        isinstance(law, list | tuple)
        and len(law) == 2
        and all(isinstance(x, list | tuple | np.ndarray) for x in law)
    ):
        z, r = law
    else:
        raise ValueError(
            f"must be a mapping {{'zeta': [m, ...], 'rate': [m/s, ...]}} (the knots and their "
            f"rates, at least 3 each) or a pair (zeta, rate) of such lists, got {law!r}"
        )
    for name, v in (("zeta", z), ("rate", r)):
        if not isinstance(v, list | tuple | np.ndarray):
            raise ValueError(f"{name} must be a list of numbers (at least 3), got {v!r}")
    try:
        z = np.array(z, dtype=np.float64)
        r = np.array(r, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError("zeta and rate must be lists of numbers") from None
    if z.ndim != 1 or z.size < 3 or r.shape != z.shape:
        raise ValueError(
            f"zeta and rate must be lists of the same length >= 3, got {z.shape}, {r.shape}"
        )
    for name, v in (("zeta", z), ("rate", r)):
        if not (np.all(np.isfinite(v)) and np.all(np.diff(v) > 0)):
            raise ValueError(f"{name} must be finite and strictly increasing, got {v.tolist()}")
    zero = np.flatnonzero(z == 0.0)
    if zero.size != 1 or r[zero[0]] != 0.0:
        raise ValueError("zeta must contain 0 with rate 0 (the state rests at s = δ)")
    return z, r


def law_document(law: tuple[np.ndarray, np.ndarray]) -> dict[str, list[float]]:
    """The ``features.relaxation`` mapping of a law ``(zeta, rate)``."""
    return {"zeta": [float(v) for v in law[0]], "rate": [float(v) for v in law[1]]}


def shortest_time_constant(law: tuple[np.ndarray, np.ndarray]) -> float:
    """Shortest time constant ``min Δζ/Δg`` of a relaxation law's segments, s."""
    z, r = law
    return float(np.min(np.diff(z) / np.diff(r)))


@njit(cache=True, error_model="numpy")
def relaxation_rate(z: float, knots: np.ndarray, rates: np.ndarray) -> float:
    """``g(ζ)`` of a piecewise-linear relaxation law (m/s), linear beyond the end knots."""
    n = knots.shape[0]
    j = 0
    while j < n - 2 and z > knots[j + 1]:
        j += 1
    return rates[j] + (rates[j + 1] - rates[j]) * (z - knots[j]) / (knots[j + 1] - knots[j])


@njit(cache=True, error_model="numpy")
def _relaxed(delta: np.ndarray, h: np.ndarray, knots: np.ndarray, rates: np.ndarray) -> np.ndarray:
    zeta = np.zeros(delta.size)
    s = delta[0]
    for k in range(h.size):
        d0, d1, dt = delta[k], delta[k + 1], h[k]
        dm = 0.5 * (d0 + d1)
        k1 = relaxation_rate(d0 - s, knots, rates)
        k2 = relaxation_rate(dm - (s + 0.5 * dt * k1), knots, rates)
        k3 = relaxation_rate(dm - (s + 0.5 * dt * k2), knots, rates)
        k4 = relaxation_rate(d1 - (s + dt * k3), knots, rates)
        s = s + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        zeta[k + 1] = d1 - s
    return zeta


def relaxed_state(delta: Any, t: Any, law: Any) -> np.ndarray:
    """Internal input ``ζ = δ − s`` of a state with relaxation law ``ṡ = g(δ − s)`` along a
    sampled deflection: one classic RK4 step per sample interval, ``δ`` linear between the
    samples; relaxed start (``ζ = 0``).

    Parameters
    ----------
    delta : deflection (n,), m.  t : sample times (n,), s, strictly increasing.
    law : relaxation law (:func:`relaxation_law`).

    Returns
    -------
    zeta : (n,), m.
    """
    t = time_base(t)
    delta = finite_vector(delta, "delta", t.size)
    z, r = relaxation_law(law)
    return _relaxed(delta, np.diff(t), z, r)


def two_slope_relaxation(
    tau_c: float, tau_r: float, zeta_c: float, zeta_r: float, ratio: float
) -> tuple[np.ndarray, np.ndarray]:
    """Relaxation law of a stiffness in series with a two-slope dashpot: time constant
    ``tau_c`` (s) for ``ζ > 0`` (compression) and ``tau_r`` for ``ζ < 0`` up to the knees
    ``zeta_c``, ``−zeta_r`` (m), beyond them the rate grows ``1/ratio`` times faster
    (a damper's blow-off, ``0 < ratio``)."""
    zk = np.array([-2.0 * zeta_r, -zeta_r, 0.0, zeta_c, 2.0 * zeta_c])
    rk = np.array(
        [
            -(zeta_r + zeta_r / ratio) / tau_r,
            -zeta_r / tau_r,
            0.0,
            zeta_c / tau_c,
            (zeta_c + zeta_c / ratio) / tau_c,
        ]
    )
    return zk, rk


class RelaxationFit(NamedTuple):
    """Result of :func:`fit_relaxation`: the law, its parameters
    ``(tau_c, tau_r, zeta_c, zeta_r, ratio)`` (s, s, m, m, 1) and the fit's RMS residual (N)."""

    law: tuple[np.ndarray, np.ndarray]
    params: tuple[float, ...]
    rms: float


def _additive_design(
    U: np.ndarray, lo: np.ndarray, up: np.ndarray, degrees: Sequence[int]
) -> np.ndarray:
    cols = [np.ones((U.shape[0], 1))]
    for j, n in enumerate(degrees):
        t = 2.0 * (U[:, j] - lo[j]) / (up[j] - lo[j]) - 1.0
        cols.append(np.polynomial.legendre.legvander(t, n)[:, 1:])
    return np.hstack(cols)


def fit_relaxation(
    runs: Sequence[Mapping[str, Any]],
    degrees: Sequence[int] = (14, 14, 9),
    start: Sequence[float] = (8e-3, 8e-3, 1e-3, 1e-3, 0.5),
    max_evaluations: int = 400,
) -> RelaxationFit:
    """Fit a :func:`two_slope_relaxation` law to element data.

    For each candidate law the state ``ζ`` of every run is integrated
    (:func:`relaxed_state`) and an additive Legendre polynomial in ``(δ, δ̇, ζ)`` of
    ``degrees`` is fitted by least squares; Nelder–Mead (in log parameters, ``ratio ≤ 1``)
    minimises its RMS residual.

    Parameters
    ----------
    runs : mappings with ``t`` (s), ``delta`` (m), ``delta_dot`` (m/s) full histories, the
        sample indices ``rows`` used in the fit and ``force`` (N) at those rows.
    degrees : degrees of the inner additive polynomial in ``(δ, δ̇, ζ)``.
    start : initial ``(tau_c, tau_r, zeta_c, zeta_r, ratio)``.
    max_evaluations : Nelder–Mead budget.
    """
    V = np.concatenate([np.asarray(r["force"], float) for r in runs])
    fixed = [(np.asarray(r["delta"], float), np.diff(time_base(r["t"]))) for r in runs]
    base = np.concatenate([np.column_stack([r["delta"], r["delta_dot"]])[r["rows"]] for r in runs])

    def params(x: np.ndarray) -> tuple[float, ...]:
        p = np.exp(x)
        p[4] = min(p[4], 1.0)
        return tuple(float(v) for v in p)

    def residual(x: np.ndarray) -> float:
        z, r = two_slope_relaxation(*params(x))
        zeta = np.concatenate(
            [_relaxed(d, h, z, r)[run["rows"]] for (d, h), run in zip(fixed, runs, strict=True)]
        )
        U = np.column_stack([base, zeta])
        A = _additive_design(U, U.min(0), U.max(0), degrees)
        c, *_ = np.linalg.lstsq(A, V, rcond=None)
        return float(np.sqrt(np.mean((A @ c - V) ** 2)))

    res = minimize(
        residual,
        np.log(np.asarray(start, float)),
        method="Nelder-Mead",
        options={"maxfev": max_evaluations, "xatol": 1e-3, "fatol": 1e-3},
    )
    p = params(res.x)
    return RelaxationFit(two_slope_relaxation(*p), p, float(res.fun))


def _tau(tau: Any) -> float:
    ok = isinstance(tau, (int, float, np.integer, np.floating)) and not isinstance(tau, bool)
    if not (ok and np.isfinite(float(tau)) and float(tau) > 0):
        raise ValueError(f"tau must be a positive time constant in s, got {tau!r}")
    return float(tau)


def maxwell_state(delta: Any, t: Any, tau: float, zeta0: float = 0.0) -> np.ndarray:
    """Internal input ``ζ = δ − s`` of the Maxwell state along a sampled deflection.

    Solves ``ζ̇ = δ̇ − ζ/τ`` exactly for ``δ`` linear between samples:
    ``ζ_{k+1} = e^{−h/τ}·ζ_k + τ·(1 − e^{−h/τ})·(δ_{k+1} − δ_k)/h``, ``h = t_{k+1} − t_k``.

    Parameters
    ----------
    delta : deflection (n,), m.
    t : sample times (n,), s, strictly increasing.
    tau : filter time constant, s (> 0).
    zeta0 : ``ζ`` at ``t[0]``, m (0: the state starts relaxed, ``s = δ``).

    Returns
    -------
    zeta : (n,), m.
    """
    t = time_base(t)
    delta = finite_vector(delta, "delta", t.size)
    tau = _tau(tau)
    if not (np.isscalar(zeta0) and np.isfinite(zeta0)):
        raise ValueError(f"zeta0 must be a finite number in m, got {zeta0!r}")
    h = np.diff(t)
    a = np.exp(-h / tau)
    b = tau * (1.0 - a) * np.diff(delta) / h
    zeta = np.empty(t.size)
    zeta[0] = zeta0
    for k in range(h.size):
        zeta[k + 1] = a[k] * zeta[k] + b[k]
    return zeta


def memory_features(
    delta: Any,
    delta_dot: Any,
    t: Any,
    tau: float | None = None,
    form: str = "maxwell",
    relaxation: Any = None,
) -> np.ndarray:
    """Inputs of a suspension element of feature form ``form`` from its time histories.

    Parameters
    ----------
    delta, delta_dot : deflection (m) and deflection rate (m/s), (n,).
    t : sample times (n,), s.
    tau : Maxwell time constant, s (required for the :data:`MEMORY_FORMS`, ignored for
        ``"static"``).
    form : a key of :data:`FEATURE_FORMS`.
    relaxation : nonlinear relaxation law of the ``"maxwell"`` state (:func:`relaxation_law`;
        ``tau`` is then not used).

    Returns
    -------
    U : (n, 2) ``(δ, δ̇)``, (n, 3) ``(δ, δ̇, ζ)`` with ζ from :func:`maxwell_state` or
    :func:`relaxed_state` (relaxed start), or (n, 4) ``(δ, δ̇, ζ, δ·ζ)``; discard the first
    few ``τ`` of a record that does not start at rest.
    """
    if form not in FEATURE_FORMS:
        raise ValueError(f"form must be one of {sorted(FEATURE_FORMS)}, got {form!r}")
    t = time_base(t)
    delta = finite_vector(delta, "delta", t.size)
    delta_dot = finite_vector(delta_dot, "delta_dot", t.size)
    if form == "static":
        return np.column_stack([delta, delta_dot])
    if relaxation is not None:
        if form != "maxwell":
            raise ValueError(f"a relaxation law needs the 'maxwell' form, got {form!r}")
        return np.column_stack([delta, delta_dot, relaxed_state(delta, t, relaxation)])
    if tau is None:
        raise ValueError(f"tau is required for the {form!r} feature form")
    zeta = maxwell_state(delta, t, tau)
    if form == "maxwell_product":
        return np.column_stack([delta, delta_dot, zeta, delta * zeta])
    return np.column_stack([delta, delta_dot, zeta])


@dataclass
class TauSelection:
    """k-fold scores of every ``τ``: ``table`` rows ``{"tau", "degree", "rms", "nrms"}``
    (the best degree of each ``τ``, ascending ``τ``); ``best`` the ``(τ, degree)`` chosen
    (``τ`` ``None`` for a memoryless element, ``states == 0``).

    A data-driven choice (:func:`railgym.vehicles.memory_element.choose_memory_element`)
    also holds the ``search`` (:class:`~surrogates.tau_search.TauSearch`), the linear
    first guess ``guess`` (:class:`~surrogates.tau_search.LinearMemory`), the memoryless
    score ``static`` (``{"degree", "rms", "nrms"}``) with its degree scores
    ``static_result``, the coupled map's score ``coupled`` (``{"tau", "degree", "rms",
    "nrms"}``, a total degree) with its degree scores ``coupled_result``, the same of the map
    with the product input ``δ·ζ`` (``product``, ``product_result``), the number of memory
    ``states`` chosen, the ``decision`` in words and the ``warnings`` (a choice at the
    edge of a search range)."""

    table: list[dict[str, Any]] = field(default_factory=list)
    best: tuple[float | None, Any] = (np.nan, None)
    results: list[SelectionResult] = field(default_factory=list)
    search: Any = None
    guess: Any = None
    static: dict[str, Any] | None = None
    static_result: SelectionResult | None = None
    coupled: dict[str, Any] | None = None
    coupled_result: SelectionResult | None = None
    product: dict[str, Any] | None = None
    product_result: SelectionResult | None = None
    states: int = 1
    decision: str = ""
    warnings: list[str] = field(default_factory=list)

    def best_result(self) -> SelectionResult:
        """The degree scores of the chosen element (the best ``τ``, or the memoryless one)."""
        if self.states == 0 and self.static_result is not None:
            return self.static_result
        taus = [r["tau"] for r in self.table]
        p = self.product
        if p is not None and self.best == (p["tau"], p["degree"]):
            assert self.product_result is not None
            return self.product_result  # the map with the product input, at its own τ
        if self.best[0] not in taus and self.coupled_result is not None:
            return self.coupled_result  # the coupled map, at its own τ
        return self.results[taus.index(self.best[0])]

    def at_cap(self) -> list[int]:
        """Inputs whose chosen degree is the largest the search tried (``--max-degree``
        widens it): of the chosen additive map; with the product input, of the additive map
        it extends (inputs δ, δ̇, ζ; the product's degrees are fixed); none for a total
        degree."""
        if not isinstance(self.best[1], tuple):  # --max-degree does not set a total degree
            return []
        p = self.product
        if p is not None and self.best == (p["tau"], p["degree"]):
            return min(self.results, key=_best_rms).at_cap()
        return self.best_result().at_cap()

    def format(self) -> str:
        """The score table as aligned text, then the linear guess, the decision and the
        warnings; a last line flags a degree at the search cap."""
        lines = [f"{'tau [ms]':>9} {'degree':>10} {'rms':>12} {'rel. rms':>10}"]
        for row in self.table:
            mark = "  <- best" if (row["tau"], row["degree"]) == self.best else ""
            lines.append(
                f"{1e3 * row['tau']:9.3g} {row['degree']!s:>10} {row['rms']:12.4g} "
                f"{row['nrms']:10.3g}{mark}"
            )
        if self.static is not None:
            mark = "  <- best" if self.states == 0 else ""
            s = self.static
            lines.append(
                f"{'static':>9} {s['degree']!s:>10} {s['rms']:12.4g} {s['nrms']:10.3g}{mark}"
            )
        if self.coupled is not None:
            c = self.coupled
            mark = "  <- best" if self.best == (c["tau"], c["degree"]) else ""
            lines.append(
                f"{1e3 * c['tau']:9.3g} {'coupled ' + str(c['degree']):>10} {c['rms']:12.4g} "
                f"{c['nrms']:10.3g}{mark}"
            )
        if self.product is not None:
            p = self.product
            mark = "  <- best" if self.best == (p["tau"], p["degree"]) else ""
            lines.append(
                f"{1e3 * p['tau']:9.3g} {'product ' + str(p['degree']):>10} {p['rms']:12.4g} "
                f"{p['nrms']:10.3g}{mark}"
            )
        if self.guess is not None:
            g = self.guess
            f_peak, phi = g.loss_peak()
            lines.append(
                f"linear fit: tau {1e3 * g.tau:.3g} ms, k0 {g.k0:.4g} N/m, k1 {g.k1:.4g} N/m, "
                f"c {g.c:.4g} N s/m; loss-angle peak {phi:.1f} deg at {f_peak:.2g} Hz; "
                f"residual {g.rms:.4g} N (no memory: {g.rms_static:.4g} N)"
            )
        if self.decision:
            lines.append(self.decision)
        lines.extend(self.warnings)
        cap = self.at_cap()
        if cap:
            lines.append(
                f"warning: the winner sits at the largest candidate degree of input(s) {cap}; "
                "widen the search range (--max-degree on the command line, degrees= in Python)"
            )
        return "\n".join(lines)


def _best_rms(res: SelectionResult) -> float:
    """k-fold RMS of the winner of a degree search, N."""
    return float(next(r["rms"] for r in res.table if r["candidate"] == res.best))


def select_tau(
    make: Callable[[Any], SurrogateModel],
    degrees: Iterable[Any],
    taus: Sequence[float],
    delta: Any,
    delta_dot: Any,
    t: Any,
    V: Any,
    *,
    rows: Any = None,
    k: int = 5,
    seed: int | None = 0,
) -> TauSelection:
    """Choose the Maxwell time constant and the degree together by k-fold cross-validation.

    For each ``τ`` the features :func:`memory_features` of the whole record are built and
    :func:`surrogates.selection.select_kfold` scores every degree on the samples ``rows``.

    Parameters
    ----------
    make : degree → unfitted model (e.g. ``surrogates.selection.factory_for("lpr")``).
    degrees : candidate degrees.
    taus : candidate time constants, s.
    delta, delta_dot, t : time histories (n,) in m, m/s, s.
    V : element force (n,), N.
    rows : indices of the samples used for fitting and scoring (default all); leave out
        the first few ``τ`` of a record that does not start at rest.
    k, seed : folds and their shuffling seed.
    """
    taus = [_tau(x) for x in taus]
    if not taus:
        raise ValueError("taus is empty")
    degrees = list(degrees)
    V = finite_vector(V, "V")
    sel = np.arange(V.size) if rows is None else np.asarray(rows)
    out = TauSelection()
    for tau in taus:
        U = memory_features(delta, delta_dot, t, tau)
        res = select_kfold(make, degrees, U[sel], V[sel], k=k, seed=seed)
        row = next(r for r in res.table if r["candidate"] == res.best)
        out.table.append({"tau": tau, "degree": res.best, "rms": row["rms"], "nrms": row["nrms"]})
        out.results.append(res)
    best = min(out.table, key=lambda r: r["rms"])
    out.best = (best["tau"], best["degree"])
    return out
