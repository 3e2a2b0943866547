"""Energy consistency of crash elements: passivity over loading–unloading cycles, rebound energy.

A crush element that starts unloaded is *passive* if the work it has received,
``W(t) = ∫ f du`` (compression positive, ``u`` its crush or feature), is never negative: it
never returns more than it received, and over any closed cycle it dissipates
(``∮ f du ≥ 0``). Passivity alone does not catch an element that gives back far more than a
crushed zone can: an elastoplastic zone unloading from force ``f_r`` returns at most its
elastic energy ``f_r² / (2 k_u)`` (``k_u`` its unloading stiffness), the rest of the work is
plastic. :func:`rebound_energy_ratio` compares what an element returns on each unloading run
with that bound.

:func:`element_force_history` drives a fitted surrogate element
(:class:`railgym.vehicles.crash.surrogate.CrashElement`) along a prescribed crush history with the
kernels' own element law, so both checks apply to the shipped elements.
:func:`repaired_paper_history` prototypes an energy-consistent ``"paper"`` element (see its
docstring); it is not used by the crash models.

Why the ``"paper"`` variant rebounds too fast: its branch is chosen by the sign of the crush
rate and the unloading LPR is fitted on the few rebound samples; clipped to the range of its
data it holds the largest rebound force from the largest crush down over the whole unloading
run, while the reference zone's force drops to zero within ``f / k_u``. The element can stay
passive and still return many times the elastic energy a zone can store. Being memoryless, it
cannot know where unloading started, so no choice of its unloading curve alone bounds the
returned energy for every crush at which unloading may start. Measured figures:
``docs/envs/crash_baselines.md``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from railgym.vehicles.crash.surrogate import VARIANTS, CrashElement
from railgym.vehicles.crash.surrogate_model import crash_element_force, crash_element_model

__all__ = [
    "CycleWork",
    "element_force_history",
    "element_work",
    "is_passive",
    "rebound_energy_ratio",
    "repaired_paper_history",
]


class CycleWork(NamedTuple):
    """Work (J) an element exchanged along a crush history (trapezoidal ``Σ f̄ Δu``).

    Attributes
    ----------
    received : sum of the positive increments ``f̄ Δu``.
    returned : minus the sum of the negative increments.
    net : ``received − returned`` (≥ 0 over a closed cycle of a passive element).
    min_cumulative : lowest cumulative work ``W(t)`` (< 0: it returned more than it received).
    """

    received: float
    returned: float
    net: float
    min_cumulative: float


def _path(u: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    u, f = np.asarray(u, dtype=float), np.asarray(f, dtype=float)
    if u.ndim != 1 or u.shape != f.shape or u.size < 2:
        raise ValueError(f"u and f must be 1-D arrays of one shape (≥ 2), got {u.shape}, {f.shape}")
    if not (np.all(np.isfinite(u)) and np.all(np.isfinite(f))):
        raise ValueError("u and f must be finite")
    return u, f


def _increments(u: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Work increments ``½ (f_k + f_{k+1}) (u_{k+1} − u_k)`` (J), as the kernels book it."""
    return 0.5 * (f[1:] + f[:-1]) * np.diff(u)


def element_work(u: np.ndarray, f: np.ndarray) -> CycleWork:
    """:class:`CycleWork` of an element with force ``f`` (N) along crush ``u`` (m)."""
    u, f = _path(u, f)
    dw = _increments(u, f)
    cumulative = np.concatenate(([0.0], np.cumsum(dw)))
    received, returned = float(dw[dw > 0].sum()), float(-dw[dw < 0].sum())
    return CycleWork(received, returned, received - returned, float(cumulative.min()))


def is_passive(u: np.ndarray, f: np.ndarray, rtol: float = 1e-9) -> bool:
    """``True`` if the cumulative work along ``u`` (m), ``f`` (N), starting unloaded, never falls
    below ``−rtol`` × the work received."""
    w = element_work(u, f)
    return w.min_cumulative >= -rtol * max(w.received, 0.0)


