"""Vector-env throughput per core and on all cores, achieved GFLOP/s against a measured peak.

For each env at 1024 sub-envs: env-steps/s with ``numba.set_num_threads(1)`` and with the
default thread count, and GFLOP/s from an estimated flop count per env-step:

* ``VerticalSuspension-v1``: 10 RK4 substeps, 4 right-hand sides each with the packaged
  memory element: additive Legendre sums of degrees (14, 14, 20), 6 flop per recurrence step,
  plus ~60 flop of dynamics, bump stops and stage updates (:func:`vertical_flop`, ~13 kflop;
  issue 13 estimated ~2 kflop for a degree-(10,10) element).
* ``VerticalVehicle-v1``: 5 RK4 substeps, 4 right-hand sides each with two degree-(10,10) LPR
  elements (~2 × 121 × 2 multiply-adds) and the 14-state rigid/flexible dynamics (~150
  flop): ~12 kflop per step.
* ``VerticalSuspension-v2``, ``VerticalVehicle-v2``: the same envs with the element evaluated
  by Hermite tables inside its box (:mod:`surrogates.models.lpr_grid`): no flop estimate.
* ``TrainCrash-v1``: 2 velocity-Verlet substeps of a 2-body surrogate with one high-degree
  LPR element (~200 flop each) and the per-step criteria bookkeeping (~200 flop): ~0.6 kflop.

The peak is a numba FMA loop over float64 arrays (``a*b+c`` written in place, cache-resident,
SIMD-vectorised by LLVM) on one thread. The vertical surrogate runs the lane kernel
(``railgym.vehicles.vertical.lanes``: loops over blocks of sub-envs innermost, vectorised);
the whole-vehicle surrogate likewise (``railgym.vehicles.vehicle.lanes``); the crash kernels
run one sub-env after another. Large batches spread over threads by ``prange``.
:func:`packed_share` recompiles a kernel function (the cached one keeps no assembly) and
counts packed (``…pd``) against scalar (``…sd``) double arithmetic in its assembly.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import tempfile
from typing import Any

import gymnasium as gym
import numba
import numpy as np
from numba import njit

import railgym  # noqa: F401  (registers the environments)
from benchmarks import _timing, measured, row
from benchmarks._stepping import Steps, rate
from benchmarks._timing import interleaved, windows

N_VEC = 1024
#: estimated flop per env-step (module docstring)
#: issue 32's share of CartPoleVectorEnv's env-steps/s at 1024 sub-envs, %, of each version
TARGET_SHARE = {"VerticalSuspension": "≥ 25", "VerticalVehicle": "≥ 12", "TrainCrash": "≥ 25"}


def vertical_flop(n_sub: int = 10) -> float:
    """Flop per VerticalSuspension-v1 env-step with the packaged memory element: per
    right-hand side 6 flop per Legendre recurrence step of each input (degree − 1 steps) and
    ~60 flop for the rest."""
    from railgym.vehicles.collect import default_vertical_surrogate
    from railgym.vehicles.vertical.kernels import surrogate_arrays

    table = surrogate_arrays(default_vertical_surrogate()).table
    degrees = [int(np.flatnonzero(r).max()) if r.any() else 0 for r in table]
    per_rhs = 6 * sum(max(d - 1, 0) for d in degrees) + 60
    return 4 * n_sub * per_rhs


FLOP_PER_STEP: dict[str, float | None] = {
    "railgym/VerticalSuspension-v1": vertical_flop(),
    "railgym/VerticalSuspension-v2": None,  # Hermite tables: no polynomial flop count
    "railgym/VerticalVehicle-v1": 12e3,
    "railgym/VerticalVehicle-v2": None,
    "railgym/VerticalSuspension-v3": None,  # v2 and the streamed track
    "railgym/VerticalVehicle-v3": None,
    "railgym/TrainCrash-v1": 0.6e3,
}


@njit(cache=True, fastmath=True)
def _fma(a: np.ndarray, b: np.ndarray, c: np.ndarray, reps: int) -> float:
    """``reps`` passes of ``c = a * b + c``; returns a sum so nothing is optimised away."""
    for _ in range(reps):
        for j in range(c.shape[0]):
            c[j] = a[j] * b[j] + c[j]
    return c.sum()


def peak_gflops(n: int = 2048, reps: int = 2000) -> np.ndarray:
    """GFLOP/s of :func:`_fma` on one thread (2 flop per element and pass), one sample per
    timed window (:func:`benchmarks._timing.windows`)."""
    a, b, c = np.full(n, 0.999), np.full(n, 1e-3), np.zeros(n)
    seconds = windows(lambda: _fma(a, b, c, reps)).seconds
    return 2.0 * n * reps / seconds / 1e9


class _Threaded(Steps):
    """:class:`~benchmarks._stepping.Steps` of a vector env with zero actions on ``threads``
    numba threads."""

    def __init__(self, venv: gym.vector.VectorEnv, n: int, threads: int) -> None:
        action = np.zeros(venv.action_space.shape, venv.action_space.dtype)
        super().__init__(venv, n, lambda k: action)
        self.threads = threads

    def __call__(self) -> None:
        numba.set_num_threads(self.threads)
        super().__call__()


def packed_share(fn: Any, args: tuple) -> tuple[int, int]:
    """Packed and scalar double arithmetic instructions in the assembly of a fresh compile of
    the numba function ``fn`` for ``args`` (callees linked in)."""
    fresh = njit(error_model="numpy", _nrt=False)(fn.py_func)
    sig = tuple(fresh.typeof_pyval(a) for a in args)
    fresh.compile(sig)
    asm = fresh.inspect_asm(sig)
    ops = r"\tv?(?:add|sub|mul|div|fmadd\d*|fnmadd\d*|fmsub\d*|max|min|sqrt)"
    return len(re.findall(ops + r"pd\t", asm)), len(re.findall(ops + r"sd\t", asm))


def _vehicle_element_args() -> tuple[Any, tuple]:
    """The whole-vehicle lane kernel's element evaluation and arguments for one block."""
    from railgym.vehicles.collect import default_vertical_surrogate
    from railgym.vehicles.vehicle import lanes as vl
    from railgym.vehicles.vehicle.model import lpr_arrays
    from surrogates.models.lpr import lpr_scratch

    lpr = lpr_arrays(default_vertical_surrogate("static"))
    lw = lpr_scratch(lpr.exps, lpr.lo, lpr.up)
    w = np.zeros((vl._ROWS, vl.LANES))
    pt = np.zeros((2, lw.shape[1], vl.LANES))
    return vl._element, (w, pt, lpr, lw, np.zeros(2), vl.LANES)


