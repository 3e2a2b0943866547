"""Accuracy indices of the paper (section 3.4) and a training timer.

- :func:`average_relative_error` — eq. 8, for outputs far from zero;
- :func:`average_absolute_error` — eq. 9, otherwise (units of the output);
- :func:`paper_error` — applies the paper's rule to choose between them;
- :func:`rms_normalised_error` — RMS error divided by the RMS of the truth (dimensionless).
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np


def _pair(pred: Any, true: Any) -> tuple[np.ndarray, np.ndarray]:
    p = np.asarray(pred, dtype=float).ravel()
    t = np.asarray(true, dtype=float).ravel()
    if p.shape != t.shape:
        raise ValueError(f"pred has {p.size} values, true has {t.size}")
    if p.size == 0:
        raise ValueError("pred and true are empty")
    return p, t


def average_relative_error(pred: Any, true: Any) -> float:
    """Eq. 8: mean of |(pred − true) / true| (dimensionless).

    Raises ``ValueError`` when ``true`` contains zeros, where eq. 8 is undefined.
    """
    p, t = _pair(pred, true)
    if np.any(t == 0.0):
        raise ValueError("true contains zeros: eq. 8 is undefined, use average_absolute_error")
    return float(np.mean(np.abs((p - t) / t)))


def average_absolute_error(pred: Any, true: Any) -> float:
    """Eq. 9: mean of |pred − true| (units of the output)."""
    p, t = _pair(pred, true)
    return float(np.mean(np.abs(p - t)))


def rms_normalised_error(pred: Any, true: Any) -> float:
    """RMS(pred − true) / RMS(true) (dimensionless; ``inf`` when the truth is all zero)."""
    p, t = _pair(pred, true)
    den = float(np.sqrt(np.mean(t**2)))
    num = float(np.sqrt(np.mean((p - t) ** 2)))
    return num / den if den > 0 else (0.0 if num == 0 else float("inf"))


def far_from_zero(true: Any, ratio: float = 0.1) -> bool:
    """The paper's condition for eq. 8: every |true| is at least ``ratio`` × mean |true|."""
    t = np.abs(np.asarray(true, dtype=float).ravel())
    return bool(t.size > 0 and t.min() > 0 and t.min() >= ratio * t.mean())


def paper_error(pred: Any, true: Any, ratio: float = 0.1) -> tuple[float, str]:
    """Eq. 8 if the outputs are far from zero (see :func:`far_from_zero`), else eq. 9.

    Returns ``(value, "relative" | "absolute")``.
    """
    if far_from_zero(true, ratio):
        return average_relative_error(pred, true), "relative"
    return average_absolute_error(pred, true), "absolute"


@contextmanager
def timer() -> Iterator[dict[str, float]]:
    """Context manager measuring wall time: ``with timer() as t: ...; t["seconds"]``."""
    out = {"seconds": float("nan")}
    start = time.perf_counter()
    try:
        yield out
    finally:
        out["seconds"] = time.perf_counter() - start
