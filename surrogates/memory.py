"""Surrogate elements with memory: the Maxwell-state feature form.

A static map ``F̂(δ, δ̇)`` cannot represent an element whose force depends on its history,
e.g. a damper in series with a bush stiffness (Maxwell element). The ``"maxwell"`` feature
form adds one internal state, a first-order filtered deflection ``s``::

    ṡ = (δ − s)/τ,        inputs u = (δ, δ̇, ζ),   ζ = δ − s,   F ≈ F̂(u)

``ζ`` obeys ``ζ̇ = δ̇ − ζ/τ``: it is ``τ`` times the first-order low-passed velocity, equal to
``τ·δ̇`` below ``1/(2πτ)`` and to the high-passed deflection above. For a linear spring ``k``
in series with a linear damper ``c`` and ``τ = c/k``, ``s`` is exactly the damper's
displacement and ``F = k·ζ``. The paper's memoryless form is ``"static"``, ``u = (δ, δ̇)``.

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

from surrogates.features import _time, _vector
from surrogates.models import SurrogateModel
from surrogates.models.checks import ModelFieldError
from surrogates.selection import SelectionResult, select_kfold

#: documented feature forms: name → input names
FEATURE_FORMS = {"static": ("delta", "delta_dot"), "maxwell": ("delta", "delta_dot", "zeta")}
#: known physics a vehicle kernel may add to the fitted element (``"bump_stop"``: the
#: vehicle's bump-stop law beyond the free travel, the element fitted on ``F − F_bump``)
KNOWN_PHYSICS = ("bump_stop",)


class ElementForm(NamedTuple):
    """Feature form of a fitted element (the ``features`` block of a model file)."""

    form: str  #: a key of :data:`FEATURE_FORMS`
    tau: float | None  #: Maxwell time constant, s (``None`` for ``"static"``)
    known_physics: tuple[str, ...]  #: entries of :data:`KNOWN_PHYSICS`


def element_form(
    features: Mapping[str, Any] | None, n_inputs: int | None = None, source: str = "model"
) -> ElementForm:
    """Validated :class:`ElementForm` of a ``features`` mapping (``None`` or no ``form``
    key: the static form, as in schema version 1 files).

    Raises :class:`~surrogates.models.checks.ModelFieldError` naming ``features.form``,
    ``features.tau`` or ``features.known_physics`` (prefixed by ``source``); ``n_inputs``,
    when given, must be 3 for ``"maxwell"`` (``"static"`` is any memoryless map; the vertical
    kernels take it with the 2 inputs δ, δ̇).
    """
    features = features or {}
    form = features.get("form", "static")
    if not isinstance(form, str) or form not in FEATURE_FORMS:
        raise ModelFieldError(
            f"{source}: field 'features.form' must be one of {sorted(FEATURE_FORMS)}, got {form!r}"
        )
    tau = features.get("tau")
    if form == "maxwell":
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
    if form == "maxwell" and n_inputs is not None and n_inputs != len(FEATURE_FORMS[form]):
        raise ModelFieldError(
            f"{source}: feature form {form!r} has {len(FEATURE_FORMS[form])} inputs "
            f"{FEATURE_FORMS[form]}, the model has {n_inputs}"
        )
    return ElementForm(form, tau, tuple(known))


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
    t = _time(t)
    delta = _vector(delta, "delta", t.size)
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
    delta: Any, delta_dot: Any, t: Any, tau: float | None = None, form: str = "maxwell"
) -> np.ndarray:
    """Inputs of a suspension element of feature form ``form`` from its time histories.

    Parameters
    ----------
    delta, delta_dot : deflection (m) and deflection rate (m/s), (n,).
    t : sample times (n,), s.
    tau : Maxwell time constant, s (required for ``"maxwell"``, ignored for ``"static"``).
    form : a key of :data:`FEATURE_FORMS`.

    Returns
    -------
    U : (n, 2) ``(δ, δ̇)`` or (n, 3) ``(δ, δ̇, ζ)`` with ζ from :func:`maxwell_state` (relaxed
    start); discard the first few ``τ`` of a record that does not start at rest.
    """
    if form not in FEATURE_FORMS:
        raise ValueError(f"form must be one of {sorted(FEATURE_FORMS)}, got {form!r}")
    t = _time(t)
    delta = _vector(delta, "delta", t.size)
    delta_dot = _vector(delta_dot, "delta_dot", t.size)
    if form == "static":
        return np.column_stack([delta, delta_dot])
    if tau is None:
        raise ValueError("tau is required for the 'maxwell' feature form")
    return np.column_stack([delta, delta_dot, maxwell_state(delta, t, tau)])


@dataclass
class TauSelection:
    """k-fold scores of every ``τ``: ``table`` rows ``{"tau", "degree", "rms", "nrms"}``
    (the best degree of each ``τ``); ``best`` the ``(τ, degree)`` with the lowest ``rms``."""

    table: list[dict[str, Any]] = field(default_factory=list)
    best: tuple[float, Any] = (np.nan, None)
    results: list[SelectionResult] = field(default_factory=list)

    def best_result(self) -> SelectionResult:
        """The degree scores of the best ``τ``."""
        return self.results[[r["tau"] for r in self.table].index(self.best[0])]

    def format(self) -> str:
        """The score table as aligned text; a last line flags a degree at the search cap."""
        lines = [f"{'tau [ms]':>9} {'degree':>10} {'rms':>12} {'rel. rms':>10}"]
        for row in self.table:
            mark = "  <- best" if (row["tau"], row["degree"]) == self.best else ""
            lines.append(
                f"{1e3 * row['tau']:9.3g} {row['degree']!s:>10} {row['rms']:12.4g} "
                f"{row['nrms']:10.3g}{mark}"
            )
        cap = self.best_result().at_cap() if self.results else []
        if cap:
            lines.append(
                f"warning: the winner sits at the largest candidate degree of input(s) {cap}; "
                "widen the search range (--max-degree on the command line, degrees= in Python)"
            )
        return "\n".join(lines)


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
    V = _vector(V, "V")
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
