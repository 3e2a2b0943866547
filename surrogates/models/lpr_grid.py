"""Additive Legendre model re-tabulated on a uniform grid: piecewise cubic Hermite.

Each 1-D series ``f_j(t) = Σ_k c_{j,k} P_k(t)`` of an additive model (the table of
:func:`~surrogates.models.lpr.additive_table`) is replaced inside the training box by the
cubic Hermite interpolant of its values and exact derivatives at ``M_j + 1`` equally spaced
knots (C1, interval ``i`` of width one in the grid coordinate ``x = (u − lower)·M_j/(upper −
lower)``)::

    f_j(x) ≈ a_i + s·(b_i + s·(c_i + s·d_i)),   i = ⌊x⌋ (at most M_j − 1),  s = x − i

so an evaluation costs one index, one gather and three multiply–adds per input instead of a
Legendre recurrence of the model's degree. ``M_j`` is the smallest power of two (from
:data:`GRID_MIN` to :data:`GRID_MAX`) whose largest deviation from ``f_j``, checked on
:data:`CHECK_POINTS` points per interval, is at most ``rtol·R/d``: ``R`` is the model's output
range over the box (the sum of the ranges of the ``f_j``), so the interpolated sum deviates
from the polynomial by at most ``rtol·R`` (:data:`GRID_RTOL` by default). Outside the box the
callers keep the polynomial and its extrapolation policy.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit
from numpy.polynomial import legendre

__all__ = [
    "CHECK_POINTS",
    "GRID_MAX",
    "GRID_MIN",
    "GRID_RTOL",
    "LprGrid",
    "grid_eval",
    "lpr_grid",
    "lpr_grid_inside",
]

#: default bound on the deviation from the polynomial inside the box, relative to the output range
GRID_RTOL = 1e-6
#: smallest and largest number of intervals per input
GRID_MIN, GRID_MAX = 16, 4096
#: points per interval of the deviation check at build time
CHECK_POINTS = 16


class LprGrid(NamedTuple):
    """Cubic Hermite tables of an additive model, one per input (rows past ``M_j`` unused)."""

    coef: np.ndarray  #: float64 (d, max M_j, 4): ``a, b, c, d`` of each interval (output units)
    scale: np.ndarray  #: float64 (d,): ``M_j/(upper_j − lower_j)``, intervals per input unit
    top: np.ndarray  #: float64 (d,): ``M_j − 1``, the last interval
    error: float  #: largest deviation from the polynomial found by the check, output units
    bound: float  #: the bound ``rtol·R`` it satisfies, output units


def _hermite(c: np.ndarray, m: int) -> np.ndarray:
    """Interval coefficients (m, 4) of the Hermite interpolant of the Legendre series ``c`` on
    ``m`` intervals of ``[−1, 1]``, in the grid coordinate (unit intervals)."""
    knots = np.linspace(-1.0, 1.0, m + 1)
    f = legendre.legval(knots, c)
    g = legendre.legval(knots, legendre.legder(c)) * (2.0 / m)
    out = np.empty((m, 4))
    out[:, 0] = f[:-1]
    out[:, 1] = g[:-1]
    out[:, 2] = 3.0 * (f[1:] - f[:-1]) - 2.0 * g[:-1] - g[1:]
    out[:, 3] = 2.0 * (f[:-1] - f[1:]) + g[:-1] + g[1:]
    return out


def _deviation(c: np.ndarray, coef: np.ndarray) -> float:
    """Largest ``|interpolant − series|`` on :data:`CHECK_POINTS` points per interval, with the
    kernels' arithmetic (:func:`grid_eval`)."""
    m = coef.shape[0]
    x = np.linspace(0.0, m, m * CHECK_POINTS + 1)
    i = np.minimum(x.astype(np.int64), m - 1)
    s = x - i
    p = coef[i, 0] + s * (coef[i, 1] + s * (coef[i, 2] + s * coef[i, 3]))
    return float(np.abs(p - legendre.legval(x * (2.0 / m) - 1.0, c)).max())


def lpr_grid(
    table: np.ndarray, lower: np.ndarray, upper: np.ndarray, rtol: float = GRID_RTOL
) -> LprGrid:
    """Hermite tables of the additive model ``table`` (d, n) (from
    :func:`~surrogates.models.lpr.additive_table`; the constant ``table[:, 0]`` goes into the
    first input's table) on the box ``[lower, upper]`` (input units), each within ``rtol`` of
    the output range (module docstring); ``ValueError`` when :data:`GRID_MAX` intervals do
    not reach it."""
    table = np.asarray(table, dtype=np.float64)
    d = table.shape[0]
    series = [table[j].copy() for j in range(d)]
    series[0][0] = table[:, 0].sum()
    for c in series[1:]:
        c[0] = 0.0
    dense = np.linspace(-1.0, 1.0, GRID_MAX * CHECK_POINTS + 1)
    bound = rtol * sum(float(np.ptp(legendre.legval(dense, c))) for c in series)
    tables, error = [], 0.0
    for j, c in enumerate(series):
        m = GRID_MIN
        while True:
            coef = _hermite(c, m)
            dev = _deviation(c, coef)
            if dev <= bound / d:
                break
            if m >= GRID_MAX:
                raise ValueError(
                    f"input {j}: {GRID_MAX} grid intervals deviate {dev:.3g} from the "
                    f"polynomial, above rtol·range/d = {bound / d:.3g}"
                )
            m *= 2
        tables.append(coef)
        error += dev
    width = max(t.shape[0] for t in tables)
    coef = np.zeros((d, width, 4))
    for j, t in enumerate(tables):
        coef[j, : t.shape[0]] = t
    sizes = np.array([t.shape[0] for t in tables], dtype=np.float64)
    scale = sizes / (np.asarray(upper, dtype=np.float64) - np.asarray(lower, dtype=np.float64))
    return LprGrid(coef, scale, sizes - 1.0, error, bound)


@njit(cache=True, inline="always")
def grid_eval(v: float, lo: float, scale: float, top: float, coef: np.ndarray, j: int) -> float:
    """The Hermite table ``j`` of :class:`LprGrid` at input ``v`` (input units) inside the box
    ``lo ≤ v ≤ lo + (top + 1)/scale``. Branch-free; outside the box (or for NaN) an in-range
    index and a value of no meaning, for lane kernels that evaluate every lane and overwrite
    those."""
    x = (v - lo) * scale
    xc = x if x > 0.0 else 0.0
    xc = xc if xc < top else top
    i = int(xc)
    s = x - i
    return coef[j, i, 0] + s * (coef[j, i, 1] + s * (coef[j, i, 2] + s * coef[j, i, 3]))


@njit(cache=True, inline="always")
def lpr_grid_inside(
    u: np.ndarray, coef: np.ndarray, lo: np.ndarray, scale: np.ndarray, top: np.ndarray
) -> float:
    """Value of the gridded additive model (the fields of :class:`LprGrid`) at a point ``u``
    (d,) inside its box ``lo`` …: the tables summed in input order."""
    value = grid_eval(u[0], lo[0], scale[0], top[0], coef, 0)
    for j in range(1, u.shape[0]):
        value += grid_eval(u[j], lo[j], scale[j], top[j], coef, j)
    return value
