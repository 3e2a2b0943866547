"""Kernel-only env-steps/s of the vertical lane kernel, one thread (run by bench_throughput in
a subprocess, with and without LLVM's loop vectoriser: ``NUMBA_LOOP_VECTORIZE``)."""

from __future__ import annotations

import time

import numba
import numpy as np

from railgym.track import track_time_input
from railgym.vehicles.collect import default_vertical_surrogate
from railgym.vehicles.vertical import (
    initial_state,
    load_vehicle,
    step_outputs,
    surrogate_arrays,
)
from railgym.vehicles.vertical.lanes import advance_lanes


def rate(n: int = 1024, n_sub: int = 10, dt: float = 1e-3) -> float:
    """Best-of-10 env-steps/s of ``advance_lanes`` on ``n`` envs (class-5 tracks, 40 m/s)."""
    numba.set_num_threads(1)
    p = load_vehicle("manchester").kernel_params().record()
    lpr = surrogate_arrays(default_vertical_surrogate())
    rows = [track_time_input(5, 40.0, 1.0, dt, seed=i) for i in range(n)]
    z = np.stack([r[1] for r in rows])
    zdot = np.stack([r[2] for r in rows])
    state, out = initial_state("surrogate", n, lpr), step_outputs(n)
    k0, fa = np.zeros(n, np.int64), np.zeros(n)
    advance_lanes(state, z, zdot, k0, n_sub, dt, fa, p, lpr, out)
    best = np.inf
    for r in range(10):
        k0[:] = r * n_sub
        t0 = time.perf_counter()
        advance_lanes(state, z, zdot, k0, n_sub, dt, fa, p, lpr, out)
        best = min(best, time.perf_counter() - t0)
    return n / best


if __name__ == "__main__":
    print(rate())