def _lane_element_args() -> tuple[Any, tuple]:
    """The vertical lane kernel's element evaluation and arguments for one block."""
    from railgym.vehicles.collect import default_vertical_surrogate
    from railgym.vehicles.vertical import lanes
    from railgym.vehicles.vertical.kernels import surrogate_arrays
    from surrogates.models.lpr import lpr_scratch

    lpr = surrogate_arrays(default_vertical_surrogate())
    w = np.zeros((lanes._ROWS, lanes.LANES))
    lw = lpr_scratch(lpr.exps, lpr.lo, lpr.up)
    return lanes._element, (w, lpr, lw, np.zeros(lpr.lo.shape[0]), lanes.LANES)


def vectorisation_gain() -> tuple[tuple[float, float], tuple[float, float]]:
    """Kernel-only env-steps/s of the vertical lane kernel (1024 envs, one thread) compiled
    with and without LLVM's loop vectoriser, each in a fresh process and numba cache:
    ``((median, spread) on, (median, spread) off)``."""
    rates = []
    for flag in ("1", "0"):
        with tempfile.TemporaryDirectory() as cache:
            env = {**os.environ, "NUMBA_LOOP_VECTORIZE": flag, "NUMBA_CACHE_DIR": cache}
            res = subprocess.run(
                [
                    sys.executable,
                    "-m",
                    "benchmarks._lanes_rate",
                    str(_timing.REPEATS),
                    str(_timing.WINDOW_S),
                ],
                env=env,
                capture_output=True,
                text=True,
                check=True,
            )
            median, spread = (float(x) for x in res.stdout.split()[-2:])
            rates.append((median, spread))
    return rates[0], rates[1]


