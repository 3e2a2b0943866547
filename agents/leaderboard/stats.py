"""Scores over runs as RL papers report them (Agarwal et al., NeurIPS 2021): the
interquartile mean (IQM, the mean of the middle 50 %) with a 95 % stratified bootstrap
confidence interval (:func:`scipy.stats.bootstrap`, percentile method).

Stratified: each stratum (an evaluation case of a task, or a task of the aggregate) is
resampled on its own with its own size, so that a CI reflects the spread between runs
(seeds) and not which strata happened to be drawn.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from scipy import stats

__all__ = ["CONFIDENCE", "RESAMPLES", "Interval", "iqm", "iqm_interval"]

#: confidence level of the intervals
CONFIDENCE = 0.95
#: bootstrap resamples
RESAMPLES = 2000


class Interval(NamedTuple):
    """An IQM and its confidence interval ``[low, high]``; ``n``: the values behind it."""

    iqm: float
    low: float
    high: float
    n: int


def iqm(values: np.ndarray, axis: int | None = None) -> np.ndarray:
    """Interquartile mean: the mean of the values between the 25th and 75th percentile
    (:func:`scipy.stats.trim_mean`, 25 % cut at each end), over all values or ``axis``."""
    if axis is None:
        return np.asarray(stats.trim_mean(np.ravel(values), 0.25))
    return np.asarray(stats.trim_mean(values, 0.25, axis=axis))


def iqm_interval(strata: Sequence[Sequence[float]], seed: int = 0) -> Interval:
    """IQM of all values of ``strata`` (sequences of scores, e.g. the seeds of one case) with
    its :data:`CONFIDENCE` stratified bootstrap interval (:data:`RESAMPLES` resamples from the
    generator of ``seed``). A single value, or values all equal, give a zero-width interval."""
    groups = [np.asarray(s, float).ravel() for s in strata if len(s)]
    if not groups:
        raise ValueError("iqm_interval needs at least one value")
    values = np.concatenate(groups)
    if not np.all(np.isfinite(values)):
        raise ValueError("iqm_interval: the scores must be finite")
    centre = float(iqm(values))
    if np.ptp(values) == 0.0 or all(len(g) == 1 for g in groups):
        # nothing to resample: every stratum is one value (or all values are equal)
        return Interval(centre, centre, centre, len(values))

    def statistic(*resampled: np.ndarray, axis: int = -1) -> np.ndarray:
        return iqm(np.concatenate(resampled, axis=axis), axis=axis)

    res = stats.bootstrap(
        groups,
        statistic,
        n_resamples=RESAMPLES,
        confidence_level=CONFIDENCE,
        method="percentile",
        vectorized=True,
        rng=np.random.default_rng(seed),
    )
    ci = res.confidence_interval
    return Interval(centre, float(ci.low), float(ci.high), len(values))
