"""Compiled pieces shared by the env batches: the divergence rule of the reward
(:func:`settle_reward`), and calling a compiled batch step without numba's per-call type
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

__all__ = ["DIVERGENCE_PENALTY", "OBS_LIMIT", "compiled_entry", "settle_reward"]

#: reward of a diverged step
DIVERGENCE_PENALTY = 100.0
#: |normalised observation| above this counts as divergence (keeps float32 observations finite)
OBS_LIMIT = 1e30


@njit(cache=True)
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