def run() -> list[dict]:
    """Rows of measurements (see ``benchmarks/__main__.py``)."""
    peak_samples = peak_gflops()
    peak = float(np.median(peak_samples))
    threads = numba.get_num_threads()
    rows = [
        measured(
            "FMA peak, 1 thread (anchor)", peak_samples, "GFLOP/s", context="numba a*b+c, float64"
        )
    ]
    cart = gym.make_vec("CartPole-v1", num_envs=N_VEC, vectorization_mode="vector_entry_point")
    cart_steps = _Threaded(cart, 100, threads)
    for env_id, flop in FLOP_PER_STEP.items():
        rows += _env_rows(env_id, flop, cart_steps, threads, peak)
    return rows + _kernel_rows()


def _env_rows(
    env_id: str, flop: float | None, cart_steps: _Threaded, threads: int, peak: float
) -> list[dict]:
    """One env's vector env-steps/s on 1 and ``threads`` threads against CartPole's
    (``cart_steps``), measured interleaved; GFLOP/s against the FMA ``peak`` where ``flop``
    per step is known."""
    venv = gym.make_vec(env_id, num_envs=N_VEC, vectorization_mode="vector_entry_point")
    name = env_id.split("/")[1]
    fns = {
        "cart": cart_steps,
        "one": _Threaded(venv, 10, 1),
        "all": _Threaded(venv, 10, threads),
    }
    w = interleaved(fns)
    numba.set_num_threads(threads)
    r_cart, r1, r_all = (rate(fns[k], w[k].seconds) for k in ("cart", "one", "all"))
    rows = [
        measured(f"CartPoleVectorEnv ({N_VEC}) (anchor, {name})", r_cart / 1e6, "M steps/s"),
        measured(f"{name} vector ({N_VEC}), 1 thread", r1 / 1e6, "M steps/s"),
        measured(f"{name} vector ({N_VEC}), {threads} threads", r_all / 1e6, "M steps/s"),
    ]
    if flop is not None:
        gflops = r1 * flop / 1e9
        rows.append(
            measured(
                f"  GFLOP/s, 1 thread ({name})",
                gflops,
                "GFLOP/s",
                context=f"{flop:.0f} flop/step est., "
                f"{100 * float(np.median(gflops)) / peak:.1f} % of peak",
            )
        )
    rows.append(
        measured(
            f"  share of CartPoleVectorEnv ({name})",
            100 * r_all / r_cart,
            "%",
            TARGET_SHARE.get(name.split("-")[0], ""),
            f"{threads} threads",
        )
    )
    return rows


def _kernel_rows() -> list[dict]:
    """The lane kernels' vectorisation gain and packed share of double arithmetic."""
    (on, s_on), (off, s_off) = vectorisation_gain()
    rows = [
        row(
            "VerticalSuspension lane kernel, vectorised",
            on / 1e6,
            "M steps/s",
            context="1 thread",
            spread=s_on,
        ),
        row(
            "  same with loop vectorisation off",
            off / 1e6,
            "M steps/s",
            context=f"NUMBA_LOOP_VECTORIZE=0: the vectoriser gives {on / off:.2f} ×",
            spread=s_off,
        ),
    ]
    for what, (fn, args), note in (
        (
            "VerticalSuspension lane kernel, element",
            _lane_element_args(),
            "Legendre recurrences over a block of sub-envs vectorise; each loop keeps a scalar "
            "remainder, and the out-of-box fallback is scalar",
        ),
        (
            "VerticalVehicle lane kernel, element",
            _vehicle_element_args(),
            "recurrences and term sums over a block vectorise; scalar remainders and the "
            "out-of-box fallback",
        ),
    ):
        packed, scalar = packed_share(fn, args)
        rows.append(
            row(
                f"  packed share of double arithmetic ({what.split()[0]})",
                100 * packed / max(packed + scalar, 1),
                "%",
                context=f"{what} asm: {packed} packed, {scalar} scalar ({note})",
            )
        )
    return rows


if __name__ == "__main__":
    for r in run():
        print(r)
