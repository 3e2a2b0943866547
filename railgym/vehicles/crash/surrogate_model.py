"""The surrogate crash model of paper eq. (4), compiled: element law, batch step, recorder and
:func:`simulate_surrogate` (elements from :mod:`~railgym.vehicles.crash.surrogate`)."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from numba import njit, prange

from railgym.vehicles.crash.outputs import (
    PARALLEL_CHUNKS,
    V_EPS,
    CrashResult,
    StopRule,
    _check_run,
    _crash_over,
    _healthy,
    _steps,
    chunk_mask,
    new_outputs,
    new_record,
    recorded_result,
)
from railgym.vehicles.crash.scenario import CrashScenario, load_scenario
from railgym.vehicles.crash.surrogate import VARIANTS, CrashSurrogate
from surrogates.models.lpr import EXTRAPOLATION_MODES

__all__ = [
    "ElementTypes",
    "LprModels",
    "SurrogateParams",
    "SurrogateState",
    "simulate_surrogate",
    "surrogate_batch_step",
    "surrogate_batch_step_parallel",
]


class LprModels(NamedTuple):
    """The element LPR models (:func:`_pack_models`), one row per model: each a 1-input
    Legendre series ``f(u) = Σ_k c_k P_k(t)``, ``t = 2 (u − lower) / (upper − lower) − 1``.

    Attributes
    ----------
    coef : (models, degrees + 1) coefficient ``c_k`` of each degree, contiguous, zero-padded.
    degree : (models,) int64 highest degree of each model.
    lower, upper : (models,) input domain, m.
    mode : (models,) extrapolation mode (:data:`surrogates.models.lpr.EXTRAPOLATION_MODES`):
        1 clips, 0 extends the series linearly beyond the domain; ``"raise"`` (2) is rejected
        when the models are packed (:func:`_pack_models`), the kernels cannot raise.
    force_range : (models, 2) lowest and highest training force of each model, N.
    """

    coef: np.ndarray
    degree: np.ndarray
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
    m : (n, bodies) body mass of each simulation (a car's payload included), kg.
    """

    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    up: np.ndarray
    fz: np.ndarray
    ff: np.ndarray
    m: np.ndarray


def _new_surrogate_state(n: int, masses: np.ndarray, n_elements: int) -> SurrogateState:
    """Zeroed :class:`SurrogateState` of ``n`` simulations with body ``masses`` (kg)."""
    n_bodies = masses.size
    body = [np.zeros((n, n_bodies)) for _ in range(3)]
    el = [np.zeros((n, n_elements)) for _ in range(2)]
    return SurrogateState(*body, *el, np.zeros((n, n_bodies)), np.tile(masses, (n, 1)))


@njit(cache=True, inline="always")
def _legendre_series(u, c, n, lower, upper, mode):
    """``Σ_{k≤n} c_k P_k(t)`` at ``t = 2 (u − lower) / (upper − lower) − 1`` by Clenshaw's
    recurrence; outside ``[lower, upper]`` the value at the nearer end, extended linearly with
    the slope there (``P_k(±1) = (±1)^k``, ``P'_k(±1) = (±1)^{k+1} k (k + 1) / 2``) unless
    ``mode`` is 1 (clip)."""
    if lower <= u <= upper:
        t = (u - lower) * (2.0 / (upper - lower)) - 1.0
        b1 = b2 = 0.0
        for k in range(n, 0, -1):
            b0 = c[k] + (2.0 * k + 1.0) / (k + 1.0) * t * b1 - (k + 1.0) / (k + 2.0) * b2
            b2 = b1
            b1 = b0
        return c[0] + t * b1 - 0.5 * b2
    s = 1.0 if u > upper else -1.0
    value = slope = 0.0
    sign = 1.0
    for k in range(n + 1):
        value += c[k] * sign
        slope += c[k] * sign * s * 0.5 * k * (k + 1)
        sign *= s
    if mode == 1:
        return value
    end = upper if u > upper else lower
    return value + slope * (2.0 / (upper - lower)) * (u - end)


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
    mu, g, veps = params.mu, params.gravity, params.v_eps
    el_front, el_back, el_type = params.front, params.back, params.kind
    ty_ = params.types
    variant, i_load, i_unload, unilateral = (
        ty_.variant,
        ty_.load_model,
        ty_.unload_model,
        ty_.unilateral,
    )
    ku, kt, slack, absorber = (
        ty_.unloading_stiffness,
        ty_.tension_stiffness,
        ty_.slack,
        ty_.absorber,
    )
    lpr = params.lpr
    C, DEG, LO, UP, MODE, FR = (
        lpr.coef,
        lpr.degree,
        lpr.lower,
        lpr.upper,
        lpr.mode,
        lpr.force_range,
    )
    N = mu.shape[0]
    ne = el_front.shape[0]
    nodes = np.empty((8, N))
    xl, vl, al, vp = nodes[0], nodes[1], nodes[2], nodes[3]
    F, dx, ffl, ff_o = nodes[4], nodes[5], nodes[6], nodes[7]
    els = np.empty((6, ne))
    upl, fl, f_o, ul, u_o, wl = els[0], els[1], els[2], els[3], els[4], els[5]
    ox, ov, oa, crush, force, rate_out = out.x, out.v, out.a, out.crush, out.force, out.rate
    work_done, dissipated, stored = out.work, out.dissipated, out.stored
    # rows are copied element by element: a row view per array and train costs two atomic
    # reference-count operations
    for i in range(x.shape[0]):
        if not active[i]:
            continue
        m = state.m[i]
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
                    f_lpr = _legendre_series(u, C[mdl], DEG[mdl], LO[mdl], UP[mdl], MODE[mdl])
                    f_min, f_max = FR[mdl, 0], FR[mdl, 1]
                s = scale[i, e] if u <= absorber[ty] else 1.0
                f, upl[e] = _element_force(
                    u,
                    upl[e],
                    f_lpr,
                    f_min,
                    f_max,
                    s,
                    variant[ty],
                    unilateral[ty],
                    ku[ty],
                    kt[ty],
                    slack[ty],
                )
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


