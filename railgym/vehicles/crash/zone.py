"""Hysteretic crush-zone law (compiled): loading envelope with a progressive-folding wave,
elastic unloading and reloading with the unloading stiffness ``k_u``, permanent set.

This is the "explicit loading envelope with elastic unloading" law used in public lumped-mass
crash codes (the alternative being a Bouc–Wen element).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["absorber_zone_force", "zone_force"]


@njit(cache=True)
def envelope_force(d: float, s: np.ndarray, f: np.ndarray, n: int, amp: float, lam: float) -> float:
    """Loading-envelope force (N) at crush ``d`` (m): origin → points, then constant; times the
    folding wave ``1 + amp sin(2π (d − s[0]) / lam)`` beyond the first point."""
    if d <= 0.0:
        return 0.0
    if d <= s[0]:
        return f[0] * d / s[0]
    if d >= s[n - 1]:
        base = f[n - 1]
    else:
        k = 1
        while s[k] < d:
            k += 1
        base = f[k - 1] + (d - s[k - 1]) / (s[k] - s[k - 1]) * (f[k] - f[k - 1])
    return base * (1.0 + amp * math.sin(2.0 * math.pi * (d - s[0]) / lam))


@njit(cache=True)
def zone_force(
    d: float, dp: float, s: np.ndarray, f: np.ndarray, n: int, amp: float, lam: float, ku: float
) -> tuple[float, float]:
    """Hysteretic crush-zone law: force (N, ≥ 0) and updated permanent set (m).

    Elastic trial ``k_u (d − dp)``: no force in a gap, elastic below the envelope, and on the
    envelope the force follows it while the permanent set moves to ``d − f_env / k_u``.
    """
    return absorber_zone_force(d, dp, s, f, n, amp, lam, ku, math.inf, 1.0)


@njit(cache=True)
def absorber_zone_force(
    d: float,
    dp: float,
    s: np.ndarray,
    f: np.ndarray,
    n: int,
    amp: float,
    lam: float,
    ku: float,
    absorber: float,
    scale: float,
) -> tuple[float, float]:
    """:func:`zone_force` with a controllable absorber: the loading envelope up to the absorber
    stroke ``absorber`` (m) is multiplied by ``scale``; beyond it (the carbody structure) and
    the unloading stiffness are unchanged."""
    trial = ku * (d - dp)
    if trial <= 0.0:
        return 0.0, dp
    env = envelope_force(d, s, f, n, amp, lam)
    if d <= absorber:
        env *= scale
    if trial >= env:
        return env, d - env / ku
    return trial, dp
