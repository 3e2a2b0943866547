"""The Maxwell time constant the data ask for: where ``τ`` is searched (:class:`TauSearch`,
declared once for the ``--tau`` flag and the ``tau=`` parameter), a first guess from the
linear standard-linear-solid fit of the element's force (:func:`fit_linear_memory`) and
the bounded refinement of a cross-validation score in ``log τ`` (:func:`search_tau`).

The linear model of an element with one memory state is a spring ``k0``, a dashpot ``c``
and a spring ``k1`` in series with a dashpot of relaxation time ``τ`` (the standard linear
solid, plus a parallel dashpot), all in parallel::

    F ≈ F0 + k0·δ + c·δ̇ + k1·ζ,     ζ̇ = δ̇ − ζ/τ      (ζ = δ − s of :mod:`surrogates.memory`)

Its dynamic stiffness is ``K(ω) = k0 + iωc + k1·iωτ/(1 + iωτ)``: ``k0`` at ``ω → 0``,
``k∞ = k0 + k1`` (and the dashpot) at ``ω → ∞``. Without the dashpot the loss angle
``tan φ = k1·ωτ/(k0 + k∞·ω²τ²)`` peaks at ``ω* τ = √(k0/k∞)``, i.e.
``τ = √(k0/k∞)/(2π f*)`` with ``tan φ* = k1/(2√(k0·k∞))``. For fixed ``τ`` the model is linear
in ``F0, k0, c, k1``; :func:`fit_linear_memory` minimises its least-squares residual over
``log τ`` (bounded), which is that relation fitted to every frequency of the records.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any, NamedTuple

import numpy as np
from scipy.optimize import minimize_scalar

from surrogates.memory import maxwell_state

__all__ = [
    "DEFAULT_TAU_RANGE",
    "EDGE_TOLERANCE",
    "MEMORY_STATES",
    "LinearMemory",
    "TauSearch",
    "TauSearchResult",
    "fit_linear_memory",
    "memory_states",
    "search_tau",
    "tau_search",
]

#: default continuous search range of ``τ``, s
DEFAULT_TAU_RANGE = (2e-3, 1.0)
#: numbers of memory states an element may carry (0: memoryless, 1: one Maxwell state)
MEMORY_STATES = (0, 1)
#: a choice within this factor (in ``log τ``) of a search-range end is "at the edge"
EDGE_TOLERANCE = 0.05
#: ``log τ`` tolerance of the bounded refinement
XTOL = 0.03


class TauSearch(NamedTuple):
    """Where ``τ`` is searched (s): the continuous range ``lo … hi`` or, with ``values``,
    those candidates only (``lo``, ``hi`` their extremes)."""

    lo: float
    hi: float
    values: tuple[float, ...] | None = None

    def describe(self) -> str:
        """The search as one phrase (ms)."""
        if self.values is not None:
            return "values " + ", ".join(f"{1e3 * v:g}" for v in self.values) + " ms"
        return f"range {1e3 * self.lo:g}-{1e3 * self.hi:g} ms"


def tau_search(value: Any, name: str = "tau") -> TauSearch:
    """The :class:`TauSearch` of the ``--tau`` flag's values or the ``tau=`` parameter
    (``name`` is named in the error): ``None`` the default range :data:`DEFAULT_TAU_RANGE`;
    one number that ``τ``; two numbers ``LO HI`` a range (``LO < HI``); three or more the
    candidate values (a :class:`TauSearch` is returned as it is). Every value is a finite
    time constant in s, > 0.

    Raises ``ValueError`` naming ``name``.
    """
    if isinstance(value, TauSearch):
        return value
    if value is None:
        return TauSearch(*DEFAULT_TAU_RANGE)
    vals = [value] if isinstance(value, int | float | np.integer | np.floating) else value
    if isinstance(vals, str | bytes | Mapping) or not isinstance(vals, Sequence | np.ndarray):
        raise ValueError(
            f"{name} must be one time constant, a range LO HI or three or more values, in s; "
            f"got {value!r}"
        )
    out = []
    for v in vals:
        ok = isinstance(v, int | float | np.integer | np.floating) and not isinstance(v, bool)
        if not (ok and math.isfinite(float(v)) and float(v) > 0):
            raise ValueError(
                f"{name} values must be time constants in s, finite and > 0, got {v!r}"
            )
        out.append(float(v))
    if not out:
        raise ValueError(f"{name} needs one value, a range LO HI or three or more values")
    if len(out) == 2:
        if not out[0] < out[1]:
            raise ValueError(f"{name} LO HI: a range needs LO < HI, got {out[0]:g} {out[1]:g}")
        return TauSearch(out[0], out[1])
    if len(set(out)) != len(out):
        raise ValueError(f"{name} values must be distinct, got {out}")
    return TauSearch(min(out), max(out), tuple(sorted(out)))


def memory_states(value: Any, name: str = "memory_states") -> int | None:
    """The number of memory states of ``--memory-states`` / ``memory_states=``: ``None``
    (decided from the data) or an entry of :data:`MEMORY_STATES`. Raises ``ValueError``
    naming ``name`` (the vertical kernels carry at most one memory state)."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 0:
        raise ValueError(f"{name} must be a whole number of memory states (0 or 1), got {value!r}")
    if int(value) not in MEMORY_STATES:
        raise ValueError(
            f"{name} must be 0 (memoryless) or 1 (one Maxwell state), got {value}: the "
            "vehicle kernels carry at most one memory state per element"
        )
    return int(value)