# Not cached: a cached parallel loop called from a cached caller crashed on loading.
@njit(parallel=True)
def surrogate_batch_step_parallel(state, out, params, scale, active, init, dt, n_sub, limit, div):
    """:func:`surrogate_batch_step` on all numba threads: ``prange`` over chunks of trains
    (:func:`chunk_mask`), each chunk one serial call on its trains: bit-identical results.

    The parameters are taken apart and rebuilt inside the loop: numba's parallel loop cannot
    capture a NamedTuple that nests NamedTuples of arrays.
    """
    m, mu, g, v_eps = params.m, params.mu, params.gravity, params.v_eps
    front, back, kind = params.front, params.back, params.kind
    types, lpr = ElementTypes(*params.types), LprModels(*params.lpr)
    chunks = min(active.shape[0], PARALLEL_CHUNKS)
    for c in prange(chunks):
        p = SurrogateParams(m, mu, g, v_eps, front, back, kind, types, lpr)
        surrogate_batch_step(
            state, out, p, scale, chunk_mask(active, c, chunks), init, dt, n_sub, limit, div
        )


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
    """:class:`LprModels` of several 1-input LPR models (their coefficients summed per
    Legendre degree) and their output ranges, N."""
    arrays = [mdl.kernel_arrays() for mdl in models]
    for i, (e, *_, mode) in enumerate(arrays):
        if e.ndim != 2 or e.shape[1] != 1:
            raise ValueError(f"surrogate element model {i} has {e.shape[-1]} inputs, expected 1")
        if mode == EXTRAPOLATION_MODES["raise"]:
            raise ValueError(
                f"surrogate element model {i} has extrapolation='raise', which the compiled "
                "crash kernels cannot honour (they would extrapolate linearly): use 'clip' or "
                "'linear'"
            )
    degree = np.array([int(e.max()) for e, *_ in arrays], dtype=np.int64)
    C = np.zeros((len(arrays), int(degree.max()) + 1))
    LO, UP = np.zeros(len(arrays)), np.zeros(len(arrays))
    MODE = np.zeros(len(arrays), dtype=np.int64)
    for i, (e, c, lo, up, mode) in enumerate(arrays):
        np.add.at(C[i], e[:, 0], c)
        LO[i], UP[i], MODE[i] = lo[0], up[0], mode
    FR = np.array(ranges, dtype=np.float64).reshape(len(arrays), 2)
    return LprModels(C, degree, LO, UP, MODE, FR)


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
    state = _new_surrogate_state(1, sy.params.m, ne)
    state.v[0] = sy.v0
    out = new_outputs(1, nb, ne)
    rec = new_record(n_samples, nb, ne, energies=False)
    stop = StopRule(stop_when_over, v_stop, f_stop)
    t0 = time.perf_counter()
    n = _record_surrogate(state, out, sy.params, dt, n_sub, stop, rec)
    wall = time.perf_counter() - t0
    return recorded_result(
        rec,
        n,
        sample_dt,
        sy,
        energy={},
        dt=dt,
        wall_time=wall,
        scenario=sc,
        model=f"surrogate:{surrogate.variant}",
    )
