"""Compiled pieces shared by the env batches: the divergence rule of the reward
(:func:`settle_reward`), one sample through a streaming weighting filter (:func:`weigh`), and
calling a compiled batch step without numba's per-call type
dispatch (:func:`compiled_entry`).

numba types every argument of every call to find the compiled overload; for the named tuples
of arrays of the batch kernels that costs more than a small step itself. A batch that holds
its arrays for its lifetime resolves the overload once (:func:`compiled_entry`) and calls it
directly.
"""

from __future__ import annotations

import math
from typing import Any

import numba
from numba import njit

__all__ = ["DIVERGENCE_PENALTY", "OBS_LIMIT", "compiled_entry", "settle_reward", "weigh"]

#: reward of a diverged step
DIVERGENCE_PENALTY = 100.0
#: |normalised observation| above this counts as divergence (keeps float32 observations finite)
OBS_LIMIT = 1e30


# inlined into the callers' IR: no call and no reference counting of the arrays per system
@njit(cache=True, inline="always")
def settle_reward(obs, terms, reward, div, i, t_acc, t_defl, t_force):
    """Reward ``reward[i]`` and its terms ``terms[i]`` (acceleration, deflection, force,
    divergence) of system ``i`` from the three weighted terms.

    A step that diverged in the kernel (``div[i]``), whose observation ``obs[i]`` exceeds
    :data:`OBS_LIMIT` or whose reward is not finite is a divergence: ``div[i]`` is set, the
    observation clamped to ``±OBS_LIMIT`` and the reward is ``-DIVERGENCE_PENALTY``.
    """
    r = t_acc + t_defl + t_force
    big = False
    for j in range(obs.shape[1]):
        if not abs(obs[i, j]) <= OBS_LIMIT:
            big = True
    if div[i] or big or not math.isfinite(r):
        div[i] = True
        for j in range(obs.shape[1]):
            obs[i, j] = min(max(obs[i, j], -OBS_LIMIT), OBS_LIMIT)
        t_acc = t_defl = t_force = 0.0
        r = -DIVERGENCE_PENALTY
    terms[i, 0] = t_acc
    terms[i, 1] = t_defl
    terms[i, 2] = t_force
    terms[i, 3] = -DIVERGENCE_PENALTY if div[i] else 0.0
    reward[i] = r


@njit(cache=True, error_model="numpy")
def weigh(sos, zi, v):
    """One sample ``v`` through the cascade ``sos`` (n_sec, 6) of second-order sections in
    transposed direct form II, as ``scipy.signal.sosfilt``; the state ``zi`` (n_sec, 2) is
    updated in place."""
    y = v
    for s in range(sos.shape[0]):
        b0, b1, b2, a1, a2 = sos[s, 0], sos[s, 1], sos[s, 2], sos[s, 4], sos[s, 5]
        out = b0 * y + zi[s, 0]
        zi[s, 0] = b1 * y - a1 * out + zi[s, 1]
        zi[s, 1] = b2 * y - a2 * out
        y = out
    return y


def compiled_entry(fn: Any, args: tuple) -> Any:
    """Compiled entry point of the numba function ``fn`` for the types of ``args``.

    The arrays passed later must keep the dtypes, dimensions and layouts of ``args`` (the
    batch holds them for its lifetime); the entry point is not picklable, so a batch makes it
    again after a copy.

    numba's threading layer is started first: a function loaded from numba's cache that links
    a ``parallel=True`` kernel (the whole-vehicle ``advance`` does) needs the symbols of the
    parallel scheduler, which numba registers only when the layer starts.
    """
    numba.get_num_threads()
    sig = tuple(fn.typeof_pyval(a) for a in args)
    if sig not in fn.overloads:
        fn.compile(sig)
    return fn.overloads[sig].entry_point