class LinearMemory(NamedTuple):
    """The linear one-state model of :func:`fit_linear_memory` (SI): ``F0 + k0·δ + c·δ̇ +
    k1·ζ`` with ``ζ̇ = δ̇ − ζ/τ``; ``rms`` its residual (N), ``rms_static`` that of the best
    ``F0 + k·δ + c·δ̇`` (no memory)."""

    tau: float
    k0: float
    c: float
    k1: float
    rms: float
    rms_static: float

    def dynamic_stiffness(self, f: Any) -> np.ndarray:
        """Complex dynamic stiffness ``K`` (N/m) at the frequencies ``f`` (Hz)."""
        w = 2.0 * np.pi * np.asarray(f, float)
        iwt = 1j * w * self.tau
        return self.k0 + 1j * w * self.c + self.k1 * iwt / (1.0 + iwt)

    def loss_peak(self, band: tuple[float, float] = (0.1, 20.0)) -> tuple[float, float]:
        """Frequency (Hz) and value (deg) of the largest loss angle ``arg K`` in ``band``."""
        f = np.geomspace(band[0], band[1], 400)
        phi = np.degrees(np.angle(self.dynamic_stiffness(f)))
        j = int(np.argmax(phi))
        return float(f[j]), float(phi[j])


def _lstsq_rms(A: np.ndarray, V: np.ndarray) -> tuple[np.ndarray, float]:
    scale = np.maximum(np.abs(A).max(axis=0), 1e-300)
    c, *_ = np.linalg.lstsq(A / scale, V, rcond=None)
    c = c / scale
    return c, float(np.sqrt(np.mean((A @ c - V) ** 2)))


