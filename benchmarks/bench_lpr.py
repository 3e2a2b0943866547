"""Legendre regression fit and evaluation time (target: fit of 101 samples ≤ 1 ms), each the
median of repeated windows (:mod:`benchmarks._timing`); the degree search is one run."""

from __future__ import annotations

import time

import numpy as np

from benchmarks import measured, row
from benchmarks._timing import windows
from surrogates import LegendreRegression
from surrogates.models.lpr import lpr_eval
from surrogates.passive import PassiveLegendreRegression
from surrogates.selection import select_kfold


class _EveryFold(PassiveLegendreRegression):
    """The same model; a subclass, so ``select_kfold`` fits it on every fold."""


def run() -> list[dict]:
    """Rows of measurements (see ``benchmarks/__main__.py``)."""
    rng = np.random.default_rng(0)
    U = np.column_stack([rng.normal(0, 0.01, 101), rng.normal(0, 0.1, 101)])
    V = 8.6e5 * U[:, 0] * (1 + 200 * U[:, 0] ** 2) + 4e4 * np.tanh(U[:, 1] / 0.1) * 0.1
    model = LegendreRegression(degree=(5, 5)).fit(U, V)
    fit = windows(lambda: LegendreRegression(degree=(5, 5)).fit(U, V)).seconds
    arrays = model.kernel_arrays()
    u = U[0].copy()
    ev = windows(lambda: lpr_eval(u, *arrays)).seconds
    return [
        measured(
            "LPR fit, 101 samples, degree (5,5)", fit * 1e3, "ms", "≤ 1", "paper T_t: 0.08-0.09 s"
        ),
        measured(
            "LPR lpr_eval, one point (from Python)", ev * 1e6, "µs", "", "includes numba dispatch"
        ),
        *_degree_search(rng),
    ]


def _degree_search(rng: np.random.Generator) -> list[dict]:
    """A passive 3-input degree search by 5-fold CV (CPU time of this process): the shared
    factorisation of ``select_kfold`` against fitting every candidate on every fold."""
    U = rng.standard_normal((20000, 3)) * (0.01, 0.1, 0.001)
    V = 4e5 * U[:, 0] * (1 + 200 * U[:, 0] ** 2) + 2e4 * np.tanh(U[:, 1] / 0.1) + 3e6 * U[:, 2]
    cands = [(a, b, c) for a in (6, 8) for b in (6, 8) for c in (8, 10)]
    times = {}
    for name, cls in (("shared", PassiveLegendreRegression), ("loop", _EveryFold)):
        t0 = time.process_time()
        select_kfold(lambda deg, cls=cls: cls(degree=deg), cands, U, V, k=5)
        times[name] = time.process_time() - t0
    context = "8 candidates, 5 folds, 20000 x 3 samples, CPU"
    return [
        row("LPR passive degree search, shared", times["shared"], "s", "", context),
        row(
            "LPR passive degree search, loop / shared",
            times["loop"] / times["shared"],
            "x",
            "≥ 5",
            "the same search, one fit per candidate and fold",
        ),
    ]


if __name__ == "__main__":
    for r in run():
        print(r)