def rebound_energy_ratio(u: np.ndarray, f: np.ndarray, unloading_stiffness: float) -> float:
    """Largest ratio, over the unloading runs of the history, of the work returned on the run
    to the elastic energy ``f_r² / (2 k_u)`` at the run's first force ``f_r``.

    An unloading run is a maximal stretch of decreasing ``u``; a consistent elastoplastic
    element has a ratio ≤ 1. Returns ``inf`` if a run returns work from ``f_r ≤ 0``.
    """
    u, f = _path(u, f)
    if not (np.isfinite(unloading_stiffness) and unloading_stiffness > 0):
        raise ValueError(f"unloading_stiffness must be positive (N/m), got {unloading_stiffness!r}")
    dw = _increments(u, f)
    down = np.diff(u) < 0
    worst = 0.0
    k = 0
    while k < down.size:
        if not down[k]:
            k += 1
            continue
        end = k
        while end < down.size and down[end]:
            end += 1
        returned = -float(dw[k:end].sum())
        bound = 0.5 * max(f[k], 0.0) ** 2 / unloading_stiffness
        if returned > 0:
            worst = max(worst, returned / bound if bound > 0 else np.inf)
        k = end
    return worst


def _branch_forces(element: CrashElement, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Loading and unloading LPR values at ``u`` (the loading ones twice for ``"hysteretic"``)."""
    load = element.loading.predict(u[:, None])
    unload = element.unloading.predict(u[:, None]) if element.unloading is not None else load
    return load, unload


def element_force_history(element: CrashElement, u: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Force (N) of a surrogate element along the crush history ``u`` (m) at times ``t`` (s),
    by the kernels' element law (branch by the crush rate ``np.gradient(u, t)``, permanent set
    carried along), absorber scale 1."""
    u, t = _path(u, np.asarray(t, dtype=float))
    rate = np.gradient(u, t)
    load, unload = _branch_forces(element, u)
    ranges = (element.force_range["loading"], element.force_range.get("unloading", (0.0, 0.0)))
    variant = VARIANTS.index(element.variant)
    ku, kt, slack = element.unloading_stiffness, element.tension_stiffness, element.slack
    f = np.zeros(u.size)
    up = 0.0
    for k in range(u.size):
        mdl = crash_element_model(u[k], rate[k], up, variant, element.unilateral, ku, 0, 1)
        f_lpr, (f_min, f_max) = (load[k], ranges[0]) if mdl == 0 else (unload[k], ranges[1])
        if mdl < 0:
            f_lpr = f_min = f_max = 0.0
        law = (variant, element.unilateral, ku, kt, slack)
        f[k], up = crash_element_force(u[k], up, f_lpr, f_min, f_max, 1.0, *law)
    return f


def repaired_paper_history(element: CrashElement, u: np.ndarray) -> np.ndarray:
    """Force (N) along ``u`` (m) of an energy-consistent ``"paper"`` element (prototype).

    It keeps the paper's two fitted branches and switches between them, but by the crush
    history instead of the crush rate, with the reversal point as state (largest crush ``u_r``
    and the force ``f_r`` there):

    * virgin loading, ``u ≥ u_r``: the loading LPR (clipped to its data range), ``u_r, f_r``
      follow;
    * below the largest crush, unloading and reloading alike: the unloading LPR shifted to
      pass through the reversal point, ``f_r + f_U(u) − f_U(u_r)``, kept between the lowest
      unloading force of the data (0 for the wall) and ``min(f_L(u), f_r − k̂_u (u_r − u))``.

    Below the largest crush the force is one function of ``u``, so a loop there exchanges no
    net work and a return to the envelope is continuous; the cap by the elastic line from the
    reversal bounds the work returned from ``f_r`` by ``f_r² / (2 k̂_u)``, and the cap by the
    loading branch keeps every closed cycle dissipative. The price is one state pair per
    element, i.e. this is the ``"hysteretic"`` variant with a fitted unloading shape under its
    elastic line.
    """
    if element.variant != "paper" or element.unloading is None:
        raise ValueError(f"element must be a 'paper' variant element, got {element.variant!r}")
    u = np.asarray(u, dtype=float)
    load, unload = _branch_forces(element, u)
    lo_l, hi_l = element.force_range["loading"]
    lo_u, _ = element.force_range["unloading"]
    floor = 0.0 if element.unilateral else min(lo_u, 0.0)
    ku = element.unloading_stiffness
    f = np.zeros(u.size)
    u_r = f_r = fu_r = 0.0
    for k in range(u.size):
        f_load = min(max(load[k], lo_l), hi_l)
        if element.unilateral and u[k] <= 0.0:
            f[k] = 0.0
        elif u[k] >= u_r:
            f[k] = max(f_load, 0.0) if element.unilateral else f_load
            u_r, f_r, fu_r = u[k], f[k], unload[k]
        else:
            cap = min(f_load, f_r - ku * (u_r - u[k]))
            f[k] = min(max(f_r + unload[k] - fu_r, floor), max(cap, floor))
    return f