def fit_linear_memory(
    runs: Sequence[Mapping[str, Any]], lo: float, hi: float, n_grid: int = 25
) -> LinearMemory:
    """Least-squares fit of the linear one-state model (module docstring) to element data,
    ``τ`` in ``lo … hi`` (s): the residual on a log grid of ``n_grid`` values, then a bounded
    scalar minimisation in ``log τ`` around the best one.

    Parameters
    ----------
    runs : mappings with full histories ``t`` (s), ``delta`` (m), ``delta_dot`` (m/s), the
        sample indices ``rows`` fitted and ``force`` (N) at those rows.
    lo, hi : search range of ``τ``, s.
    """
    V = np.concatenate([np.asarray(r["force"], float) for r in runs])
    base = np.concatenate(
        [
            np.column_stack(
                [np.ones(len(r["rows"])), r["delta"][r["rows"]], r["delta_dot"][r["rows"]]]
            )
            for r in runs
        ]
    )

    def design(tau: float) -> np.ndarray:
        zeta = np.concatenate([maxwell_state(r["delta"], r["t"], tau)[r["rows"]] for r in runs])
        return np.column_stack([base, zeta])

    def rms(x: float) -> float:
        return _lstsq_rms(design(math.exp(x)), V)[1]

    grid = np.linspace(math.log(lo), math.log(hi), n_grid)
    scores = [rms(x) for x in grid]
    j = int(np.argmin(scores))
    a, b = grid[max(j - 1, 0)], grid[min(j + 1, n_grid - 1)]
    res = minimize_scalar(rms, bounds=(a, b), method="bounded", options={"xatol": 1e-3})
    x = float(res.x) if res.fun < scores[j] else float(grid[j])
    tau = math.exp(x)
    coef, err = _lstsq_rms(design(tau), V)
    _, err_static = _lstsq_rms(base, V)
    return LinearMemory(tau, float(coef[1]), float(coef[2]), float(coef[3]), err, err_static)


class TauSearchResult(NamedTuple):
    """Result of :func:`search_tau`: the best ``τ`` (s), every ``τ`` scored with its score
    (ascending ``τ``), and the end of the search range the best one sits at (``"lower"``,
    ``"upper"``) or ``None``."""

    best: float
    scores: list[tuple[float, float]]
    edge: str | None


def _edge(tau: float, lo: float, hi: float) -> str | None:
    if math.log(tau / lo) < EDGE_TOLERANCE:
        return "lower"
    if math.log(hi / tau) < EDGE_TOLERANCE:
        return "upper"
    return None


def search_tau(
    score: Callable[[float], float],
    search: TauSearch,
    guess: float | None = None,
    xtol: float = XTOL,
    max_brackets: int = 6,
) -> TauSearchResult:
    """Minimise ``score(τ)`` (e.g. a k-fold CV error) over ``search``: every candidate of
    ``search.values``; in a range, a bounded scalar minimisation in ``log τ`` on the bracket
    ``guess/3 … 3·guess`` (clipped to the range; ``guess`` default the range's geometric
    mean), re-centred on a bracket end that is not a range end (at most ``max_brackets``
    brackets). ``xtol``: tolerance in ``log τ``."""
    seen: dict[float, float] = {}

    def f(tau: float) -> float:
        if tau not in seen:
            seen[tau] = float(score(tau))
        return seen[tau]

    lo, hi = search.lo, search.hi
    if search.values is not None:
        for v in search.values:
            f(v)
        best = min(seen, key=seen.__getitem__)
        edge = _edge(best, lo, hi) if len(search.values) > 1 else None
        return TauSearchResult(best, sorted(seen.items()), edge)
    centre = math.sqrt(lo * hi) if guess is None else min(max(guess, lo), hi)
    for _ in range(max_brackets):
        a, b = math.log(max(lo, centre / 3.0)), math.log(min(hi, centre * 3.0))
        res = minimize_scalar(
            lambda x: f(math.exp(x)), bounds=(a, b), method="bounded", options={"xatol": xtol}
        )
        x = float(res.x)
        if x - a < 2 * xtol and a > math.log(lo) + 1e-12:
            centre = math.exp(a)
        elif b - x < 2 * xtol and b < math.log(hi) - 1e-12:
            centre = math.exp(b)
        else:
            break
    near = _edge(min(seen, key=seen.__getitem__), lo, hi)
    if near is not None:  # a minimum pushed to a range end: score the end itself
        f(lo if near == "lower" else hi)
    best = min(seen, key=seen.__getitem__)
    return TauSearchResult(best, sorted(seen.items()), _edge(best, lo, hi))
