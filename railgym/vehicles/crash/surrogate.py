"""Surrogate crash model (paper eq. 4): :func:`build_crash_surrogate`, :func:`simulate_surrogate`.

One mass per car (plus the obstacle, if any); the wall element's feature is
``u = x_lead − x_barrier`` (``x_barrier = 0`` for a rigid wall), the interface's
``u = x_{k+1} − x_k``, both from the cars' centre-of-mass displacements, as the paper's
``(x_1, f_1)`` and ``(x_1 − x_2, f_2)``. Two element variants:

``"paper"``
    one LPR for the loading branch and one for the unloading branch, switched by the sign of
    the crush rate ``u̇`` (paper section 3.1); the training samples are split by
    :func:`surrogates.features.split_branches`. Each LPR's output is clipped to the force
    range of its branch's data: the unloading branch is fitted on few samples (the rebound)
    and, unclipped, its extrapolation throws the cars apart. Being memoryless, this variant
    can push at any crush (e.g. the loading force at rest when ``u̇`` is a hair above zero).
``"hysteretic"``
    the loading LPR is the envelope (fitted on virgin-loading samples only); unloading and
    reloading follow a straight line of stiffness ``k̂_u`` (estimated from the unloading samples)
    from the largest crush reached, with permanent set, exactly like the reference law; so the
    element dissipates energy only on the envelope. Interface tension, if the data have any, is a
    fitted linear spring ``k̂_t`` with slack ``ŝ`` beyond the permanent set.

A wall element never pulls (``f ≥ 0``) in either variant. LPR degrees are chosen by 10-fold
cross-validation (:func:`surrogates.selection.select_kfold`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from numba import njit

from railgym.vehicles.crash.reference import (
    V_EPS,
    CrashResult,
    StopRule,
    _check_run,
    _crash_over,
    _healthy,
    _steps,
    new_outputs,
    new_record,
)
from railgym.vehicles.crash.scenario import CrashScenario, load_scenario
from surrogates.features import LOADING, split_branches
from surrogates.models.lpr import lpr_eval_into, lpr_scratch
from surrogates.selection import factory_for, select_kfold

__all__ = [
    "VARIANTS",
    "CrashElement",
    "CrashSurrogate",
    "ElementTypes",
    "LprModels",
    "SurrogateParams",
    "SurrogateState",
    "TrainingSet",
    "build_crash_surrogate",
    "crash_errors",
    "crash_training_data",
    "simulate_surrogate",
    "surrogate_batch_step",
    "virgin_loading",
]

#: element variants of the surrogate model
VARIANTS = ("paper", "hysteretic")


@dataclass
class CrashElement:
    """One surrogate crash element (paper eq. 4), fitted on reference time histories.

    Attributes
    ----------
    name : ``"wall"`` (lead car against the barrier) or ``"interface"`` (between two cars).
    variant : ``"paper"`` or ``"hysteretic"`` (see the module docstring).
    loading : LPR of the loading branch (``"paper"``) or of the envelope (``"hysteretic"``),
        force (N) of the feature ``u`` (m).
    unloading : LPR of the unloading branch (``"paper"`` only).
    unloading_stiffness : ``k̂_u`` of elastic unloading/reloading, N/m (estimated for both
        variants, used by ``"hysteretic"``).
    tension_stiffness, slack : fitted coupler tension ``k̂_t`` (N/m; 0 = none) and slack ``ŝ``
        (m) beyond the permanent set (``"hysteretic"``).
    unilateral : the element never pulls and carries no force for ``u ≤ 0`` (the wall).
    force_range : (branch → (lowest, highest) training force, N); each LPR's output is clipped
        to its branch's range, so that a branch extrapolated beyond its data (the paper
        variant's unloading branch, fitted on a narrow set) cannot produce unseen forces.
    selection : 10-fold cross-validation table of each fitted LPR (branch → SelectionResult).
    n_samples : number of training samples of each branch.
    """

    name: str
    variant: str
    loading: Any
    unloading: Any
    unloading_stiffness: float
    tension_stiffness: float
    slack: float
    unilateral: bool
    force_range: dict[str, tuple[float, float]]
    selection: dict[str, Any]
    n_samples: dict[str, int]

    @property
    def degrees(self) -> dict[str, int]:
        """Chosen LPR degree of each branch."""
        out = {"loading": _degree(self.loading)}
        if self.unloading is not None:
            out["unloading"] = _degree(self.unloading)
        return out


@dataclass
class CrashSurrogate:
    """The surrogate elements of one model: ``elements["wall"]`` and ``elements["interface"]``."""

    variant: str
    elements: dict[str, CrashElement]
    source: str
    build_time: float


def _degree(model: Any) -> int:
    d = model.degree
    return int(d[0] if isinstance(d, tuple) else d)


TrainingSet = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]


def crash_training_data(result: CrashResult, branch_tol: float = 0.01) -> dict[str, TrainingSet]:
    """Surrogate training data ``(u, f, u̇, loading, series)`` per element type.

    ``u`` from the cars' centre-of-mass displacements: wall ``x_lead − x_barrier``, interface
    ``x_{k+1} − x_k`` (all interfaces pooled); ``f`` the zone's force (N); ``u̇`` by
    :func:`numpy.gradient` of each series (m/s); ``loading`` the loading-branch mask of
    :func:`surrogates.features.split_branches` (sign of the crush rate with hysteresis
    ``branch_tol`` × the 90th percentile of |u̇|; its default 0.05, i.e. ~0.5 m/s in a 40 km/h
    crash, would label the slow rebound as loading); ``series`` the index of the time
    history each sample comes from (one per interface).
    """
    t = result.t
    if t.size < 3:
        raise ValueError("result has fewer than 3 samples: too short to train on")
    names = result.body_names
    x_bar = result.x[:, names.index("obstacle")] if "obstacle" in names else 0.0
    n_cars = result.scenario.n_cars
    series: dict[str, list[tuple[np.ndarray, np.ndarray]]] = {"wall": [], "interface": []}
    wall = result.force[:, result.zone_names.index("wall")]
    series["wall"].append((result.x[:, 0] - x_bar, wall))
    for k in range(1, n_cars):
        j = result.zone_names.index(f"interface_{k}")
        series["interface"].append((result.x[:, k] - result.x[:, k - 1], result.force[:, j]))
    out = {}
    for key, items in series.items():
        if items:
            u = np.concatenate([s[0] for s in items])
            f = np.concatenate([s[1] for s in items])
            rate = np.concatenate([np.gradient(s[0], t) for s in items])
            load = np.concatenate(
                [split_branches(s[0], t, tol=branch_tol) == LOADING for s in items]
            )
            series_id = np.repeat(np.arange(len(items)), t.size)
            out[key] = (u, f, rate, load, series_id)
    return out


def virgin_loading(
    u: np.ndarray, rate: np.ndarray, series: np.ndarray | None = None, tol: float = 1e-4
) -> np.ndarray:
    """Mask of the samples on the virgin loading path: crush growing and within ``tol`` (m) of
    the largest crush reached so far in the same time history (``series``, default one)."""
    series = np.zeros(u.size, dtype=np.int64) if series is None else series
    out = np.zeros(u.size, dtype=bool)
    for k in np.unique(series):
        i = series == k
        out[i] = (rate[i] > 0.0) & (u[i] >= np.maximum.accumulate(u[i]) - tol)
    return out


def _fit_lpr(u: np.ndarray, f: np.ndarray, max_degree: int, seed: int) -> tuple[Any, Any]:
    """LPR of f(u) with the degree chosen by 10-fold CV (``clip`` extrapolation)."""
    n = u.size
    if n < 4:
        raise ValueError(f"too few training samples ({n}) to fit a surrogate branch")
    make = factory_for("lpr", extrapolation="clip")
    cands = list(range(1, min(max_degree, n - 2) + 1))
    sel = select_kfold(make, cands, u[:, None], f, k=min(10, n), seed=seed)
    return make(sel.best).fit(u[:, None], f), sel


def _unloading_stiffness(
    u: np.ndarray, f: np.ndarray, rate: np.ndarray, series: np.ndarray
) -> float:
    """Least-squares slope (N/m) of Δf against Δu over consecutive unloading samples under load."""
    du, df = np.diff(u), np.diff(f)
    ok = (rate[1:] < 0) & (rate[:-1] < 0) & (f[1:] > 0) & (f[:-1] > 0) & (du < 0) & (df < 0)
    ok &= series[1:] == series[:-1]
    if np.count_nonzero(ok) < 2:
        raise ValueError("the training data hold no elastic unloading: k_u cannot be estimated")
    return float(np.sum(df[ok] * du[ok]) / np.sum(du[ok] ** 2))


def build_crash_surrogate(
    reference: CrashResult,
    variant: str = "hysteretic",
    seed: int = 0,
    max_degree: int = 30,
) -> CrashSurrogate:
    """Fit the surrogate elements of paper eq. (4) on a reference result.

    Parameters
    ----------
    reference : output of :func:`simulate_reference`.
    variant : ``"paper"`` (loading/unloading LPR switched by the crush rate) or
        ``"hysteretic"`` (LPR envelope + elastic unloading, energy-consistent).
    seed : seed of the cross-validation folds.
    max_degree : largest LPR degree tried by 10-fold cross-validation.
    """
    if variant not in VARIANTS:
        raise ValueError(f"variant must be one of {VARIANTS}, got {variant!r}")
    if reference.model != "reference":
        raise ValueError(f"reference must be a reference-model result, got {reference.model!r}")
    t0 = time.perf_counter()
    elements = {}
    for name, (u, f, rate, loading, series) in crash_training_data(reference).items():
        unilateral = name == "wall"
        sel: dict[str, Any] = {}
        n: dict[str, int] = {}
        kt = slack = 0.0
        unload = None
        if variant == "paper":
            lo, un = loading, ~loading
            load, sel["loading"] = _fit_lpr(u[lo], f[lo], max_degree, seed)
            unload, sel["unloading"] = _fit_lpr(u[un], f[un], max_degree, seed)
            n = {"loading": int(lo.sum()), "unloading": int(un.sum())}
            rng = {"loading": (f[lo].min(), f[lo].max()), "unloading": (f[un].min(), f[un].max())}
            ku = _unloading_stiffness(u, f, rate, series)
        else:
            vg = virgin_loading(u, rate, series) & (f > 0)
            uu = np.concatenate(([0.0], u[vg]))
            ff = np.concatenate(([0.0], f[vg]))
            load, sel["loading"] = _fit_lpr(uu, ff, max_degree, seed)
            ku = _unloading_stiffness(u, f, rate, series)
            n = {"loading": int(uu.size)}
            rng = {"loading": (0.0, ff.max())}
            tension = f < 0
            if not unilateral and np.count_nonzero(tension) >= 5:
                # f = k_t (u − u_0) on the tension samples; slack measured from the final set
                A = np.column_stack([u[tension], np.ones(np.count_nonzero(tension))])
                (kt, c), *_ = np.linalg.lstsq(A, f[tension], rcond=None)
                up = _permanent_set_history(u, series, load, ku)
                slack = max(0.0, float(up[tension].mean() + c / kt)) if kt > 0 else 0.0
                kt = max(float(kt), 0.0)
                n["tension"] = int(np.count_nonzero(tension))
        elements[name] = CrashElement(
            name=name,
            variant=variant,
            loading=load,
            unloading=unload,
            unloading_stiffness=ku,
            tension_stiffness=kt,
            slack=slack,
            unilateral=unilateral,
            force_range={k: (float(a), float(b)) for k, (a, b) in rng.items()},
            selection=sel,
            n_samples=n,
        )
    return CrashSurrogate(
        variant=variant,
        elements=elements,
        source=reference.scenario.name,
        build_time=time.perf_counter() - t0,
    )


def _permanent_set_history(
    u: np.ndarray, series: np.ndarray, envelope: Any, ku: float
) -> np.ndarray:
    """Permanent set (m) along each feature history ``u`` under the hysteretic element law."""
    env = envelope.predict(u[:, None])
    up = np.zeros_like(u)
    cur = 0.0
    for i in range(u.size):
        if i > 0 and series[i] != series[i - 1]:
            cur = 0.0
        if env[i] > 0 and ku * (u[i] - cur) >= env[i]:
            cur = u[i] - env[i] / ku
        up[i] = cur
    return up


class LprModels(NamedTuple):
    """Kernel arrays of the element LPR models (:func:`_pack_models`), one row per model.

    Attributes
    ----------
    exponents : (models, terms, 1) int64, zero-padded to a common term count.
    coef : (models, terms) coefficients.
    lower, upper : (models, 1) input domain, m.
    mode : (models,) extrapolation mode of :func:`surrogates.models.lpr.lpr_eval_into`.
    force_range : (models, 2) lowest and highest training force of each model, N.
    """

    exponents: np.ndarray
    coef: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    mode: np.ndarray
    force_range: np.ndarray


class ElementTypes(NamedTuple):
    """Element characteristics, one row per element type (wall, interface).

    Attributes
    ----------
    variant : 0 ``"paper"``, 1 ``"hysteretic"``.
    load_model, unload_model : row of the loading / unloading LPR in :class:`LprModels`.
    unilateral : 1 if the element never pulls.
    unloading_stiffness, tension_stiffness, slack : ``k̂_u``, ``k̂_t`` (N/m) and ``ŝ`` (m).
    absorber : absorber stroke in the feature ``u``, m.
    """

    variant: np.ndarray
    load_model: np.ndarray
    unload_model: np.ndarray
    unilateral: np.ndarray
    unloading_stiffness: np.ndarray
    tension_stiffness: np.ndarray
    slack: np.ndarray
    absorber: np.ndarray


class SurrogateParams(NamedTuple):
    """Static arrays of the surrogate model (paper eq. 4), passed into the kernels.

    Attributes
    ----------
    m, mu : (bodies,) body mass (kg) and friction coefficient.
    gravity, v_eps : m/s² and the friction regularisation velocity, m/s.
    front, back, kind : (elements,) bodies each element joins (front −1 = wall) and its row
        of ``types``.
    types : the :class:`ElementTypes` table. lpr : the :class:`LprModels`.
    """

    m: np.ndarray
    mu: np.ndarray
    gravity: float
    v_eps: float
    front: np.ndarray
    back: np.ndarray
    kind: np.ndarray
    types: ElementTypes
    lpr: LprModels


class SurrogateState(NamedTuple):
    """Per-simulation state of :func:`surrogate_batch_step`, one row per simulation.

    Attributes
    ----------
    x, v, a : (n, bodies) displacement (m), velocity (m/s), acceleration (m/s²).
    up, fz : (n, elements) permanent set in ``u`` (m) and force (N) of each element.
    ff : (n, bodies) friction force magnitude along v, N.
    """

    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    up: np.ndarray
    fz: np.ndarray
    ff: np.ndarray


def _new_surrogate_state(n: int, n_bodies: int, n_elements: int) -> SurrogateState:
    """Zeroed :class:`SurrogateState` of ``n`` simulations."""
    body = [np.zeros((n, n_bodies)) for _ in range(3)]
    el = [np.zeros((n, n_elements)) for _ in range(2)]
    return SurrogateState(*body, *el, np.zeros((n, n_bodies)))


@njit(cache=True)
def _lpr_work(lpr):
    """Scratch of :func:`surrogates.models.lpr.lpr_eval_into` for every model of ``lpr``
    (:class:`LprModels`): float64 (models, d + 4, L), one common width ``L``."""
    E, LO, UP = lpr.exponents, lpr.lower, lpr.upper
    n, T, d = E.shape
    every = E.reshape(n * T, d)  # the largest degree of all models sets the common width
    first = lpr_scratch(every, LO[0], UP[0])
    work = np.empty((n, first.shape[0], first.shape[1]))
    work[0] = first
    for k in range(1, n):
        work[k] = lpr_scratch(every, LO[k], UP[k])
    return work


@njit(cache=True, inline="always")
def _element_model(u, rate, up, variant, unilateral, ku, i_load, i_unload):
    """Index of the LPR model the element law (:func:`_element_force`) reads at feature ``u``,
    rate ``u̇`` and permanent set ``up``; −1 where it needs none."""
    if unilateral and u <= 0.0:
        return -1
    if variant == 0:
        return i_load if rate >= 0.0 else i_unload
    return i_load if ku * (u - up) > 0.0 else -1


@njit(cache=True, inline="always")
def _element_force(u, up, f_lpr, f_min, f_max, s, variant, unilateral, ku, kt, slack):
    """Force (N, compression positive) and new permanent set of one surrogate element.

    ``f_lpr`` is the value at ``u`` of the LPR model chosen by :func:`_element_model` and
    ``[f_min, f_max]`` that model's force range, N (unused where it chose none). ``s``
    multiplies the LPR force (controllable absorber, 1 beyond the absorber stroke, as
    :func:`absorber_zone_force`). ``variant`` 0 is ``"paper"``, 1 ``"hysteretic"``; ``k_u``,
    ``k_t`` (N/m) and ``slack`` (m) as in :class:`CrashElement`.
    """
    if unilateral and u <= 0.0:
        return 0.0, up
    if variant == 0:
        f = s * min(max(f_lpr, f_min), f_max)
        if unilateral and f < 0.0:
            f = 0.0
        return f, up
    trial = ku * (u - up)
    if trial > 0.0:
        env = s * min(f_lpr, f_max)
        if env <= 0.0:
            return 0.0, up
        if trial >= env:
            return env, u - env / ku
        return trial, up
    if kt > 0.0 and u < up - slack:
        return kt * (u - up + slack), up
    return 0.0, up


# The element evaluation sits in the kernel's loop body (arrays unpacked once per call): behind
# a helper taking the packed arrays, numba's reference counting of those arrays costs more
# than the physics.
@njit(cache=True)
def surrogate_batch_step(state, out, params, scale, active, init, dt, n_sub, limit, div):
    """:func:`reference_batch_step` for the surrogate model (paper eq. 4).

    ``state`` is a :class:`SurrogateState`, ``params`` :class:`SurrogateParams`. No dampers:
    ``dissipated[:, 1]`` stays 0.
    """
    x, v, a, up, fel, ff = state.x, state.v, state.a, state.up, state.fz, state.ff
    m, mu, g, veps = params.m, params.mu, params.gravity, params.v_eps
    el_front, el_back, el_type = params.front, params.back, params.kind
    ty_ = params.types
    variant, i_load, i_unload, unilateral = (
        ty_.variant, ty_.load_model, ty_.unload_model, ty_.unilateral,
    )  # fmt: skip
    ku, kt, slack, absorber = (
        ty_.unloading_stiffness, ty_.tension_stiffness, ty_.slack, ty_.absorber,
    )  # fmt: skip
    lpr = params.lpr
    E, C, LO, UP, MODE, FR = (
        lpr.exponents,
        lpr.coef,
        lpr.lower,
        lpr.upper,
        lpr.mode,
        lpr.force_range,
    )
    N = m.shape[0]
    ne = el_front.shape[0]
    nodes = np.empty((8, N))
    xl, vl, al, vp = nodes[0], nodes[1], nodes[2], nodes[3]
    F, dx, ffl, ff_o = nodes[4], nodes[5], nodes[6], nodes[7]
    els = np.empty((6, ne))
    upl, fl, f_o, ul, u_o, wl = els[0], els[1], els[2], els[3], els[4], els[5]
    ubuf = np.zeros(1)
    work = _lpr_work(lpr)
    ox, ov, oa, crush, force, rate_out = out.x, out.v, out.a, out.crush, out.force, out.rate
    work_done, dissipated, stored = out.work, out.dissipated, out.stored
    # rows are copied element by element: a row view per array and train costs two atomic
    # reference-count operations
    for i in range(x.shape[0]):
        if not active[i]:
            continue
        for j in range(N):
            xl[j], vl[j], al[j], ffl[j] = x[i, j], v[i, j], a[i, j], ff[i, j]
        for e in range(ne):
            upl[e], fl[e], ul[e], wl[e] = up[i, e], fel[i, e], crush[i, e], work_done[i, e]
        w_fric = dissipated[i, 0]
        # init: forces at the current state; else n_sub velocity-Verlet steps
        for _ in range(1 if init else n_sub):
            if init:
                vp[:] = vl
            else:
                f_o[:], ff_o[:], u_o[:] = fl, ffl, ul
                for j in range(N):
                    dx[j] = vl[j] * dt + 0.5 * al[j] * dt * dt
                    xl[j] += dx[j]
                    vp[j] = vl[j] + al[j] * dt
            for j in range(N):
                ffl[j] = mu[j] * m[j] * g * math.tanh(vp[j] / veps)
                F[j] = -ffl[j]
            for e in range(ne):
                fr, bk, ty = el_front[e], el_back[e], el_type[e]
                u = xl[bk] - (xl[fr] if fr >= 0 else 0.0)
                rate = vp[bk] - (vp[fr] if fr >= 0 else 0.0)
                mdl = _element_model(
                    u, rate, upl[e], variant[ty], unilateral[ty], ku[ty], i_load[ty], i_unload[ty]
                )
                f_lpr = f_min = f_max = 0.0
                if mdl >= 0:
                    ubuf[0] = u
                    f_lpr = lpr_eval_into(
                        ubuf, E[mdl], C[mdl], LO[mdl], UP[mdl], MODE[mdl], work[mdl]
                    )
                    f_min, f_max = FR[mdl, 0], FR[mdl, 1]
                s = scale[i, e] if u <= absorber[ty] else 1.0
                f, upl[e] = _element_force(
                    u, upl[e], f_lpr, f_min, f_max, s, variant[ty], unilateral[ty], ku[ty],
                    kt[ty], slack[ty],
                )  # fmt: skip
                fl[e] = f
                ul[e] = u
                if fr >= 0:
                    F[fr] += f
                F[bk] -= f
            for j in range(N):
                a_new = F[j] / m[j]
                if not init:
                    vl[j] += 0.5 * (al[j] + a_new) * dt
                    w_fric += 0.5 * (ff_o[j] + ffl[j]) * dx[j]
                al[j] = a_new
            if not init:
                for e in range(ne):
                    wl[e] += 0.5 * (f_o[e] + fl[e]) * (ul[e] - u_o[e])
        if not _healthy(xl, vl, al, limit):
            div[i] = True
            continue
        energy = 0.0
        for j in range(N):
            x[i, j], v[i, j], a[i, j], ff[i, j] = xl[j], vl[j], al[j], ffl[j]
            ox[i, j], ov[i, j], oa[i, j] = xl[j], vl[j], al[j]
            energy += 0.5 * m[j] * vl[j] * vl[j]
        stored[i] = energy
        dissipated[i, 0] = w_fric
        for e in range(ne):
            up[i, e], fel[i, e] = upl[e], fl[e]
            crush[i, e], force[i, e], work_done[i, e] = ul[e], fl[e], wl[e]
            fr = el_front[e]
            rate_out[i, e] = vl[el_back[e]] - (vl[fr] if fr >= 0 else 0.0)


@njit(cache=True)
def _record_surrogate(state, out, params, dt, n_sub, stop, rec):
    """Record simulation 0 of ``state`` sample by sample with :func:`surrogate_batch_step`
    into ``rec`` (:class:`Record`); returns the number of samples taken."""
    scale = np.ones((1, params.front.shape[0]))
    active = np.ones(1, np.bool_)
    div = np.zeros(1, np.bool_)
    for k in range(rec.x.shape[0]):
        surrogate_batch_step(state, out, params, scale, active, k == 0, dt, n_sub, math.inf, div)
        rec.x[k], rec.v[k], rec.a[k] = out.x[0], out.v[0], out.a[0]
        rec.crush[k], rec.force[k], rec.permanent_set[k] = out.crush[0], out.force[0], state.up[0]
        if stop.enabled and k > 0 and _crash_over(out, state.fz, stop):
            return k + 1
    return rec.x.shape[0]


def _pack_models(models: list[Any], ranges: list[tuple[float, float]]) -> LprModels:
    """Kernel arrays of several 1-input LPR models, zero-padded to a common term count, and
    their output ranges (models, 2)."""
    arrays = [mdl.kernel_arrays() for mdl in models]
    T = max(a[0].shape[0] for a in arrays)
    E = np.zeros((len(arrays), T, 1), dtype=np.int64)
    C = np.zeros((len(arrays), T))
    LO = np.zeros((len(arrays), 1))
    UP = np.zeros((len(arrays), 1))
    MODE = np.zeros(len(arrays), dtype=np.int64)
    for i, (e, c, lo, up, mode) in enumerate(arrays):
        if e.shape[1] != 1:
            raise ValueError(f"surrogate element model {i} has {e.shape[1]} inputs, expected 1")
        E[i, : e.shape[0]] = e
        C[i, : c.size] = c
        LO[i], UP[i], MODE[i] = lo, up, mode
    FR = np.array(ranges, dtype=np.float64).reshape(len(arrays), 2)
    return LprModels(E, C, LO, UP, MODE, FR)


@dataclass
class _System:
    """The surrogate model of one scenario: kernel parameters plus what the kernels do not
    need."""

    params: SurrogateParams
    v0: np.ndarray  # initial velocities, m/s
    body_names: list[str]
    zone_names: list[str]


def _surrogate_system(sc: CrashScenario, surrogate: CrashSurrogate) -> _System:
    """Bodies, elements and packed LPR models of ``surrogate`` on scenario ``sc``."""
    for key in ("wall", "interface"):
        if key not in surrogate.elements and (key == "wall" or sc.n_cars > 1):
            raise ValueError(f"surrogate has no {key!r} element")
    masses = list(sc.car_masses)
    mu = [sc.friction] * sc.n_cars
    v0 = [sc.speed] * sc.n_cars
    names = ["lead"] + [f"car{k + 1}" for k in range(1, sc.n_cars)]
    wall_front = -1
    if sc.obstacle is not None:
        masses.append(sc.obstacle.mass)
        mu.append(sc.obstacle.friction)
        v0.append(0.0)
        names.append("obstacle")
        wall_front = sc.n_cars
    el_front = np.array([wall_front] + list(range(sc.n_cars - 1)), dtype=np.int64)
    el_back = np.arange(sc.n_cars, dtype=np.int64)
    el_type = np.array([0] + [1] * (sc.n_cars - 1), dtype=np.int64)
    el_names = ["wall"] + [f"interface_{k}" for k in range(1, sc.n_cars)]
    types = [surrogate.elements["wall"], surrogate.elements.get("interface")]
    types = [ty for ty in types if ty is not None]
    models, ranges, load_idx, unload_idx = [], [], [], []
    for ty in types:
        load_idx.append(len(models))
        models.append(ty.loading)
        ranges.append(ty.force_range["loading"])
        unload_idx.append(len(models) if ty.unloading is not None else load_idx[-1])
        if ty.unloading is not None:
            models.append(ty.unloading)
            ranges.append(ty.force_range["unloading"])
    zone_stroke = [sc.wall.absorber_stroke, sc.interface.absorber_stroke][: len(types)]
    element_types = ElementTypes(
        variant=np.array([VARIANTS.index(ty.variant) for ty in types], np.int64),
        load_model=np.array(load_idx, np.int64),
        unload_model=np.array(unload_idx, np.int64),
        unilateral=np.array([ty.unilateral for ty in types], np.int64),
        unloading_stiffness=np.array([ty.unloading_stiffness for ty in types]),
        tension_stiffness=np.array([ty.tension_stiffness for ty in types]),
        slack=np.array([ty.slack for ty in types]),
        absorber=np.array(zone_stroke, dtype=np.float64),
    )
    params = SurrogateParams(
        m=np.array(masses),
        mu=np.array(mu),
        gravity=float(sc.gravity),
        v_eps=V_EPS,
        front=el_front,
        back=el_back,
        kind=el_type,
        types=element_types,
        lpr=_pack_models(models, ranges),
    )
    return _System(params=params, v0=np.array(v0), body_names=names, zone_names=el_names)


def simulate_surrogate(
    scenario: CrashScenario | str,
    surrogate: CrashSurrogate,
    n_cars: int | None = None,
    speed: float | None = None,
    duration: float = 2.0,
    sample_dt: float = 1e-3,
    dt: float = 5e-4,
    stop_when_over: bool = True,
    v_stop: float = 0.01,
    f_stop: float = 1e3,
) -> CrashResult:
    """Run the surrogate crash model (paper eq. 4): one mass per car (+ obstacle).

    Parameters
    ----------
    scenario : a :class:`CrashScenario` or a name/path for :func:`load_scenario`.
    surrogate : elements from :func:`build_crash_surrogate`.
    n_cars, speed : optional overrides (number of cars; initial speed in m/s).
    duration, sample_dt : longest simulated time and output interval, s.
    dt : largest integration step, s (rounded down to divide ``sample_dt``); the stiffest
        surrogate mode has ``ω² ≈ 2 (k̂_u,wall + k̂_u,interface) / m_1`` (docs/envs/crash.md).
    stop_when_over, v_stop, f_stop : stop as :func:`simulate_reference` does.

    Returns
    -------
    :class:`CrashResult` with ``crush``/``force`` holding each element's feature ``u`` and force
    and ``permanent_set`` its permanent set in ``u``; ``energy`` is empty.
    """
    sc = load_scenario(scenario) if isinstance(scenario, str | Path) else scenario
    sc = sc.with_overrides(n_cars=n_cars, speed=speed)
    _check_run(duration, sample_dt)
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a positive finite number (s), got {dt!r}")
    dt, n_sub = _steps(sample_dt, dt)
    sy = _surrogate_system(sc, surrogate)
    n_samples = int(round(duration / sample_dt)) + 1
    nb, ne = len(sy.body_names), len(sy.zone_names)
    state = _new_surrogate_state(1, nb, ne)
    state.v[0] = sy.v0
    out = new_outputs(1, nb, ne)
    rec = new_record(n_samples, nb, ne, energies=False)
    stop = StopRule(stop_when_over, v_stop, f_stop)
    t0 = time.perf_counter()
    n = _record_surrogate(state, out, sy.params, dt, n_sub, stop, rec)
    wall = time.perf_counter() - t0
    return CrashResult(
        t=np.arange(n) * sample_dt,
        x=rec.x[:n],
        v=rec.v[:n],
        a=rec.a[:n],
        body_names=sy.body_names,
        zone_names=sy.zone_names,
        crush=rec.crush[:n],
        force=rec.force[:n],
        permanent_set=rec.permanent_set[:n],
        energy={},
        initial_kinetic_energy=float(0.5 * np.sum(sy.params.m * sy.v0**2)),
        dt=dt,
        wall_time=wall,
        scenario=sc,
        model=f"surrogate:{surrogate.variant}",
    )


def crash_errors(prediction: CrashResult, truth: CrashResult) -> dict[str, np.ndarray]:
    """Paper eq. (9) average absolute errors per car over the common samples.

    Returns ``{"x": (cars,) m, "v": (cars,) m/s, "a": (cars,) m/s²}``.
    """
    if not np.isclose(prediction.t[1] - prediction.t[0], truth.t[1] - truth.t[0]):
        raise ValueError("prediction and truth must share the sample interval")
    n = min(prediction.t.size, truth.t.size)
    cars = truth.scenario.n_cars
    if prediction.scenario.n_cars != cars:
        raise ValueError("prediction and truth have different numbers of cars")
    out = {}
    for key in ("x", "v", "a"):
        diff = getattr(prediction, key)[:n, :cars] - getattr(truth, key)[:n, :cars]
        out[key] = np.mean(np.abs(diff), axis=0)
    return out
