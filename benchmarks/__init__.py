"""Benchmarks: speed against anchors measured in the same run (``python -m benchmarks``)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def row(
    name: str,
    value: float,
    unit: str,
    target: str = "",
    context: str = "",
    spread: float | None = None,
) -> dict:
    """One benchmark measurement as printed by ``python -m benchmarks``; ``spread``: the
    interquartile range of its repeated samples relative to their median (``None``: a figure
    not timed in repeated windows, or in fewer than three)."""
    return {
        "name": name,
        "value": float(value),
        "unit": unit,
        "target": target,
        "context": context,
        "spread": spread,
    }


def measured(
    name: str,
    samples: Sequence[float] | np.ndarray,
    unit: str,
    target: str = "",
    context: str = "",
) -> dict:
    """A :func:`row` of repeated samples: their median and spread
    (:func:`benchmarks._timing.spread`)."""
    from benchmarks._timing import spread

    s = spread(samples)
    return row(name, float(np.median(samples)), unit, target, context, None if np.isnan(s) else s)
