"""Crash criteria as users report them, from recorded crash histories (pure functions).

Inputs are time histories sampled at ``t`` (s, increasing, first contact at ``t[0]``): per car
the centre-of-mass velocity ``v`` (m/s, positive towards the barrier) and acceleration ``a``
(m/s², negative when braking), per crush zone the crush (m, compression positive) — the
arrays of :class:`railgym.vehicles.crash.outputs.CrashResult` (``v``, ``a``, ``crush``) or the env's
per-step ``CrashOutputs``. Decelerations are returned in g, positive when braking.

Definitions
-----------
peak deceleration
    ``max_t (−a(t)) / g`` over the record.
moving-average peak
    the largest mean deceleration over any window of length ``T`` (default 10 ms) inside the
    record, ``max_τ (v(τ) − v(τ + T)) / (g T)``: the window mean of the acceleration is the
    velocity change over the window, so it is exact whatever the sample interval; ``v`` is
    interpolated linearly at ``τ + T``.
mean deceleration over the crash pulse
    ``Δv / (g · (t_end − t_start))`` for each car's own pulse: ``t_start`` is the first sample
    at which the car's deceleration reaches ``onset_g`` (default 0.5 g, above wheel–rail
    friction 0.1 g; a car at the back starts braking after the lead car), ``t_end`` the first
    time its velocity reaches zero (linear interpolation between samples), or, for a car that
    does not stop (an obstacle pushed away), the last sample at which its deceleration is still
    ``onset_g`` or more; ``Δv = v(t_start) − v(t_end)``. Between the two samples around the
    zero crossing the car is taken to brake at the first one's deceleration if that stops it
    within the interval, else its velocity is interpolated linearly. This is the "mean longitudinal
    deceleration of the survival space" of the EN 15227 deceleration criterion as it is usually
    stated, a velocity change over the collision time (issue 11 asks for Δv / (g·t_stop)). The
    standard's text is paywalled (``/work/shared/reference-data.md``); we implement this
    definition and do not claim compliance with the standard.
survival-space intrusion
    per zone, crush beyond the absorber stroke, ``max(0, max_t crush(t) − absorber_stroke)``:
    the envelope is a function of the total crush and the carbody structure starts at the
    absorber stroke, so any crush beyond it is structure crush (loss of survival space).

Limits (:class:`CriteriaLimits`): ``mean_decel_g`` 5 g by default, the value issue 11 gives
for the EN 15227 survival-space deceleration criterion (quoted there, not checked against the
standard's text); the peak and moving-average limits are off (``inf``) by default, the standard
states none for them; ``intrusion_m`` 0 m (no structure crush; the CEM design goal that the
absorbers alone take the collision energy).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

__all__ = [
    "ONSET_G",
    "WINDOW",
    "CrashCriteria",
    "CriteriaLimits",
    "G",
    "Pulse",
    "crash_criteria",
    "crash_pulse",
    "intrusion",
    "moving_average_peak",
    "peak_deceleration",
    "zero_crossing",
]

#: moving-average window of :func:`moving_average_peak`, s
WINDOW = 0.01
#: deceleration that starts (and, for a car that does not stop, ends) a car's pulse, g
ONSET_G = 0.5
#: standard gravity, m/s²
G = 9.81


class CriteriaLimits(NamedTuple):
    """Acceptance limits of :func:`crash_criteria` (``inf`` = not checked).

    Attributes
    ----------
    mean_decel_g : mean deceleration over each car's pulse, g.
    peak_decel_g : peak deceleration of each car, g.
    moving_average_g : moving-average peak of each car, g.
    intrusion_m : survival-space intrusion of each zone, m.
    """

    mean_decel_g: float = 5.0
    peak_decel_g: float = math.inf
    moving_average_g: float = math.inf
    intrusion_m: float = 0.0


class Pulse(NamedTuple):
    """Each car's crash pulse (arrays (cars,)): start and end time (s), velocity change
    ``Δv`` (m/s) and mean deceleration ``Δv / (g (end − start))`` (g)."""

    start: np.ndarray
    end: np.ndarray
    delta_v: np.ndarray
    mean_g: np.ndarray


class CrashCriteria(NamedTuple):
    """Criteria of one crash (:func:`crash_criteria`).

    Attributes
    ----------
    peak_decel_g, moving_average_g : (cars,) peak and moving-average peak deceleration, g.
    pulse : each car's :class:`Pulse`.
    intrusion_m : (zones,) survival-space intrusion, m.
    passed : criterion name → (cars,) or (zones,) bool array, ``True`` where within the limit
        (``"mean_decel"``, ``"peak_decel"``, ``"moving_average"``, ``"intrusion"``).
    limits : the :class:`CriteriaLimits` applied.
    """

    peak_decel_g: np.ndarray
    moving_average_g: np.ndarray
    pulse: Pulse
    intrusion_m: np.ndarray
    passed: dict[str, np.ndarray]
    limits: CriteriaLimits

    @property
    def all_passed(self) -> bool:
        """``True`` if every car and zone meets every limit."""
        return all(bool(np.all(p)) for p in self.passed.values())


def _time(t: np.ndarray) -> np.ndarray:
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or t.size < 2:
        raise ValueError(f"t must be a 1-D array of at least 2 samples, got shape {t.shape}")
    if not (np.all(np.isfinite(t)) and np.all(np.diff(t) > 0)):
        raise ValueError("t must be finite and strictly increasing")
    return t


def _per_car(name: str, x: np.ndarray, n: int) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    x = x[:, None] if x.ndim == 1 else x
    if x.ndim != 2 or x.shape[0] != n:
        raise ValueError(f"{name} must have shape ({n},) or ({n}, columns), got {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{name} must be finite")
    return x


def peak_deceleration(a: np.ndarray, g: float = G) -> np.ndarray:
    """Peak deceleration (g) of each column of ``a`` (n, cars), m/s²."""
    a = np.asarray(a, dtype=float)
    a = a[:, None] if a.ndim == 1 else a
    return np.max(-a, axis=0) / g


def moving_average_peak(
    t: np.ndarray, v: np.ndarray, window: float = WINDOW, g: float = G
) -> np.ndarray:
    """Largest mean deceleration (g) over any ``window`` (s) inside the record, per car.

    ``v`` (n, cars) in m/s; windows start at every sample ``τ`` with ``τ + window ≤ t[-1]``.
    """
    t = _time(t)
    v = _per_car("v", v, t.size)
    if not (math.isfinite(window) and 0 < window <= t[-1] - t[0]):
        raise ValueError(f"window must be in (0, {t[-1] - t[0]}] s, got {window!r}")
    starts = t[t + window <= t[-1] + 1e-12 * window]
    out = np.empty(v.shape[1])
    for c in range(v.shape[1]):
        v0 = np.interp(starts, t, v[:, c])
        v1 = np.interp(starts + window, t, v[:, c])
        out[c] = np.max(v0 - v1) / (g * window)
    return out


@njit(cache=True)
def zero_crossing(t0: float, t1: float, v0: float, v1: float, a0: float) -> float:
    """Time in [t0, t1] at which a velocity going from ``v0 > 0`` to ``v1 ≤ 0`` reaches zero:
    at the deceleration ``a0`` of the first sample if that stops it inside the interval (a car
    that comes to rest, ``v1 = 0``), else by linear interpolation (a car that rebounds)."""
    if a0 < 0.0 and t0 - v0 / a0 <= t1:
        return t0 - v0 / a0
    return t0 + v0 / (v0 - v1) * (t1 - t0)


def crash_pulse(
    t: np.ndarray, v: np.ndarray, a: np.ndarray, onset_g: float = ONSET_G, g: float = G
) -> Pulse:
    """Each car's own crash pulse and its mean deceleration (see the module docstring).

    A car that never reaches ``onset_g`` has no pulse: start = end = ``t[0]``, Δv 0, mean 0.
    """
    t = _time(t)
    v = _per_car("v", v, t.size)
    a = _per_car("a", a, t.size)
    if a.shape != v.shape:
        raise ValueError(f"a has shape {a.shape} but v has {v.shape}")
    n_cars = v.shape[1]
    start, end, dv = np.full(n_cars, t[0]), np.full(n_cars, t[0]), np.zeros(n_cars)
    for c in range(n_cars):
        braking = np.flatnonzero(-a[:, c] >= onset_g * g)
        if braking.size == 0:
            continue
        i0 = braking[0]
        stopped = np.flatnonzero(v[i0:, c] <= 0.0)
        if stopped.size:
            k = i0 + stopped[0]
            t_end = t[k]
            if k > i0:
                t_end = zero_crossing(t[k - 1], t[k], v[k - 1, c], v[k, c], a[k - 1, c])
            v_end = 0.0 if k > i0 else v[k, c]
        else:
            k = braking[-1]
            t_end, v_end = t[k], v[k, c]
        start[c], end[c], dv[c] = t[i0], t_end, v[i0, c] - v_end
    span = end - start
    mean = np.divide(dv, g * span, out=np.zeros(n_cars), where=span > 0)
    return Pulse(start=start, end=end, delta_v=dv, mean_g=mean)


def intrusion(crush: np.ndarray, absorber_stroke: np.ndarray) -> np.ndarray:
    """Survival-space intrusion (m) of each zone: ``max(0, max_t crush − absorber_stroke)``.

    ``crush`` (n, zones) m; ``absorber_stroke`` (zones,) m.
    """
    crush = np.asarray(crush, dtype=float)
    crush = crush[:, None] if crush.ndim == 1 else crush
    stroke = np.atleast_1d(np.asarray(absorber_stroke, dtype=float))
    if stroke.shape != (crush.shape[1],):
        raise ValueError(
            f"absorber_stroke must have shape ({crush.shape[1]},), one per zone, got {stroke.shape}"
        )
    return np.maximum(np.max(crush, axis=0) - stroke, 0.0)


def crash_criteria(
    t: np.ndarray,
    v: np.ndarray,
    a: np.ndarray,
    crush: np.ndarray,
    absorber_stroke: np.ndarray,
    limits: CriteriaLimits | None = None,
    window: float = WINDOW,
    onset_g: float = ONSET_G,
    g: float = G,
) -> CrashCriteria:
    """All criteria of one crash and pass/fail against ``limits`` (default
    :class:`CriteriaLimits`: 5 g mean pulse deceleration, no intrusion).

    Parameters
    ----------
    t : (n,) s. v, a : (n, cars) m/s and m/s². crush : (n, zones) m.
    absorber_stroke : (zones,) m. window : moving-average window, s.
    onset_g : pulse onset deceleration, g. g : gravity, m/s².
    """
    limits = CriteriaLimits() if limits is None else limits
    for name, value in limits._asdict().items():
        if not (isinstance(value, int | float) and value >= 0 and not math.isnan(value)):
            raise ValueError(f"limits.{name} must be a non-negative number, got {value!r}")
    peak = peak_deceleration(_per_car("a", a, np.asarray(t).size), g)
    moving = moving_average_peak(t, v, window, g)
    pulse = crash_pulse(t, v, a, onset_g, g)
    intr = intrusion(crush, absorber_stroke)
    passed = {
        "mean_decel": pulse.mean_g <= limits.mean_decel_g,
        "peak_decel": peak <= limits.peak_decel_g,
        "moving_average": moving <= limits.moving_average_g,
        "intrusion": intr <= limits.intrusion_m,
    }
    return CrashCriteria(peak, moving, pulse, intr, passed, limits)
