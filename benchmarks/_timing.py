"""Timing shared by the benchmarks: repeated windows, their median and spread, and a figure's
verdict against its target.

A measured figure is the median of :data:`REPEATS` windows, each at least :data:`WINDOW_S`
long (the number of calls per window is calibrated first, after a warm-up call that compiles
or loads the kernels). Figures compared with each other (a ratio, a share) are timed in
interleaved rounds (:func:`interleaved`): round ``r`` times one window of each, so a change of
the machine's load hits both sides of the ratio of that round, and the ratio's samples are the
per-round ratios. The spread of a figure is the interquartile range of its samples relative to
their median (:func:`spread`). A figure with a numeric target (``"≥ 25"``, ``"≤ 1.3"``) is
``met`` or ``missed``, and ``unresolved`` when its spread exceeds the relative margin by which
it meets or misses the target (:func:`verdict`).
"""

from __future__ import annotations

import re
import time
from collections.abc import Callable, Mapping, Sequence
from typing import NamedTuple

import numpy as np

#: timed windows per figure (the median is reported); ``python -m benchmarks --repeats``
REPEATS = 5
#: minimum length of one timed window, s; ``python -m benchmarks --window``
WINDOW_S = 0.2
#: calls per window at most (a guard against a function that returns at once)
MAX_CALLS = 1 << 22

_TARGET = re.compile(r"^\s*(≤|≥|<=|>=|<|>)\s*([0-9.eE+-]+)(?:\s*/\s*([0-9.eE+-]+))?\s*(\S*)\s*$")


class Windows(NamedTuple):
    """Seconds per call of one timed function: one sample per window."""

    seconds: np.ndarray  #: (repeats,) mean seconds per call in each window
    calls: int  #: calls per window


def calls_per_window(fn: Callable[[], object], window_s: float | None = None) -> int:
    """Calls of ``fn`` that take at least ``window_s`` (default :data:`WINDOW_S`): doubled
    from 1 until a trial window is long enough (the trials are discarded)."""
    window_s = WINDOW_S if window_s is None else window_s
    k = 1
    while True:
        t0 = time.perf_counter()
        for _ in range(k):
            fn()
        elapsed = time.perf_counter() - t0
        if elapsed >= window_s or k >= MAX_CALLS:
            return k
        # aim at the window from the trial's rate, at most 8 × more calls per trial
        k = min(MAX_CALLS, max(2 * k, min(8 * k, int(k * 1.2 * window_s / max(elapsed, 1e-9)))))


def interleaved(
    fns: Mapping[str, Callable[[], object]],
    repeats: int | None = None,
    window_s: float | None = None,
) -> dict[str, Windows]:
    """Time every function of ``fns`` in ``repeats`` interleaved rounds, one window each per
    round, after one warm-up call each and the calibration of its calls per window."""
    repeats = REPEATS if repeats is None else repeats
    calls = {}
    for name, fn in fns.items():
        fn()  # warm-up: compile or load the kernels, fill caches
        calls[name] = calls_per_window(fn, window_s)
    seconds: dict[str, list[float]] = {name: [] for name in fns}
    for _ in range(repeats):
        for name, fn in fns.items():
            k = calls[name]
            t0 = time.perf_counter()
            for _ in range(k):
                fn()
            seconds[name].append((time.perf_counter() - t0) / k)
    return {name: Windows(np.array(seconds[name]), calls[name]) for name in fns}


def windows(
    fn: Callable[[], object], repeats: int | None = None, window_s: float | None = None
) -> Windows:
    """Seconds per call of ``fn`` in ``repeats`` windows (see :func:`interleaved`)."""
    return interleaved({"fn": fn}, repeats, window_s)["fn"]


#: fewest samples with a spread (and so a verdict)
MIN_SAMPLES = 3


def spread(samples: Sequence[float] | np.ndarray) -> float:
    """Interquartile range of ``samples`` relative to their median; NaN for fewer than
    :data:`MIN_SAMPLES` samples (no spread to show)."""
    x = np.asarray(samples, np.float64)
    if x.size < MIN_SAMPLES:
        return float("nan")
    q25, q50, q75 = np.percentile(x, [25, 50, 75])
    return float((q75 - q25) / abs(q50)) if q50 != 0 else float("inf")


def parse_target(target: str) -> tuple[str, float] | None:
    """``(op, bound)`` of a numeric target such as ``"≥ 25"``, ``"≤ 1.3"``, ``"≥ 1/3"``,
    ``"<= 2 s"`` (op one of ``≤ ≥ < >``); ``None`` for any other text."""
    m = _TARGET.match(target or "")
    if m is None:
        return None
    op = {"<=": "≤", ">=": "≥"}.get(m.group(1), m.group(1))
    try:
        bound = float(m.group(2)) / (float(m.group(3)) if m.group(3) else 1.0)
    except (ValueError, ZeroDivisionError):
        return None
    return op, bound


def verdict(value: float, rel_spread: float | None, target: str) -> str:
    """``"met"``, ``"missed"`` or ``"unresolved"`` of a figure ``value`` against ``target``:
    unresolved when ``rel_spread`` (relative to ``value``) exceeds the margin
    ``|value − bound| / |value|`` by which it meets or misses the bound. ``""`` without a
    numeric target or a spread (``None`` or NaN: a figure not timed in repeated windows)."""
    parsed = parse_target(target)
    if parsed is None or rel_spread is None or np.isnan(rel_spread) or not np.isfinite(value):
        return ""
    op, bound = parsed
    ok = {"≤": value <= bound, "≥": value >= bound, "<": value < bound, ">": value > bound}[op]
    margin = abs(value - bound) / abs(value) if value != 0 else float("inf")
    if rel_spread > margin:
        return "unresolved"
    return "met" if ok else "missed"


def verdict_of(samples: Sequence[float] | np.ndarray, target: str) -> str:
    """The :func:`verdict` of the median of ``samples`` with their :func:`spread`."""
    return verdict(float(np.median(samples)), spread(samples), target)
