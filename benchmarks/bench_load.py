"""Kriging fit time on a loaded machine: every core busy with another process.

A Kriging fit runs hundreds of small Cholesky factorisations; with a multi-threaded BLAS each
one wakes a thread pool, which on a machine whose cores are taken by other work costs far
more than the arithmetic. ``Kriging.fit`` runs with one BLAS thread (``threadpoolctl``); this
benchmark measures a 201-point fit idle and with one busy-looping process per core.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time

import numpy as np

from surrogates.models.kriging import Kriging

N_POINTS = 201


def _data() -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(0)
    U = rng.uniform(-1.0, 1.0, (N_POINTS, 2))
    return U, np.sin(3.0 * U[:, 0]) * np.cos(2.0 * U[:, 1]) + 0.5 * U[:, 1] ** 2


def _fit_time(U: np.ndarray, V: np.ndarray, repeats: int) -> float:
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        Kriging().fit(U, V)
        best = min(best, time.perf_counter() - t0)
    return best


def run(repeats: int = 2) -> list[dict]:
    """Best-of-``repeats`` fit time idle and under load, and their ratio."""
    U, V = _data()
    idle = _fit_time(U, V, repeats)
    busy = [
        subprocess.Popen([sys.executable, "-c", "while True: pass"])
        for _ in range(os.cpu_count() or 1)
    ]
    try:
        loaded = _fit_time(U, V, repeats)
    finally:
        for p in busy:
            p.kill()
            p.wait()
    ctx = f"Kriging(nugget='auto') fit, {N_POINTS} points, 2-D; load: {len(busy)} busy processes"
    return [
        {"name": "kriging_fit_idle", "value": idle, "unit": "s", "target": "-", "context": ctx},
        {
            "name": "kriging_fit_under_load",
            "value": loaded,
            "unit": "s",
            "target": "<= 3 x idle",
            "context": ctx + " (issue 19: 58-84 s with 2 BLAS threads)",
        },
        {
            "name": "kriging_fit_load_ratio",
            "value": loaded / idle,
            "unit": "x",
            "target": "<= 3",
            "context": ctx,
        },
    ]
