"""Kernel-only env-steps/s of the vertical lane kernel, one thread (run by bench_throughput in
a subprocess, with and without LLVM's loop vectoriser: ``NUMBA_LOOP_VECTORIZE``); prints the
median and the spread of the timed windows."""

from __future__ import annotations

import sys

import numba
import numpy as np

from benchmarks import _timing
from benchmarks._timing import windows
from railgym.track import track_time_input
from railgym.vehicles.collect import default_vertical_surrogate
from railgym.vehicles.vertical.kernels import initial_state, step_outputs, surrogate_arrays
from railgym.vehicles.vertical.lanes import advance_lanes
from railgym.vehicles.vertical.params import load_vehicle


def rate(n: int = 1024, n_sub: int = 10, dt: float = 1e-3) -> np.ndarray:
    """Env-steps/s of ``advance_lanes`` on ``n`` envs (class-5 tracks, 40 m/s), one sample per
    timed window (:func:`benchmarks._timing.windows`)."""
    numba.set_num_threads(1)
    p = load_vehicle("manchester").kernel_params().record()
    lpr = surrogate_arrays(default_vertical_surrogate())
    rows = [track_time_input(5, 40.0, 1.0, dt, seed=i) for i in range(n)]
    z = np.stack([r[1] for r in rows])
    zdot = np.stack([r[2] for r in rows])
    state, out = initial_state("surrogate", n, lpr), step_outputs(n)
    k0, fa = np.zeros(n, np.int64), np.zeros(n)
    last = z.shape[1] - 1 - n_sub

    def call() -> None:
        k0[:] = (k0[0] + n_sub) % last  # walk along the track, wrapping before its end
        advance_lanes(state, z, zdot, k0, n_sub, dt, fa, p, lpr, out)

    return n / windows(call).seconds


if __name__ == "__main__":
    if len(sys.argv) == 3:  # repeats and window length of the parent run
        _timing.REPEATS, _timing.WINDOW_S = int(sys.argv[1]), float(sys.argv[2])
    samples = rate()
    print(float(np.median(samples)), _timing.spread(samples))
