"""Vector-env throughput per core and on all cores, achieved GFLOP/s against a measured peak.

For each env at 1024 sub-envs: env-steps/s with ``numba.set_num_threads(1)`` and with the
default thread count, and GFLOP/s from an estimated flop count per env-step:

* ``VerticalSuspension-v0``: 10 RK4 substeps, 4 right-hand sides each with a degree-(10,10)
  LPR element (~2 kflop per step, issue 13's estimate).
* ``VerticalVehicle-v0``: 5 RK4 substeps, 4 right-hand sides each with two degree-(10,10) LPR
  elements (~2 × 121 × 2 multiply-adds) and the 14-state rigid/flexible dynamics (~150
  flop): ~12 kflop per step.
* ``TrainCrash-v0``: 2 velocity-Verlet substeps of a 2-body surrogate with one high-degree
  LPR element (~200 flop each) and the per-step criteria bookkeeping (~200 flop): ~0.6 kflop.

The peak is a numba FMA loop over float64 arrays (``a*b+c`` written in place, cache-resident,
SIMD-vectorised by LLVM) on one thread. The env kernels run one sub-env after another (a
per-env loop with branches, which LLVM does not vectorise across sub-envs); large batches are
spread over threads by ``prange`` over chunks of sub-envs. :func:`packed_share` recompiles the
whole-vehicle per-vehicle kernel (the cached one keeps no assembly) and counts packed
(``…pd``) against scalar (``…sd``) double arithmetic in its assembly.
"""

from __future__ import annotations

import re
import time

import gymnasium as gym
import numba
import numpy as np
from numba import njit

import railgym  # noqa: F401  (registers the environments)
from benchmarks import row

N_VEC = 1024
#: estimated flop per env-step (module docstring)
#: issue 13's share of CartPoleVectorEnv's env-steps/s at 1024 sub-envs, %
TARGET_SHARE = {"railgym/VerticalSuspension-v0": "≥ 25", "railgym/TrainCrash-v0": "≥ 50"}
FLOP_PER_STEP = {
    "railgym/VerticalSuspension-v0": 2e3,
    "railgym/VerticalVehicle-v0": 12e3,
    "railgym/TrainCrash-v0": 0.6e3,
}


@njit(cache=True, fastmath=True)
def _fma(a: np.ndarray, b: np.ndarray, c: np.ndarray, reps: int) -> float:
    """``reps`` passes of ``c = a * b + c``; returns a sum so nothing is optimised away."""
    for _ in range(reps):
        for j in range(c.shape[0]):
            c[j] = a[j] * b[j] + c[j]
    return c.sum()


def peak_gflops(n: int = 2048, reps: int = 20000) -> float:
    """Best-of-5 GFLOP/s of :func:`_fma` on one thread (2 flop per element and pass)."""
    a, b, c = np.full(n, 0.999), np.full(n, 1e-3), np.zeros(n)
    _fma(a, b, c, 1)
    best = np.inf
    for _ in range(5):
        t0 = time.perf_counter()
        _fma(a, b, c, reps)
        best = min(best, time.perf_counter() - t0)
    return 2.0 * n * reps / best / 1e9


def _rate(venv: gym.vector.VectorEnv, n: int) -> float:
    """Best-of-3 env-steps/s over ``n`` steps with zero actions."""
    action = np.zeros(venv.action_space.shape, venv.action_space.dtype)
    venv.reset(seed=0)
    venv.step(action)
    best = np.inf
    for _ in range(3):
        t0 = time.perf_counter()
        for _ in range(n):
            venv.step(action)
        best = min(best, time.perf_counter() - t0)
    return venv.num_envs * n / best


def packed_share() -> tuple[int, int]:
    """Packed and scalar double arithmetic instructions in the assembly of a fresh compile of
    the whole-vehicle per-vehicle kernel (surrogate variant; callees linked in)."""
    from railgym.vehicles import vehicle as vh
    from railgym.vehicles.collect import default_vertical_surrogate

    veh = vh.load_whole_vehicle()
    bt, out = vh.make_batch(1, "surrogate", 10)
    lpr = vh.lpr_arrays(default_vertical_surrogate("static"))
    e = veh.suspension.kernel_params().record()[0]
    s = bt.state.shape[1]
    wk = vh._work(s, lpr)
    args = (3, bt, 0, 1, 2e-3, vh.kernel_params(veh), e, lpr, out, wk)
    fresh = njit(error_model="numpy", _nrt=False)(vh._advance_one.py_func)
    sig = tuple(fresh.typeof_pyval(a) for a in args)
    fresh.compile(sig)
    asm = fresh.inspect_asm(sig)
    ops = r"\tv?(?:add|sub|mul|div|fmadd\d*|fnmadd\d*|fmsub\d*|max|min|sqrt)"
    return len(re.findall(ops + r"pd\t", asm)), len(re.findall(ops + r"sd\t", asm))


def run() -> list[dict]:
    """Rows of measurements (see ``benchmarks/__main__.py``)."""
    peak = peak_gflops()
    threads = numba.get_num_threads()
    rows = [row("FMA peak, 1 thread (anchor)", peak, "GFLOP/s", context="numba a*b+c, float64")]
    cart = gym.make_vec("CartPole-v1", num_envs=N_VEC, vectorization_mode="vector_entry_point")
    r_cart = _rate(cart, 300)
    rows.append(row(f"CartPoleVectorEnv ({N_VEC}) (anchor)", r_cart / 1e6, "M steps/s"))
    for env_id, flop in FLOP_PER_STEP.items():
        venv = gym.make_vec(env_id, num_envs=N_VEC, vectorization_mode="vector_entry_point")
        name = env_id.split("/")[1]
        numba.set_num_threads(1)
        r1 = _rate(venv, 20)
        numba.set_num_threads(threads)
        r_all = _rate(venv, 20)
        rows += [
            row(f"{name} vector ({N_VEC}), 1 thread", r1 / 1e6, "M steps/s"),
            row(f"{name} vector ({N_VEC}), {threads} threads", r_all / 1e6, "M steps/s"),
            row(
                f"  GFLOP/s, 1 thread ({name})",
                r1 * flop / 1e9,
                "GFLOP/s",
                context=f"{flop:.0f} flop/step est., {100 * r1 * flop / 1e9 / peak:.1f} % of peak",
            ),
            row(
                f"  share of CartPoleVectorEnv ({name})",
                100 * r_all / r_cart,
                "%",
                TARGET_SHARE.get(env_id, ""),
                f"{threads} threads",
            ),
        ]
    packed, scalar = packed_share()
    rows.append(
        row(
            "  packed share of double arithmetic",
            100 * packed / max(packed + scalar, 1),
            "%",
            context=f"VerticalVehicle per-vehicle kernel asm: {packed} packed, {scalar} scalar "
            "(short state loops vectorise; branchy RHS and LPR scalar; none across vehicles)",
        )
    )
    return rows


if __name__ == "__main__":
    for r in run():
        print(r)
